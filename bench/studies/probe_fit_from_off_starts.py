"""Whether a fit started away from the maximum reaches it: the log-likelihood the search ends below the best one
found, from the default starts and from starts with every parameter off by a factor e^±1.5 (a loop's refit
starts from the previous fit and a detector's guess). The search's finish (``mle.maximise``) is preconditioned by
the Whittle information at the start (``whittle.whittle_information``); run this at two commits to compare two
metrics (docs/em.md, "The finish's metric").

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_fit_from_off_starts.py [--seeds 5 --starts 3]
(prints its findings; about two minutes)
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from imu_noise_id.core.estimation.em.mle import LR_DROP_95
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.noise.components import GM, RW, WN, Component, simulate_sum
from imu_noise_id.core.noise.resonant import LPF, OSC

DT = 0.01
SAMPLES = 60_000
CASES: dict[str, list[Component]] = {
    "WN+RW": [WN(1e-3), RW(2e-5)],
    "WN+GM+RW": [WN(1e-3), GM(tau=20.0, sigma=2e-3), RW(4e-5)],
    "WN+LPF+RW": [WN(5e-4), LPF(2e-3, 15.0), RW(3e-5)],
    "WN+OSC+RW": [WN(2e-3), OSC(frequency=0.5, bandwidth=0.02, sigma=4e-3), RW(3e-4)],
}
#: Every parameter of an off start is the default fit's times e^u, u uniform in ±OFF (an OSC's frequency ±1 %).
OFF = 1.5


def off_start(fit_components: list[Component], rng: np.random.Generator) -> list[Component]:
    """The fitted components with every parameter moved by a random factor (module docstring)."""
    out = []
    for c in fit_components:
        params = {k: v * math.exp(rng.uniform(-OFF, OFF)) for k, v in c.params().items()}
        if isinstance(c, OSC):
            params["frequency"] = c.frequency * math.exp(rng.uniform(-0.01, 0.01))
        out.append(type(c)(**params))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--starts", type=int, default=3, help="off starts per record")
    args = ap.parse_args()
    options = FitOptions(uncertainty=False)
    print(f"# {SAMPLES} samples at {1 / DT:g} Hz per record; shortfall = best log-likelihood found on the record "
          f"minus the fit's (default start, then {args.starts} off starts, parameters × e^±{OFF})")
    short_default, short_off, seconds = [], [], 0.0
    for name, truth in CASES.items():
        for seed in range(args.seeds):
            y = simulate_sum(truth, SAMPLES, DT, np.random.default_rng(100 + seed))
            model = NoiseModel(y, DT, name)
            t0 = time.process_time()
            default = model.fit(None, options)
            rng = np.random.default_rng(seed)
            lls = [default.loglik]
            for _ in range(args.starts):
                try:
                    lls.append(model.fit(off_start(default.components, rng), options).loglik)
                except ValueError:  # InputError is a ValueError: no valid likelihood from that start
                    lls.append(-math.inf)
            seconds += time.process_time() - t0
            best = max(lls)
            short = [best - ll for ll in lls]
            short_default.append(short[0])
            short_off += short[1:]
            print(f"{name:10s} seed {seed}: " + " ".join(f"{s:9.2f}" for s in short), flush=True)
    for label, values in (("default starts", short_default), ("off starts", short_off)):
        v = np.array(values)
        print(f"{label:15s}: {np.sum(v > LR_DROP_95)} of {v.size} end more than {LR_DROP_95:.2f} below the best "
              f"(the 95 % likelihood-ratio threshold); largest {np.max(v):.3g}, median {np.median(v):.3g}")
    print(f"CPU time of the fits: {seconds:.1f} s")


if __name__ == "__main__":
    main()
