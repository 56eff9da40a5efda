"""Files shipped with the package and user configuration files: found and parsed here, for the node and the CLI.

The default files (:data:`NODE_PARAMETERS`, :data:`DEFAULT_HYPOTHESES`) live in the source tree's ``config/``,
installed into ``<prefix>/share/imu_noise_id/config/``. :func:`packaged_config` returns the first copy found in:
1. ``config/`` beside the package directory with ``package.xml`` (checkout, editable or symlink install);
2. ``<prefix>/share/imu_noise_id/config/``, ``<prefix>`` the imported package's installation prefix;
3. ``sys.prefix/share/imu_noise_id/config/``; 4. the ament share directory (``ament_index_python``).
Else :class:`~.core.errors.InputError` naming the file, every folder searched and the fix.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

from .core.errors import InputError

PACKAGE = "imu_noise_id"
#: The directory of the imported package (``…/imu_noise_id``).
PACKAGE_DIR = Path(__file__).resolve().parent
#: The node's default parameters (``imu_noise_id_node: ros__parameters:``).
NODE_PARAMETERS = "imu_noise_id.yaml"
#: The default hypothesis set of the Bayesian bank.
DEFAULT_HYPOTHESES = "hypotheses_default.yaml"


def _ament_share() -> tuple[Path | None, str]:
    """The package's ament share directory (or None) and why it is missing."""
    if not os.environ.get("AMENT_PREFIX_PATH"):
        return None, "AMENT_PREFIX_PATH is not set"
    try:
        from ament_index_python.packages import get_package_share_directory
    except ImportError:
        return None, "ament_index_python is not installed"
    try:
        return Path(get_package_share_directory(PACKAGE, print_warning=False)), ""
    except (LookupError, OSError, ValueError):
        return None, f"{PACKAGE} is not in AMENT_PREFIX_PATH"


def config_dirs() -> list[Path]:
    """The folders :func:`packaged_config` searches, in order (module docstring), without repetitions."""
    dirs = []
    checkout = PACKAGE_DIR.parent
    if (checkout / "package.xml").is_file():
        dirs.append(checkout / "config")
    # <prefix>/lib/pythonX.Y/site-packages/imu_noise_id, or <prefix>/lib/site-packages/… (Windows: Lib).
    lib = next((d for d in list(checkout.parents)[:2] if d.name.lower() in ("lib", "lib64")), None)
    if lib is not None:
        dirs.append(lib.parent / "share" / PACKAGE / "config")
    dirs.append(Path(sys.prefix) / "share" / PACKAGE / "config")
    share, _ = _ament_share()
    if share is not None:
        dirs.append(share / "config")
    unique: list[Path] = []
    for d in dirs:
        if d not in unique:
            unique.append(d)
    return unique


def packaged_config(name: str) -> Path:
    """Path of the shipped configuration file ``name`` (e.g. :data:`NODE_PARAMETERS`): the first copy found in
    :func:`config_dirs`; InputError when none has it."""
    dirs = config_dirs()
    for d in dirs:
        if (d / name).is_file():
            return d / name
    _, why_not_ament = _ament_share()
    searched = ", ".join(str(d) for d in dirs) + (f" (not the ament index: {why_not_ament})" if why_not_ament else "")
    raise InputError(
        f"the default configuration file {name} of {PACKAGE} was not found; searched {searched}. Reinstall the "
        f"package (`pip install .` or `colcon build`; an editable `pip install -e .` needs the checkout's config/ "
        f"folder beside {PACKAGE}/), or give the file yourself (--params-file, identify --hypotheses, the node's "
        f"hypotheses.file)"
    )


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
