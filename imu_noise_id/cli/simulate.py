"""``imu-noise-id simulate``: write a rosbag2 bag of a static IMU whose errors follow a given model."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..core.errors import InputError
from ..core.noise.components import COMPONENT_TYPES

_EXAMPLE = "gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)"


def _unit(text: str) -> str:
    return text.replace("sqrt(Hz)", "√Hz").replace("*", "·")


def component_syntax() -> str:
    """Every component of ``COMPONENT_TYPES`` with its parameters and units, e.g. ``GM(tau=[s], sigma=[u])``;
    optional fixed parameters in brackets."""
    out = []
    for name, cls in COMPONENT_TYPES.items():
        units = cls.parameter_units
        args = [f"{p}=[{_unit(units[p])}]" for p in cls.parameter_names]
        args += [f"[{p}=[{_unit(units.get(p, '?'))}]]" for p in cls.fixed_names]
        out.append(f"{name}({', '.join(args)})")
    return ", ".join(out)


DESCRIPTION = f"""\
Simulate a static 6-axis IMU and write it as a rosbag2 bag (sensor_msgs/Imu, header stamps
from --start-time).

MODEL is a model spec string, e.g. "{_EXAMPLE}".
Components and their continuous-time parameters (positional in this order, or by name):
{component_syntax()};
u = rad/s for gyro, m/s² for accel.
Keys: gyro, accel or single axes gyro_x … accel_z; a spec without key applies to all six axes.
MODEL may also be a YAML file mapping the same keys to specs (e.g. `gyro: WN(1e-3)+RW(1e-5)`),
or a model.yaml written by the analysis (`axes: {{AXIS: {{components: [{{type: WN, noise_density: …}}]}}}}`).
The accelerometer z axis also reads +9.80665 m/s² (level sensor)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate",
        help="write a simulated static IMU bag with known noise",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--model", required=True, metavar="MODEL", help="model spec string or YAML file (see above)")
    parser.add_argument("--rate", required=True, type=float, metavar="HZ", help="sampling rate [Hz]")
    parser.add_argument("--duration", required=True, type=float, metavar="S", help="recording length [s]")
    parser.add_argument("--out", required=True, type=Path, metavar="BAG", help="bag directory to create")
    parser.add_argument("--seed", type=int, default=None, metavar="N", help="random seed (reproducible data)")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap", help="rosbag2 storage (mcap)")
    parser.add_argument("--topic", default="/imu/data", metavar="T", help="IMU topic (/imu/data)")
    parser.add_argument("--frame-id", default="imu_link", metavar="FRAME", help="header.frame_id (imu_link)")
    parser.add_argument(
        "--start-time", type=float, default=0.0, metavar="S", help="header stamp of the first sample [s] (0)"
    )
    parser.set_defaults(run=run)


def _spec_from_yaml(path: Path) -> str:
    """Model spec string from a YAML file (group/axis → spec, or a model.yaml with ``axes``)."""
    import yaml

    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"cannot read model file {str(path)!r}: {exc}") from None
    if isinstance(data, dict) and isinstance(data.get("axes"), dict):
        data = {axis: _spec_from_model_entry(path, axis, entry) for axis, entry in data["axes"].items()}
    if not isinstance(data, dict) or not data or not all(isinstance(v, str) for v in data.values()):
        raise InputError(
            f"model file {str(path)!r} must map gyro/accel (or axis names) to spec strings, e.g. 'gyro: WN(1e-3)'"
        )
    return "; ".join(f"{key}: {spec}" for key, spec in data.items())


def _spec_from_model_entry(path: Path, axis: str, entry: object) -> str:
    from ..core.noise.components import COMPONENT_TYPES

    components = entry.get("components") if isinstance(entry, dict) else None
    if not isinstance(components, list) or not components:
        raise InputError(f"model file {str(path)!r}: axis {axis!r} has no 'components' list")
    terms = []
    for comp in components:
        kind = comp.get("type") if isinstance(comp, dict) else None
        if kind not in COMPONENT_TYPES:
            raise InputError(f"model file {str(path)!r}: axis {axis!r} has a component of unknown type {kind!r}")
        names = COMPONENT_TYPES[kind].parameter_names
        missing = [p for p in names if p not in comp]
        if missing:
            raise InputError(f"model file {str(path)!r}: {axis} {kind} lacks {', '.join(missing)}")
        terms.append(f"{kind}(" + ", ".join(f"{p}={comp[p]}" for p in names) + ")")
    return "+".join(terms)


def _is_file(path: Path) -> bool:
    """Whether ``path`` names an existing file; False for what cannot be a file name (too long, NUL bytes)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def run(args: argparse.Namespace) -> int:
    """Simulate and write the bag; print what was written and the true model."""
    from ..bag.writer import write_bag
    from ..core.axes import AXES, UNITS
    from ..core.noise.modelspec import model_name, parse_imu_model
    from ..core.simulation.static import simulate_static_imu

    model_path = Path(args.model)
    is_file = model_path.suffix in (".yaml", ".yml") or _is_file(model_path)
    if is_file and not _is_file(model_path):
        raise InputError(f"model file {args.model!r} does not exist: give a spec string or an existing YAML file")
    spec = _spec_from_yaml(model_path) if is_file else args.model
    model = parse_imu_model(spec)
    if args.out.exists():
        raise InputError(f"--out {str(args.out)!r} exists already: choose another path or delete it")
    if args.start_time < 0:
        raise InputError(f"--start-time must be >= 0 s (ROS stamps), got {args.start_time}")
    if not 0 < args.rate <= 1e5:
        raise InputError(f"--rate must be in (0, 100000] Hz, got {args.rate}")
    if not args.duration > 0 or args.rate * args.duration > 5e8:
        raise InputError(f"--duration must be > 0 s and give at most 5e8 samples, got {args.duration} s")
    try:
        imu = simulate_static_imu(
            model, args.rate, args.duration, seed=args.seed, t0=args.start_time, frame_id=args.frame_id
        )
    except ValueError as exc:
        raise InputError(f"cannot simulate: {exc}") from None
    write_bag(args.out, imu, storage=args.storage, imu_topic=args.topic)
    print(
        f"wrote {args.out} ({args.storage}): {len(imu)} sensor_msgs/Imu samples on {args.topic} "
        f"(frame {args.frame_id}) at {args.rate:g} Hz, {len(imu) / args.rate:g} s, seed {args.seed}"
    )
    print("true model (continuous time; u = unit of the axis):")
    for axis in AXES:
        terms = " + ".join(str(c) for c in model[axis])
        print(f"  {axis:8s} [{UNITS[axis]}]  {model_name(model[axis])}: {terms}")
    return 0
