"""GMWM speed against the EM, side by side in one run, and the linear cost of the wavelet-variance pass (issue 14,
target 2); the EM's per-sample cost that sets ``EM_MAX_SAMPLES``.

Run:  nice -n 10 python bench/bench_gmwm_speed.py [--n 10000000] [--axes 6]
      (output in docs/results/bench_gmwm_speed.txt)

1. The WV pass (classical, all dyadic scales up to N/8) on one axis of N = 10⁵, 10⁶, 10⁷ samples: wall time per
   sample (constant = linear in N), and the fit on the J numbers alone (covariance V and minimisation: grows with
   J ≈ log₂N, not with N).
2. ``--axes`` axes of ``--n`` samples at 1 kHz (2.8 h at 10⁷), each WN+GM+RW: the GMWM fit (WV pass, two-step fit,
   intervals) and the EM fit (``fit_model``, default options: 3 starts, EM + quasi-Newton, intervals) of the same
   structure on the same samples, axis by axis; wall and CPU seconds and their ratio. An EM fit still running after
   ``--em-budget`` seconds of wall time is stopped: its time and the ratio are then printed as lower bounds (">"),
   its N and K as "—" (on 10⁷ samples the EM's profile-likelihood intervals alone ran for more than an hour).
3. The EM's model selection (``select_model``, the default candidates) on 10⁶ samples of one axis: its CPU per sample
   and the record length per axis beyond which the default analyze (selection on 6 axes, the loop roughly doubling
   it, issue 10's measurement) would take more than ten minutes of CPU on this machine.
4. The GMWM as the EM's starting value (what ``analyze --estimator both`` does): on 10⁶ samples of each of three
   axes, the EM from its default 3 Allan-variance starts against the EM from 1 Allan start plus the GMWM fit, CPU
   and log-likelihood reached.
"""

from __future__ import annotations

import argparse
import resource
import signal
import time

import numpy as np

from imu_noise_id.core.estimation.em.model import fit_model
from imu_noise_id.core.estimation.em.selection import select_model
from imu_noise_id.core.estimation.gmwm.fit import fit_gmwm
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.wavelet.variance import wavelet_variance

DT = 0.001
AXES = {
    "gyro_x": [WN(1.5e-4), GM(tau=100.0, sigma=1e-4), RW(2e-6)],
    "gyro_y": [WN(1.7e-4), GM(tau=300.0, sigma=8e-5), RW(1.5e-6)],
    "gyro_z": [WN(1.6e-4), GM(tau=50.0, sigma=1.2e-4), RW(2.5e-6)],
    "accel_x": [WN(6e-4), GM(tau=200.0, sigma=6e-4), RW(2e-5)],
    "accel_y": [WN(5e-4), GM(tau=100.0, sigma=8e-4), RW(2e-5)],
    "accel_z": [WN(7e-4), GM(tau=400.0, sigma=5e-4), RW(1.5e-5)],
}


class Clock:
    def __enter__(self) -> Clock:
        self.wall, self.cpu = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc) -> None:
        self.wall, self.cpu = time.perf_counter() - self.wall, time.process_time() - self.cpu


def peak_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def linear_pass() -> None:
    print("== 1. WV pass vs N (one axis, WN+GM+RW, dt = 1 ms) ==")
    print(f"{'N':>10} {'scales':>6} {'WV wall s':>10} {'ns/sample':>10} {'fit on J numbers s':>19}")
    for n in (10**5, 10**6, 10**7):
        y = simulate_sum(AXES["gyro_x"], n, DT, np.random.default_rng(1))
        with Clock() as c_wv:
            wv = wavelet_variance(y, DT)
        with Clock() as c_fit:
            fit_gmwm(None, DT, "WN+GM+RW", wv=wv)
        print(f"{n:>10} {wv.m.size:>6} {c_wv.wall:10.3f} {1e9 * c_wv.wall / n:10.1f} {c_fit.wall:19.2f}", flush=True)
        del y


class OverBudget(Exception):
    """The EM fit ran past its wall-time budget."""


def _over_budget(signum: int, frame: object) -> None:
    raise OverBudget


def side_by_side(n: int, n_axes: int, budget: float) -> None:
    print(f"\n== 2. {n_axes} axes x {n} samples at {1 / DT:g} Hz ({n * DT / 3600:.2f} h), WN+GM+RW: GMWM vs EM ==")
    print(f"{'axis':8} {'GMWM wall':>9} {'CPU':>7} {'EM wall':>9} {'CPU':>7} {'wall ratio':>10}  N_gmwm/N_em "
          "K_gmwm/K_em")
    totals = np.zeros(4)
    any_stopped = False
    for k, (axis, truth) in enumerate(list(AXES.items())[:n_axes]):
        y = simulate_sum(truth, n, DT, np.random.default_rng(100 + k))
        with Clock() as cg:
            g = fit_gmwm(y, DT, "WN+GM+RW")
        signal.signal(signal.SIGALRM, _over_budget)
        signal.setitimer(signal.ITIMER_REAL, budget)
        e, stopped = None, False
        try:
            with Clock() as ce:
                e = fit_model(y, DT, "WN+GM+RW")
        except OverBudget:
            stopped = True
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
        totals += (cg.wall, cg.cpu, ce.wall, ce.cpu)
        bound = ">" if stopped else " "
        ratios = ("         —          —" if e is None else
                  f"{g.components[0].noise_density / e.components[0].noise_density:10.4f} "
                  f"{g.components[2].random_walk / e.components[2].random_walk:10.3f}")
        print(f"{axis:8} {cg.wall:9.1f} {cg.cpu:7.1f} {bound}{ce.wall:8.1f} {ce.cpu:7.1f} "
              f"{bound}{ce.wall / cg.wall:8.1f}x  {ratios}   (peak RSS so far {peak_mib():.0f} MiB)", flush=True)
        any_stopped = any_stopped or stopped
        del y
    bound = ">" if any_stopped else " "
    print(f"{'total':8} {totals[0]:9.1f} {totals[1]:7.1f} {bound}{totals[2]:8.1f} {totals[3]:7.1f} "
          f"{bound}{totals[2] / totals[0]:8.1f}x  (CPU ratio {bound}{totals[3] / totals[1]:.1f}x)"
          + (f"; '>': the EM stopped at its {budget:g} s budget" if any_stopped else ""))


def em_threshold() -> None:
    n = 10**6
    y = simulate_sum(AXES["gyro_x"], n, DT, np.random.default_rng(7))
    with Clock() as c:
        sel = select_model(y, DT)
    per_sample = c.cpu / n
    # Default analyze: the selection on 6 axes, and the closed loop at the recording's rate about as much again
    # (issue 10/11's measurements: 214 s CPU for 1 h at 400 Hz, of which the model stage about half).
    threshold = 600.0 / (per_sample * 6 * 2)
    print(f"\n== 3. EM model selection on {n} samples of one axis ({len(sel.table)} candidates, best "
          f"{sel.best.model}): {c.wall:.1f} s wall, {c.cpu:.1f} s CPU = {1e6 * per_sample:.1f} µs CPU per sample ==")
    print(f"   default analyze (6 axes, selection + loop ≈ 2 × selection) above 10 min CPU beyond "
          f"{threshold:.3g} samples per axis ({threshold * DT / 3600:.2f} h at 1 kHz, {threshold / 400 / 3600:.2f} h "
          "at 400 Hz)")


def gmwm_start() -> None:
    from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel

    n = 10**6
    print(f"\n== 4. EM from the Allan starts vs from the GMWM fit, {n} samples, WN+GM+RW ==")
    print(f"{'axis':8} {'EM 3 AV starts CPU':>19} {'EM 1 AV + GMWM CPU (incl. GMWM)':>32} {'loglik gain':>12}")
    for k, axis in enumerate(("gyro_x", "gyro_y", "accel_x")):
        y = simulate_sum(AXES[axis], n, DT, np.random.default_rng(300 + k))
        with Clock() as c0:
            base = NoiseModel(y, DT, "WN+GM+RW").fit(options=FitOptions(uncertainty=False))
        with Clock() as c1:
            g = fit_gmwm(y, DT, "WN+GM+RW")
            warm = NoiseModel(y, DT, "WN+GM+RW", starts=[g.components]).fit(
                options=FitOptions(n_starts=1, uncertainty=False))
        print(f"{axis:8} {c0.cpu:19.1f} {c1.cpu:32.1f} {warm.loglik - base.loglik:12.3f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=10**7)
    ap.add_argument("--axes", type=int, default=6)
    ap.add_argument("--em-budget", type=float, default=300.0, help="wall seconds allowed to each EM fit of part 2")
    ap.add_argument("--skip", nargs="*", type=int, default=[], help="parts not to run (3, 4: the EM-only parts)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# bench_gmwm_speed.py --n {args.n} --axes {args.axes} --em-budget {args.em_budget:g}"
          f"{' --skip ' + ' '.join(map(str, args.skip)) if args.skip else ''}; shared 2-core machine (other agents' "
          "load: the ratios are side by side in one process, the absolute seconds are not)")
    linear_pass()
    side_by_side(args.n, args.axes, args.em_budget)
    if 3 not in args.skip:
        em_threshold()
    if 4 not in args.skip:
        gmwm_start()
    print(f"# total {time.perf_counter() - t0:.0f} s, peak RSS {peak_mib():.0f} MiB")


if __name__ == "__main__":
    main()
