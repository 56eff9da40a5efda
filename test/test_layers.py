"""The layering of the package holds: every import, read from the source, points down.

core (numpy/scipy and the standard library) ← pipelines ← adapters (bag, ros, report, cli) ← demo. The core never
imports ROS, rosbags or matplotlib; pipelines never import an adapter; only ``ros/`` and the demo import rclpy.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "imu_noise_id"

#: For each layer, the package's own layers it must not import.
FORBIDDEN = {
    "core": {"pipelines", "bag", "ros", "report", "cli", "demo", "resources", "batch"},
    "pipelines": {"bag", "ros", "report", "cli", "demo", "batch"},
    "bag": {"pipelines", "ros", "report", "cli", "demo", "batch"},
    "report": {"ros", "cli", "demo", "bag", "batch"},
    "ros": {"cli", "demo", "batch"},
    "batch": {"cli", "demo", "ros"},
    "cli": {"demo"},
}
#: Third-party modules the core may use.
CORE_THIRD_PARTY = {"numpy", "scipy"}


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _imports(path: Path) -> list[tuple[str, int]]:
    """Absolute dotted names of everything ``path`` imports (relative imports resolved), with their levels."""
    # The package a relative import starts from: the folder of the module (for __init__.py, its own package).
    package = path.relative_to(PACKAGE.parent).with_suffix("").parts[:-1]
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [(alias.name, 0) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                prefix = ".".join(base)
                targets = [node.module] if node.module else [alias.name for alias in node.names]
                names += [(f"{prefix}.{t}", node.level) for t in targets]
            else:
                names.append((node.module or "", 0))
    return names


def _layer(dotted: str) -> str | None:
    parts = dotted.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "imu_noise_id" else None


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_point_down(path):
    layer = _layer(".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts))
    imported = [name for name, _ in _imports(path)]
    if layer in FORBIDDEN:
        wrong = sorted({n for n in imported if _layer(n) in FORBIDDEN[layer]})
        assert not wrong, f"{path.relative_to(PACKAGE)} ({layer}) imports upwards: {wrong}"
    if layer == "core":
        stdlib = set(sys.stdlib_module_names) | {"__future__"}
        outside = sorted({n for n in imported if not n.startswith("imu_noise_id")
                          and n.split(".")[0] not in stdlib | CORE_THIRD_PARTY})
        assert not outside, f"{path.relative_to(PACKAGE)} (core) imports {outside}"
    if layer not in {"ros", "demo"}:
        assert not [n for n in imported if n.split(".")[0] == "rclpy"], f"{path} imports rclpy outside ros/"


def test_the_checker_sees_relative_imports():
    """A module known to import the core relatively resolves to absolute names (the test above can fail)."""
    names = [n for n, level in _imports(PACKAGE / "pipelines" / "analyze" / "__init__.py") if level]
    assert any(n.startswith("imu_noise_id.core.") for n in names)
    assert any(n == "imu_noise_id.pipelines.loop" for n in names)
