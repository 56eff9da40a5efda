"""Files shipped with the package and user configuration files: found and parsed here, for the node and the CLI.

The default parameter and hypothesis files live in ``imu_noise_id/config/`` (package data: present in an editable
checkout, a wheel and a colcon install alike; ``setup.py`` also installs them into ``share/imu_noise_id/config/``,
where ``ros2 run … --params-file`` users find them).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .core.errors import InputError

CONFIG_DIR = Path(__file__).resolve().parent / "config"
#: The node's default parameters (``imu_noise_id_node: ros__parameters:``).
NODE_PARAMETERS = "imu_noise_id.yaml"
#: The default hypothesis set of the Bayesian bank.
DEFAULT_HYPOTHESES = "hypotheses_default.yaml"


def packaged_config(name: str) -> Path:
    """Path of the configuration file ``name`` shipped in ``imu_noise_id/config/``."""
    path = CONFIG_DIR / name
    if not path.is_file():
        raise InputError(f"the packaged configuration file {name} is missing from {CONFIG_DIR}: reinstall the package")
    return path


def read_hypotheses_file(path: str | Path | None) -> tuple[dict[str, Any], str]:
    """Parse a hypothesis-set YAML file (default: the packaged one); returns the mapping and its source name."""
    import yaml

    p = Path(path) if path is not None else packaged_config(DEFAULT_HYPOTHESES)
    if not p.is_file():
        raise InputError(f"hypotheses file {p} does not exist or is not a file: give an existing YAML file")
    try:
        data = yaml.safe_load(p.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise InputError(f"hypotheses file {p} is not valid YAML: {' '.join(str(exc).split())}") from None
    except OSError as exc:
        raise InputError(f"hypotheses file {p} cannot be read ({exc.strerror or exc}): check its permissions") from None
    if not isinstance(data, dict):
        raise InputError(f"hypotheses file {p} must hold a mapping with 'hypotheses' or 'sensors'")
    return data, str(p)
