"""CPU time of writing an analysis (its figures) against the analysis itself, as written now and with each of the
three savings undone, side by side in one process.

    .venv/bin/python bench/bench_figures.py [--minutes 2] [--rate 100] [--repeats 5]

A simulated static record (WN + RW on the gyros and accelerometers) is analysed once with the default stages
(EM fit and closed loop); :func:`imu_noise_id.report.analysis.write_analysis` then writes its files ``--repeats``
times in each variant, in turn:

- ``now``: the margins of :mod:`imu_noise_id.report.layout` and the log axes' minor ticks at 2 and 5 of each decade
  (:mod:`imu_noise_id.report.png`);
- ``mathtext labels``: as now, but the log axes' powers of ten in matplotlib's mathtext instead of plain text;
- ``every minor tick``: the same margins with matplotlib's eight minor ticks per decade (and mathtext labels);
- ``tight_layout``: ``fig.tight_layout()`` in place of the margins, with every minor tick and mathtext labels (as
  before all three savings).

Printed: the analysis's CPU time, each variant's writing CPU time (median), its ratio to ``now`` and the writing's
share of analyse + write.
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
from imu_noise_id.report import analysis, layout, png

MODEL = "gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)"
THINNED = png.LOG_MINOR_SUBS


def _tight(fig, **_: object) -> None:
    fig.tight_layout()


VARIANTS = ("now", "mathtext labels", "every minor tick", "tight_layout")


def _write(result, folder: Path, variant: str) -> float:
    """CPU seconds of writing every output of ``result`` into ``folder`` in ``variant``."""
    patched = _users() if variant == "tight_layout" else []
    for module in patched:
        module.fix_margins = _tight
    # "auto": matplotlib's default minor ticks
    png.LOG_MINOR_SUBS = "auto" if variant in ("every minor tick", "tight_layout") else THINNED
    png.PLAIN_POWERS = variant == "now"
    try:
        start = time.process_time()
        analysis.write_analysis(result, folder, meta={"source": "bench"})
        return time.process_time() - start
    finally:
        png.LOG_MINOR_SUBS = THINNED
        png.PLAIN_POWERS = True
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
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)

    imu = simulate_static_imu(parse_imu_model(MODEL), args.rate, 60.0 * args.minutes, seed=7)
    start = time.process_time()
    result = analyze(imu, None, AnalyzeOptions(jobs=1))
    fit_cpu = time.process_time() - start
    times: dict[str, list[float]] = {v: [] for v in VARIANTS}
    with tempfile.TemporaryDirectory() as tmp:
        _write(result, Path(tmp) / "warm-up", "now")  # fonts and mathtext caches filled before any timing
        for k in range(args.repeats):
            for variant in VARIANTS:
                times[variant].append(_write(result, Path(tmp) / f"{k}_{VARIANTS.index(variant)}", variant))
    median = {v: statistics.median(t) for v, t in times.items()}
    print(f"# bench/bench_figures.py --minutes {args.minutes:g} --rate {args.rate:g} --repeats {args.repeats} "
          f"({MODEL}; default stages, one process)")
    print(f"analysis (Allan, EM, closed loop)  CPU {fit_cpu:6.1f} s")
    for v in VARIANTS:
        print(f"writing, {v:24s} CPU {median[v]:6.1f} s  (median of {args.repeats}; {median[v] / median['now']:.2f} x "
              f"now; {median[v] / (fit_cpu + median[v]):.0%} of analyse + write)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
