"""N of a consumer part's low-pass filter at high output rates, as ``analyze`` pastes it, this checkout against others.

A MEMS part's DLPF (5–40 Hz, first order here) on its noise behind a white floor, at 200 Hz, 400 Hz and 1 kHz: a
memory of 1–32 samples. Each record runs ``analyze``'s stages for one axis — the model selection (with intervals),
the closed loop from its winner, the final model — and the Allan-slope reading, in each source tree's own process
(``bench/common.py``: one BLAS thread, the tree's package checked), on the same samples (simulated once here,
passed as a file). Printed per record and tree: the final model, N's error against the truth (the simulated
components' density as sampled, ``kalibr.passband_density``), whether N's 95 % interval holds it, the Allan-slope
N's error and method, and the CPU time; then a summary per tree::

    git worktree add ../baseline <commit>
    .venv/bin/python bench/studies/bench_sensor_filter.py --baseline ../baseline

The truth per record: N = 1.5·10⁻⁴ u/√Hz through the DLPF (cutoff log-uniform in 5–40 Hz), a white floor of
5–20 % of it, K = 2·10⁻⁵ u/s/√Hz; ``--minutes`` of data (default 5) per record. What it found is in docs/loop.md
(The loop's rules, rule 1) and docs/analysis.md (Noise parameters from the slopes, rule 5); its last output is
docs/results/studies/bench_sensor_filter.txt.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from common import run_in_checkout  # bench/common.py

from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import LPF, RW, WN, simulate_sum

ROOT = Path(__file__).resolve().parents[2]
N_TRUE, K_TRUE = 1.5e-4, 2e-5

#: Run in each source tree on one record: analyze's stages for one axis and the Allan-slope reading, one JSON line.
ONE_RECORD = """
import json
import numpy as np
from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.allan.slopes import fit_axis_slopes
from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.pipelines.analyze.final import final_model
from imu_noise_id.pipelines.analyze.models import ModelStage, fit_axis
from imu_noise_id.pipelines.loop import ImuLoop
y = np.load({path!r})
dt = {dt!r}
data = np.column_stack([y] * 6)
imu = ImuSeries(np.arange(y.size) * dt, data[:, :3], data[:, 3:])
allan = allan_variance(y, dt)
model = fit_axis(imu, "gyro_x", ModelStage(), dt, allan)
loop = ImuLoop(imu, None, intervals=True).run("gyro_x", model.fit)
final = final_model(model.fit, loop, allan)
slope = fit_axis_slopes(allan).noise_density
print(json.dumps({{"model": final.fit.model, "n": final.noise_density.value, "ci": final.noise_density.ci95,
                  "allan_n": slope.value, "allan_method": slope.method}}))
"""


def simulate(rate: float, minutes: float, seed: int) -> tuple[np.ndarray, float, float, float]:
    """(samples, dt, cutoff [Hz], N's truth as sampled) of one record."""
    rng = np.random.default_rng(seed)
    cutoff = float(math.exp(rng.uniform(math.log(5.0), math.log(40.0))))
    floor = float(rng.uniform(0.05, 0.2))
    dt = 1.0 / rate
    comps = [WN(N_TRUE * floor), LPF(noise_density=N_TRUE, cutoff=cutoff), RW(K_TRUE)]
    y = simulate_sum(comps, int(minutes * 60 * rate), dt, rng)
    return y, dt, cutoff, float(kalibr.passband_density(comps[:2], dt))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[200.0, 400.0, 1000.0])
    ap.add_argument("--seeds", type=int, default=6, help="records per rate")
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--baseline", type=Path, action="append", default=[], help="another checkout (repeatable)")
    args = ap.parse_args(argv)
    sources = [("this checkout", ROOT), *[(f"baseline {p}", p.resolve()) for p in args.baseline]]
    print(f"# bench/studies/bench_sensor_filter.py --rates {' '.join(f'{r:g}' for r in args.rates)} "
          f"--seeds {args.seeds} --minutes {args.minutes:g}; {os.cpu_count()} CPUs; "
          f"load average before {os.getloadavg()[0]:.2f}")
    print(f"# truth: N = {N_TRUE:g} through a first-order DLPF (cutoff log-uniform 5-40 Hz) beside a white floor of "
          f"5-20 % of it, K = {K_TRUE:g}; N's truth is the density as sampled")
    rows: dict[str, list[dict]] = {name: [] for name, _ in sources}
    with tempfile.TemporaryDirectory() as tmp:
        for rate in args.rates:
            for seed in range(args.seeds):
                y, dt, cutoff, truth = simulate(rate, args.minutes, 1000 * int(rate) + seed)
                path = str(Path(tmp) / "record.npy")
                np.save(path, y)
                memory = rate / (2.0 * math.pi * cutoff)
                for name, source in sources:
                    cpu, out = run_in_checkout(source, ONE_RECORD.format(path=path, dt=dt), "one record")
                    err = out["n"] / truth - 1.0 if out["n"] else math.inf
                    held = out["ci"][0] <= truth <= out["ci"][1] if out["n"] else False
                    allan_err = out["allan_n"] / truth - 1.0
                    rows[name].append({"err": err, "held": held, "allan_err": allan_err,
                                       "allan_fit": out["allan_method"] == "fit"})
                    print(f"{rate:6g} Hz seed {seed} cutoff {cutoff:5.1f} Hz (memory {memory:5.1f} samples)  "
                          f"{name:32s} {out['model']:22s} N {100 * err:+7.1f} % (interval holds it: {held})  "
                          f"Allan-slope N {100 * allan_err:+7.1f} % ({out['allan_method']})  CPU {cpu:6.1f} s",
                          flush=True)
    for name, _ in sources:
        r = rows[name]
        errs = [abs(x["err"]) for x in r]
        allan = [abs(x["allan_err"]) for x in r]
        print(f"{name}: N within 10 % on {sum(e <= 0.1 for e in errs)} of {len(r)} (median |error| "
              f"{100 * statistics.median(errs):.1f} %, max {100 * max(errs):.1f} %), its interval holds the truth on "
              f"{sum(x['held'] for x in r)}; Allan-slope N within 10 % on {sum(e <= 0.1 for e in allan)} (median "
              f"{100 * statistics.median(allan):.1f} %, max {100 * max(allan):.1f} %), read from a fit on "
              f"{sum(x['allan_fit'] for x in r)}")
    print(f"load average after {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
