"""``imu-noise-id cmkf``: replay the online covariance matching Kalman filter over a bag (IMU + odometry)."""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path

from ..core.errors import InputError
from ..pipelines.online.config import CMKF_TUNABLES, CmkfTunable, tuned_config
from . import results_folder
from .options import add_out, add_topic

#: The CMKF's fields that are options of this command (``--accel-bias-tau`` …), declared with the node's.
OPTIONS: tuple[CmkfTunable, ...] = tuple(t for t in CMKF_TUNABLES if t.option)

DESCRIPTION = """\
Run the online covariance matching Kalman filter (paper 004, generalised to a robot) over a bag with a
sensor_msgs/Imu and a nav_msgs/Odometry topic, as fast as it runs, exactly as the ROS node would, and write:

  DIR/cmkf.yaml   final accelerometer bias [m/s²] ± std, velocity-random-walk PSD S_v [m²/s³] with its
                  standard error and 95 % interval, accel noise density √S_v [m/s²/√Hz] where the data
                  identify it (else a 95 % upper bound and the reason), the same for the gyro, the filter's
                  consistency (NIS, updates rejected by the innovation gate, the likely cause when it is
                  inconsistent), message counters and everything the filter knew
  DIR/cmkf.csv    the estimates after every odometry message
  DIR/cmkf.png    biases, noise densities and NIS over time

All results are per IMU axis (the Imu message frame). The IMU mounting rotation relative to the odometry's
child frame (base_link) must be given with --imu-rotation unless it is the identity. Gravity is removed with the
IMU's own orientation when its messages provide one (REP-145), else with the odometry's (--gravity-from)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``cmkf`` subcommand."""
    p = subparsers.add_parser(
        "cmkf",
        help="replay the online accel/gyro bias and noise estimator (CMKF) over a bag with odometry",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("bag", type=Path, metavar="BAG", help="ROS 1 .bag, rosbag2 directory, .db3 or .mcap")
    add_topic(p, "sensor_msgs/Imu topic (needed if several)", aliases=("--imu-topic",))
    p.add_argument("--odom-topic", default=None, metavar="T", help="nav_msgs/Odometry topic (needed if several)")
    add_out(p, "cmkf")
    p.add_argument(
        "--imu-rotation", type=float, nargs="+", default=None, metavar="V",
        help="IMU orientation in the base frame: 3 numbers = yaw pitch roll [rad] (static_transform_publisher "
        "order, e.g. -1.5708 0 1.5708) or 4 numbers = quaternion x y z w (default: identity)",
    )
    p.add_argument(
        "--gravity-from", choices=("imu", "odom"), default=None,
        help="orientation used to remove gravity: imu = the Imu messages' own orientation (right on uneven ground; "
        "needs a driver that provides it), odom = the odometry orientation propagated with the gyro (planar wheel "
        "odometry has no roll/pitch). Default: imu when the bag's Imu messages provide an orientation, else odom",
    )
    add_cmkf_options(p)
    p.add_argument("--no-plot", action="store_true", help="skip cmkf.png")
    p.set_defaults(run=run)


def add_cmkf_options(p: argparse.ArgumentParser) -> None:
    """An option per field of :data:`OPTIONS`: its type, default (the CMKF's), choices, description and unit."""
    for t in OPTIONS:
        default = "" if t.default is None else f" (default: {t.default:g})" if t.kind is float \
            else f" (default: {t.default})"
        unit = f" [{t.unit}]" if t.unit else ""
        metavar = None if t.choices else t.unit.upper().replace("/", "_").replace("^", "") or None
        p.add_argument(f"--{t.field.replace('_', '-')}", type=t.kind, default=t.default, choices=t.choices or None,
                       metavar=metavar, help=f"{t.description}{unit}{default}")


def imu_rotation(values: list[float] | None) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) from ``--imu-rotation`` (3 = yaw pitch roll, 4 = quaternion)."""
    from ..core.cmkf import rotation as rot

    if values is None:
        return rot.IDENTITY
    if not all(math.isfinite(v) for v in values):
        raise InputError("--imu-rotation: values must be finite numbers")
    if len(values) == 3:
        return rot.from_ypr(*values)
    if len(values) == 4:
        try:
            return rot.normalise(values)
        except ValueError as exc:
            raise InputError(f"--imu-rotation: {exc}") from None
    raise InputError("--imu-rotation takes 3 numbers (yaw pitch roll [rad]) or 4 (quaternion x y z w)")


def run(args: argparse.Namespace) -> int:
    """Read the bag, replay the filter, write cmkf.yaml, cmkf.csv and cmkf.png."""
    import numpy as np
    import yaml

    from ..bag.reader import read_bag
    from ..pipelines.cmkf_replay import DENSITY_FIELDS, SERIES_FIELDS, replay, to_yaml_dict

    config = tuned_config(OPTIONS, lambda t: getattr(args, t.field), "parameter",
                          imu_rotation_xyzw=imu_rotation(args.imu_rotation))
    from .progress import TextProgress

    with TextProgress(f"reading {args.bag.name}") as progress:
        contents = read_bag(args.bag, imu_topic=args.topic, odom_topic=args.odom_topic, require_odometry=True,
                            progress=progress)
    imu_orientation = contents.imu.orientation_xyzw
    gravity_from = args.gravity_from or ("imu" if imu_orientation is not None else "odom")
    if gravity_from == "imu" and imu_orientation is None:
        raise InputError(
            f"--gravity-from imu: the Imu messages of {contents.imu.topic!r} in {args.bag} provide no orientation "
            "(orientation_covariance[0] = -1 or a zero quaternion): use --gravity-from odom"
        )
    config = dataclasses.replace(config, gravity_source="imu" if gravity_from == "imu" else "odometry")
    with TextProgress("CMKF replay", unit="odometry messages") as progress:
        result = replay(contents.imu, contents.odom, config, imu_orientation if gravity_from == "imu" else None,
                        progress=progress)
    notes = [*contents.notes]
    if gravity_from == "imu" and not np.isfinite(imu_orientation).all():
        notes.append("some Imu messages provide no orientation: gravity uses the last one provided (the odometry's "
                     "before the first)")
    if result.final.n_stacked == 0:
        notes.append("no stacked sample: S_v and S_g not estimated (odometry too short or not overlapping the IMU)")
    if result.cmkf_errors:
        notes.append(f"the CMKF failed {result.cmkf_errors} time(s) and was restarted, as the node does: the estimates "
                     "are of the messages after the last restart")
    data = to_yaml_dict(result, notes)
    data["filter"]["bag"] = str(args.bag)
    names = [*SERIES_FIELDS, *DENSITY_FIELDS]
    cols = (["t"] + [f"{name}_{a}" for name in names for a in "xyz"]
            + ["nis_accel", "nis_gyro", "gated_accel", "gated_gyro", "status"])
    table = np.column_stack([result.t] + [result.series[name] for name in names]
                            + [result.nis_accel, result.nis_gyro, result.gated_accel, result.gated_gyro])
    folder = results_folder(args, str(args.bag), contents.imu.topic)
    with folder as staging:
        (staging / "cmkf.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
        with (staging / "cmkf.csv").open("w") as fh:
            fh.write(",".join(cols) + "\n")
            for row, status in zip(table, result.status, strict=True):
                fh.write(f"{row[0]:.6f}," + ",".join(f"{v:.9g}" for v in row[1:]) + f",{status}\n")
        if not args.no_plot:
            from ..report.cmkf_plot import plot_cmkf

            plot_cmkf(result, staging / "cmkf.png", title=f"CMKF replay of {args.bag.name}")
    folder.report()
    e = result.final
    print(f"{args.bag}: {result.info['imu_samples']} IMU samples ({result.info['imu_rate_hz']:.4g} Hz), "
          f"{result.info['odom_messages']} odometry ({result.info['odom_rate_hz']:.4g} Hz); status {data['status']}")
    np.set_printoptions(precision=4)
    print(f"  gravity from the {'IMU' if gravity_from == 'imu' else 'odometry'} orientation")
    if data["accel_bias"]["x"] is not None:
        print(f"  accel bias [m/s²]      {e.accel_bias} ± {e.accel_bias_std}")
        print(f"  gyro bias [rad/s]      {e.gyro_bias} ± {e.gyro_bias_std}")
    for line in data["summary"]:
        print(f"  {line}")
    nis = data["nis"]["accel"]
    print(f"  NIS accel mean {nis['mean']:.3g} (dof {nis['dof']}), {100 * nis['share_in_95']:.0f} % inside 95 % "
          f"bounds, {nis['gated']} updates gated ({e.n_stacked} stacked samples)")
    print(f"  replay: {result.info['imu_samples_per_second']:.0f} IMU samples/s; wrote {args.out}/cmkf.yaml, .csv"
          + ("" if args.no_plot else ", .png"))
    return 0
