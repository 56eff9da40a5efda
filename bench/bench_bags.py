"""Bag reading speed and memory: numpy fast path vs rosbags' deserialize_cdr, and peak RSS of reading.

Run: ``PYTHONPATH=. .venv/bin/python bench/bench_bags.py`` (about 2 minutes; needs ~1 GB in the temp dir).
Prints
  (a) decode rate on 720 000 sensor_msgs/Imu messages (1 h at 200 Hz, rosbag2 mcap): numpy fast path vs
      ``deserialize_cdr`` + attribute access, both on the same raw bytes, plus whole-read times. Times are CPU
      seconds of the (single-threaded) benchmark process, so that other jobs on a shared machine do not inflate them;
  (b) peak RSS of ``read_imu`` on 1 h at 400 Hz (1.44 M messages) in a fresh subprocess, against the size of the
      decoded float64 arrays (t, gyro, accel; plus orientation for the bag whose messages provide one) and the RSS
      of the same interpreter before reading.
:func:`peak_rss_of` measures any command (e.g. ``imu-noise-id analyze``) the same way.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from itertools import islice
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from imu_noise_id.bag.fastdecode import FlatDecoder  # noqa: E402
from imu_noise_id.bag.mcapfast import fast_mcap_messages  # noqa: E402
from imu_noise_id.bag.reader import read_bag  # noqa: E402
from imu_noise_id.bag.stream import BATCH  # noqa: E402
from imu_noise_id.bag.topics import IMU_TYPE  # noqa: E402
from imu_noise_id.bag.writer import write_bag  # noqa: E402
from imu_noise_id.core.noise.modelspec import parse_imu_model  # noqa: E402
from imu_noise_id.core.simulation.static import simulate_static_imu  # noqa: E402

SPEC = "gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)"
IMU_OUTPUTS = {
    "sec": ("header.stamp.sec",),
    "nsec": ("header.stamp.nanosec",),
    "gyro": ("angular_velocity.x", "angular_velocity.y", "angular_velocity.z"),
    "accel": ("linear_acceleration.x", "linear_acceleration.y", "linear_acceleration.z"),
}


def _vm_hwm(pid: int) -> int | None:
    """High-water mark of the resident set of a running process [bytes] (Linux ``VmHWM``), None once it exited."""
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def peak_rss_of(cmd: list[str], env: dict[str, str] | None = None, poll_s: float = 0.01) -> tuple[int, float, int]:
    """Run ``cmd`` and return (peak resident set size [bytes], wall time [s], exit code) of that process.

    Polls the kernel's high-water mark ``VmHWM`` of the child every ``poll_s`` seconds (it only grows, so only
    growth in the last poll interval before exit can be missed). ``ru_maxrss`` from ``wait4`` is not used: after
    fork/vfork + exec it starts from the *parent's* RSS, which would dominate here.
    """
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env if env is not None else dict(os.environ))
    peak = 0
    while proc.poll() is None:
        hwm = _vm_hwm(proc.pid)
        if hwm is not None:
            peak = max(peak, hwm)
        time.sleep(poll_s)
    return peak, time.perf_counter() - start, proc.returncode


def make_bag(
    directory: Path, rate: float, duration: float, storage: str, orientation: bool = False
) -> tuple[Path, int]:
    imu = simulate_static_imu(parse_imu_model(SPEC), rate, duration, seed=1, t0=1.7e9)
    if orientation:  # a slowly turning sensor that reports its orientation (REP-145: provided)
        half = 1e-3 * (imu.t - imu.t[0])
        imu.orientation_xyzw = np.column_stack([0 * half, 0 * half, np.sin(half), np.cos(half)])
    path = directory / f"imu_{rate:g}hz_{duration:g}s_{storage}{'_orientation' if orientation else ''}"
    start = time.perf_counter()
    write_bag(path, imu, storage=storage)
    print(f"  wrote {len(imu)} messages ({storage}) in {time.perf_counter() - start:.1f} s: {path.name}")
    return path, len(imu)


def decode_rates(path: Path) -> dict[str, float]:
    """Seconds spent on raw iteration, numpy decoding and deserialize_cdr decoding over one pass of the bag."""
    from rosbags.highlevel import AnyReader

    times = {"iterate": 0.0, "fast": 0.0, "deserialize_cdr": 0.0}
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.msgtype == IMU_TYPE]
        decoder = FlatDecoder(
            reader.typestore.fielddefs,
            IMU_TYPE,
            IMU_OUTPUTS,
            strings=("header.frame_id",),
            ros1=False,
            deserialize=reader.deserialize,
        )
        deserialize = reader.typestore.deserialize_cdr
        messages = reader.messages(connections=conns)
        n = 0
        while True:
            t0 = time.process_time()
            batch = list(islice(messages, BATCH))
            times["iterate"] += time.process_time() - t0
            if not batch:
                break
            raws = [raw for _, _, raw in batch]
            k = len(raws)
            out = {"sec": np.empty(k, np.int64), "nsec": np.empty(k, np.int64),
                   "gyro": np.empty((k, 3)), "accel": np.empty((k, 3))}  # fmt: skip
            t0 = time.process_time()
            decoder.decode(raws, out)
            t_fast = out["sec"] + out["nsec"] * 1e-9
            times["fast"] += time.process_time() - t0
            t0 = time.process_time()
            rows = []
            for raw in raws:
                m = deserialize(raw, IMU_TYPE)
                w, a = m.angular_velocity, m.linear_acceleration
                rows.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, w.x, w.y, w.z, a.x, a.y, a.z))
            ref = np.array(rows)
            times["deserialize_cdr"] += time.process_time() - t0
            if not (np.array_equal(ref[:, 0], t_fast) and np.array_equal(ref[:, 1:4], out["gyro"])
                    and np.array_equal(ref[:, 4:], out["accel"])):  # fmt: skip
                raise SystemExit("fast path and deserialize_cdr disagree: bug")
            n += k
        start = time.process_time()
        count = sum(1 for _ in fast_mcap_messages(reader, conns))
        times["iterate_mcapfast"] = time.process_time() - start
        assert count == n
    times["n"] = n
    return times


def part_a(directory: Path, duration: float) -> None:
    print(f"(a) decode rate, {round(200 * duration):,} Imu messages ({duration:g} s at 200 Hz), CPU seconds")
    path, n = make_bag(directory, 200.0, duration, "mcap")
    times = decode_rates(path)
    fast, ref, it = times["fast"], times["deserialize_cdr"], times["iterate"]
    it_fast = times["iterate_mcapfast"]
    print(f"  raw iteration (rosbags AnyReader.messages): {it:6.2f} s  {n / it:>11,.0f} msg/s")
    print(f"  raw iteration (mcapfast chunk walker):      {it_fast:6.2f} s  {n / it_fast:>11,.0f} msg/s")
    print(f"  decode, numpy fast path:                    {fast:6.2f} s  {n / fast:>11,.0f} msg/s")
    print(f"  decode, deserialize_cdr + fields → numpy:   {ref:6.2f} s  {n / ref:>11,.0f} msg/s")
    print(f"  decode-only ratio: fast path {ref / fast:.1f}× faster per message (values identical)")
    print(f"  read incl. rosbags iteration: fast {it + fast:.2f} s vs deserialize_cdr {it + ref:.2f} s → "
          f"{(it + ref) / (it + fast):.1f}× faster")  # fmt: skip
    print(f"  read incl. iteration, ours (mcapfast + numpy) vs rosbags + deserialize_cdr: {it_fast + fast:.2f} s vs "
          f"{it + ref:.2f} s → {(it + ref) / (it_fast + fast):.1f}× faster")  # fmt: skip
    for storage in ("mcap", "sqlite3"):
        bag = path if storage == "mcap" else make_bag(directory, 200.0, duration, storage)[0]
        start = time.process_time()
        got = read_bag(bag)
        wall = time.process_time() - start
        print(f"  read_bag end to end ({storage}): {wall:.2f} s for {len(got.imu)} messages "
              f"({len(got.imu) / wall:,.0f} msg/s), repairs and checks included")  # fmt: skip


def part_b(directory: Path, duration: float) -> None:
    print(f"(b) peak RSS of reading {duration:g} s at 400 Hz ({round(400 * duration):,} messages), fresh subprocess")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    prelude = "from imu_noise_id.bag.reader import read_imu; import numpy, rosbags.highlevel, rosbags.typesys"
    base, _, _ = peak_rss_of([sys.executable, "-c", prelude + "; import time; time.sleep(0.2)"], env)
    mb = 1024**2
    print(f"  interpreter + imports before reading: {base / mb:.1f} MiB")
    path, n = make_bag(directory, 400.0, duration, "mcap")
    arrays = n * 7 * 8  # t (N) + gyro (N, 3) + accel (N, 3), float64
    # The child sleeps briefly after reading so that the last poll sees its final high-water mark.
    code = f"{prelude}; imu = read_imu({str(path)!r}); assert len(imu) == {n}; import time; time.sleep(0.2)"
    peak, wall, rc = peak_rss_of([sys.executable, "-c", code], env)
    if rc != 0:
        raise SystemExit(f"reading failed with exit code {rc}")
    check = code.replace("; import time", "; from imu_noise_id.core.stillness import static_check; "
                         "assert static_check(imu).static; import time")  # fmt: skip
    peak_check, wall_check, rc = peak_rss_of([sys.executable, "-c", check], env)
    if rc != 0:
        raise SystemExit(f"read + static_check failed with exit code {rc}")
    print(f"  decoded float64 arrays: {arrays / mb:.1f} MiB")
    for what, value, seconds in (("read_imu", peak, wall), ("read_imu + static_check", peak_check, wall_check)):
        _print_peak(what, value, base, arrays, seconds)
    # Messages that provide the orientation: 4 more float64 per message are kept (ImuSeries.orientation_xyzw).
    path, n = make_bag(directory, 400.0, duration, "mcap", orientation=True)
    arrays = n * 11 * 8
    code = (f"{prelude}; imu = read_imu({str(path)!r}); assert len(imu) == {n}; "
            "assert imu.orientation_xyzw is not None; import time; time.sleep(0.2)")  # fmt: skip
    peak, wall, rc = peak_rss_of([sys.executable, "-c", code], env)
    if rc != 0:
        raise SystemExit(f"reading (with orientation) failed with exit code {rc}")
    print(f"  decoded float64 arrays with orientation: {arrays / mb:.1f} MiB")
    _print_peak("read_imu, orientation", peak, base, arrays, wall)


def _print_peak(what: str, value: int, base: int, arrays: int, seconds: float) -> None:
    mb = 1024**2
    added = value - base
    print(f"  peak RSS of {what + ':':26s} {value / mb:6.1f} MiB = {value / arrays:.2f}× the arrays; "
          f"adds {added / mb:.1f} MiB = {added / arrays:.2f}× the arrays ({seconds:.1f} s)")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tmp", type=Path, default=None, help="folder for the generated bags (default: system temp)")
    parser.add_argument("--duration", type=float, default=3600.0, help="recording length [s] (3600)")
    parser.add_argument("--only", choices=("a", "b"), default=None, help="run one part only")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    with tempfile.TemporaryDirectory(dir=args.tmp, prefix="bench_bags_") as tmp:
        if args.only in (None, "a"):
            part_a(Path(tmp), args.duration)
        if args.only in (None, "b"):
            part_b(Path(tmp), args.duration)


if __name__ == "__main__":
    main()
