"""``compare`` on measured data: the ADIS16405 runs against a default ``analyze`` of run 2.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/bench_compare_adis.py [--seconds 1000] [--reference DIR] \
        [--out docs/results/bench_compare_adis.txt]

Run 2's first ``--seconds`` are written as a bag and analyzed by the default ``imu-noise-id analyze`` (model
selection and the closed loop; 13 min for 1000 s on this 2-core machine), or ``--reference DIR`` names such a
results folder made earlier. Then the first ``--seconds`` of runs 1, 3, 4, 5 and 6 (the same sensor model; the data's
README does not say whether the same unit) are compared against it with the command's defaults; printed per run its
exit code and the command's table (per axis the live/reference density with its interval and what differs).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import adis_data_missing, load_adis_run  # bench/common.py, beside this script

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main as cli
from imu_noise_id.core.axes import ImuSeries


def write_run(run: int, seconds: float, folder: Path) -> Path:
    """Run ``run``'s first ``seconds`` as a bag in ``folder``."""
    data, dt = load_adis_run(run)
    data = data[: round(seconds / dt)]
    t = dt * np.arange(data.shape[0])
    return write_bag(folder / f"run{run}", ImuSeries(t, data[:, :3], data[:, 3:], "imu_link", "/imu/data"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1000.0)
    parser.add_argument("--reference", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=None, help="write the output there (default: stdout)")
    args = parser.parse_args()
    if adis_data_missing():
        return 2
    lines = [f"# bench/bench_compare_adis.py --seconds {args.seconds:g}"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        reference = args.reference
        if reference is None:
            reference = folder / "reference"
            start = time.perf_counter()
            cli(["analyze", str(write_run(2, args.seconds, folder)), "--out", str(reference)])
            lines.append(f"reference: default analyze of run 2's first {args.seconds:g} s "
                         f"({time.perf_counter() - start:.0f} s)")
        else:
            lines.append(f"reference: {reference} (a default analyze of run 2's first {args.seconds:g} s)")
        for run in (1, 3, 4, 5, 6):
            bag = write_run(run, args.seconds, folder)
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed):
                code = cli(["compare", str(bag), "--reference", str(reference)])
            table = printed.getvalue().replace(f"{folder}/", "").replace(str(reference), "the reference")
            lines += ["", f"## run {run}: exit {code}", *table.rstrip().splitlines()]
            print(f"run {run}: exit {code}", file=sys.stderr, flush=True)
    text = "\n".join(lines) + "\n"
    if args.out is None:
        print(text, end="")
    else:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
