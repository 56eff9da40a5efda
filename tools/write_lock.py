"""Write the exact versions installed in this Python environment as a pip constraints file (``requirements.lock``).

Run by ``make lock`` with the interpreter of an environment freshly installed from ``requirements-dev.txt`` without
constraints: what it prints is what ``make setup`` then installs on every machine. Distributions that pip did not
install (the metadata the ROS 2 wheels embed, e.g. ``rclpy``, ``sensor_msgs``), this package itself, pip and
setuptools are left out.
"""

from __future__ import annotations

import sys
from importlib import metadata

HEADER = """\
# The exact versions `make setup` installs, as pip constraints (`pip install -r requirements-dev.txt -c THIS`).
# Written by `make lock` from an environment installed without constraints; `make test-latest` tests the newest
# versions instead. Python 3.11, Linux x86_64.
"""
SKIPPED = {"imu-noise-id", "pip", "setuptools"}


def pinned_distributions() -> list[str]:
    """``Name==version`` of every distribution pip installed in this environment, sorted by name."""
    pins = {}
    for dist in metadata.distributions():
        name = dist.metadata["Name"]
        key = name.lower().replace("_", "-")
        installed_by_pip = any(str(f).endswith("INSTALLER") for f in dist.files or [])
        if installed_by_pip and key not in SKIPPED:
            pins[key] = f"{name}=={dist.version}"
    return [pins[key] for key in sorted(pins)]


if __name__ == "__main__":
    sys.stdout.write(HEADER + "\n".join(pinned_distributions()) + "\n")
