"""CPU time of writing an analysis (its figures) against the analysis itself, with fixed margins and with
matplotlib's ``tight_layout``, side by side in one process.

    .venv/bin/python bench/bench_figures.py [--minutes 2] [--rate 100] [--repeats 3]

A simulated static record (WN + RW on the gyros and accelerometers) is analysed once with the default stages
(EM fit and closed loop); :func:`imu_noise_id.report.analysis.write_analysis` then writes its files ``--repeats``
times with the margins of :mod:`imu_noise_id.report.layout` and as many times with ``fig.tight_layout()`` in their
place, alternating. Printed: the analysis's CPU time, each writing's CPU time (median) and their ratio.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, analyze
from imu_noise_id.report import analysis, layout

MODEL = "gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)"


def _tight(fig, **_: object) -> None:
    fig.tight_layout()


def _write(result, folder: Path, *, tight: bool) -> float:
    """CPU seconds of writing every output of ``result`` into ``folder``."""
    patched = _users() if tight else []
    for module in patched:
        module.fix_margins = _tight
    try:
        start = time.process_time()
        analysis.write_analysis(result, folder, rostopic="/imu", meta={"source": "bench"})
        return time.process_time() - start
    finally:
        for module in patched:
            module.fix_margins = layout.fix_margins


def _users() -> list:
    """The loaded report modules that imported :func:`~imu_noise_id.report.layout.fix_margins` (each holds its own
    reference, so each is patched)."""
    return [m for name, m in list(sys.modules.items())
            if name.startswith("imu_noise_id.report.") and m is not layout
            and getattr(m, "fix_margins", None) is layout.fix_margins]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=2.0)
    ap.add_argument("--rate", type=float, default=100.0)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)

    imu = simulate_static_imu(parse_imu_model(MODEL), args.rate, 60.0 * args.minutes, seed=7)
    start = time.process_time()
    result = analyze(imu, None, AnalyzeOptions(jobs=1))
    fit_cpu = time.process_time() - start
    times: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeats):
            for tight in (False, True):
                times[tight].append(_write(result, Path(tmp) / f"{k}_{tight}", tight=tight))
    fixed, tight = statistics.median(times[False]), statistics.median(times[True])
    print(f"# bench/bench_figures.py --minutes {args.minutes:g} --rate {args.rate:g} --repeats {args.repeats} "
          f"({MODEL}; default stages, one process)")
    print(f"analysis (Allan, EM, closed loop)      CPU {fit_cpu:6.1f} s")
    print(f"writing, fixed margins (report.layout) CPU {fixed:6.1f} s  (median of {args.repeats})")
    print(f"writing, tight_layout                  CPU {tight:6.1f} s  (median of {args.repeats})")
    print(f"tight_layout / fixed margins: {tight / fixed:.2f}; writing's share of analyze + write: "
          f"{fixed / (fit_cpu + fixed):.0%} (fixed) against {tight / (fit_cpu + tight):.0%} (tight)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
