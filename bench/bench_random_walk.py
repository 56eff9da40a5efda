"""The random walk K that ``analyze`` pastes beside a Gauss–Markov, a flicker or an oscillation, this checkout against
others.

Each record is one gyro axis at 200 Hz: white noise N = 5·10⁻⁴ rad/s/√Hz and a random walk K = 2·10⁻⁵ rad/s/√s
(their Allan variances cross at τ = √3 N/K ≈ 43 s), and per cell (:data:`CELLS`) beside them nothing, a GM of
τ = 20 s or 100 s whose AV peak equals the walk's AV at τ = 100 s, a flicker (bias instability B whose AV plateau
equals the walk's AV at 100 s, over :func:`~imu_noise_id.core.noise.flicker.band_for_record`) or an oscillation at
0.5 Hz (bandwidth 0.02 Hz, σ 2·10⁻³ rad/s). Each record runs ``analyze``'s stages for one axis in each source tree's
own process (``bench/common.py``: the selection with intervals, the loop from its winner, the final model, the
resolution), on the same samples. Printed per record and tree: the final model, the pasted K (``imu.yaml``'s
reading) over the truth, its method and 95 % interval, whether the interval holds the truth, N over the truth; then
per cell and tree: the share of seeds whose pasted K's interval holds the truth (the target: ≥ 90 %), among the
pasted bounds (``bound``, ``unresolved``, ``allan_upper_bound``, ``overbound``) the share at or above the truth
(≥ 95 %), the seeds whose K lies below the truth by more than its interval says, the median |ln(K̂/K)| (≤ 0.25 at 1 h
and 3 h) and the median N error; a record ``analyze`` stops on (its InputError) is printed as such and counts as a
miss. The oscillation cell's records take minutes each (the loop adds the line); ``run_all.py --long`` runs the
others::

    .venv/bin/python bench/bench_random_walk.py --minutes 20 --baseline ../baseline   # side by side
    .venv/bin/python bench/bench_random_walk.py --minutes 60 --cells WN+RW WN+GM20+RW
    .venv/bin/python bench/bench_random_walk.py --minutes 20 --cells WN+OSC+RW --seeds 10 --first-seed 10  # half
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import tempfile
from pathlib import Path

import numpy as np
from common import ONE_AXIS_STAGES, run_in_checkout  # bench/common.py, beside this script

from imu_noise_id.core.noise.components import GM, OSC, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI, band_for_record

ROOT = Path(__file__).resolve().parents[1]
RATE_HZ = 200.0
N_TRUE, K_TRUE = 5e-4, 2e-5
#: The τ [s] at which the GM's AV peak and the flicker's plateau equal the walk's AV.
TAU_MATCHED = 100.0
#: Methods of a pasted K that is an upper bound, not an estimate.
BOUND_METHODS = ("bound", "unresolved", "allan_upper_bound", "overbound")
CELLS = ("WN+RW", "WN+GM20+RW", "WN+GM100+RW", "WN+BI+RW", "WN+OSC+RW")

#: Run in each source tree on one record: analyze's stages for one axis, one JSON line.
ONE_RECORD = ONE_AXIS_STAGES + """
print(json.dumps({{"model": final.model, "n": n.value, "n_method": n.method, "k": k.value, "k_ci": k.ci95,
                  "k_method": k.method, "passed": loop.passed}}))
"""


def _walk_av(tau: float) -> float:
    return K_TRUE**2 * tau / 3.0


def matched_gm(tau_c: float, dt: float) -> GM:
    """The GM of correlation time ``tau_c`` [s] whose AV peak equals the walk's AV at :data:`TAU_MATCHED`."""
    tau = np.geomspace(dt, 100 * tau_c, 2000)
    peak = float(np.max(GM(tau=tau_c, sigma=1.0).allan_variance(tau, dt)))
    return GM(tau=tau_c, sigma=math.sqrt(_walk_av(TAU_MATCHED) / peak))


def components(cell: str, n: int, dt: float) -> list:
    """The simulated components of ``cell`` (module docstring) for ``n`` samples at ``dt`` [s]."""
    beside = {"WN+RW": [], "WN+GM20+RW": [matched_gm(20.0, dt)], "WN+GM100+RW": [matched_gm(100.0, dt)],
              "WN+BI+RW": [BI(math.sqrt(_walk_av(TAU_MATCHED) * math.pi / (2 * math.log(2))),
                              *band_for_record(n, dt))],
              "WN+OSC+RW": [OSC(frequency=0.5, bandwidth=0.02, sigma=2e-3)]}[cell]
    return [WN(N_TRUE), *beside, RW(K_TRUE)]


def summary(rows: list[dict]) -> str:
    """One cell's line for one tree (module docstring); a record ``analyze`` stopped on counts as a miss."""
    done = [r for r in rows if "stopped" not in r]
    held = sum(r["k_ci"][0] <= K_TRUE <= r["k_ci"][1] for r in done)
    bounds = [r for r in done if r["k_method"] in BOUND_METHODS]
    above = sum(r["k"] >= K_TRUE for r in bounds)
    below = sum(r["k_ci"][1] < K_TRUE for r in done)
    log_err = statistics.median(abs(math.log(r["k"] / K_TRUE)) for r in done) if done else math.nan
    n_err = statistics.median(r["n"] / N_TRUE - 1.0 for r in done) if done else math.nan
    stopped = f"; analyze stopped on {len(rows) - len(done)}" if len(done) < len(rows) else ""
    return (f"K's interval holds the truth {held}/{len(rows)} ({100 * held / len(rows):.0f} %); bounds at or above it "
            f"{above}/{len(bounds)}; below it beyond the interval {below}; median |ln(K/K_true)| {log_err:.3f}; "
            f"median N error {100 * n_err:+.2f} %{stopped}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="records per cell")
    ap.add_argument("--first-seed", type=int, default=0, help="the first record's seed (to split a cell's records "
                                                                   "over processes)")
    ap.add_argument("--minutes", type=float, default=20.0)
    ap.add_argument("--cells", nargs="+", default=list(CELLS), choices=list(CELLS))
    ap.add_argument("--baseline", type=Path, action="append", default=[], help="another checkout (repeatable)")
    args = ap.parse_args(argv)
    sources = [("this checkout", ROOT), *[(f"baseline {p}", p.resolve()) for p in args.baseline]]
    dt = 1.0 / RATE_HZ
    n = int(args.minutes * 60 * RATE_HZ)
    print(f"# bench/bench_random_walk.py --seeds {args.seeds} --first-seed {args.first_seed} --minutes "
          f"{args.minutes:g} --cells {' '.join(args.cells)}; {os.cpu_count()} CPUs; load average before "
          f"{os.getloadavg()[0]:.2f}")
    print(f"# truth: N = {N_TRUE:g}, K = {K_TRUE:g} at {RATE_HZ:g} Hz; per cell beside them: "
          + "; ".join(f"{c}: {'+'.join(repr(x) for x in components(c, n, dt)[1:-1]) or 'nothing'}"
                      for c in args.cells))
    rows: dict[tuple[str, str], list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "record.npy")
        for cell in args.cells:
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                rng = np.random.default_rng([CELLS.index(cell), int(args.minutes), seed])
                np.save(path, simulate_sum(components(cell, n, dt), n, dt, rng))
                for name, source in sources:
                    cpu, out = run_in_checkout(source, ONE_RECORD.format(path=path, dt=dt), "one record", stops=True)
                    rows.setdefault((cell, name), []).append(out)
                    if "stopped" in out:
                        print(f"{cell:12s} seed {seed:2d} {name:28s} analyze stopped: {out['stopped']}  "
                              f"CPU {cpu:5.1f} s", flush=True)
                        continue
                    lo, hi = out["k_ci"]
                    print(f"{cell:12s} seed {seed:2d} {name:28s} {out['model']:22s} K/K_true {out['k'] / K_TRUE:7.3f} "
                          f"({out['k_method']}, interval [{lo / K_TRUE:.3f}, {hi / K_TRUE:.3f}], holds: "
                          f"{lo <= K_TRUE <= hi})  N/N_true {out['n'] / N_TRUE:.4f}  loop passed: {out['passed']}  "
                          f"CPU {cpu:5.1f} s", flush=True)
    for cell in args.cells:
        for name, _ in sources:
            print(f"{cell:12s} {name:28s} {summary(rows[(cell, name)])}")
    print(f"load average after {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
