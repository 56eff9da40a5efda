"""The code the benches share: the measured records, what the data say without a fit, and side-by-side runs.

- The ADIS16405 static runs in ``../shared/data/adis16405_static`` (:func:`load_adis_run`, :func:`adis_data_missing`)
  and the rest phases of the BROAD trials in ``../shared/data/broad_trials`` (:func:`load_broad_rest`): short
  records of a consumer module (myon aktos-t, 285.7 Hz, 28–42 s at rest), whose gyros carry a 22 Hz harmonic family.
- The data's own levels, which share nothing with a fit: the white-noise level over a passband
  (:func:`data_passband_level`) and the random walk the long-τ Allan variance allows (:func:`long_tau_rw_bounds`).
- Code run against another checkout of the project in its own process, with a check of which package it imported
  (:func:`run_in_checkout`, :func:`check_imports_own_package`): a speed claim is a ratio between checkouts only if
  each process imported its own checkout's package.

Scripts in ``bench/`` import it as ``common`` (it lies beside them); those in ``bench/studies/`` put ``bench/`` on
``sys.path`` first. Its module-level imports are the standard library, numpy and scipy: a side-by-side bench's child
imports it in another checkout (``studies/bench_loop_measured_time.py``), whose package may lack this one's modules.
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy import signal

#: ``../shared/data`` beside the repository: third-party measured data, never committed.
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
ADIS_DATA = SHARED_DATA / "adis16405_static"
BROAD_DATA = SHARED_DATA / "broad_trials"
#: The BROAD data's ``movement`` flag lags the motion's start by up to 1.3 s (``studies/bench_motion_bursts.py``): a
#: rest phase ends this much [s] before it.
MOTION_MARGIN_S = 2.0
#: The band [Hz] of the data's passband level: above the ADIS16405's ≈ 0.5 Hz disturbance, below its ≈ 10 Hz
#: vibration line and the sensor's filter (the median over the band steps over narrower lines).
PASSBAND_HZ = (1.0, 6.0)
#: The long-τ random-walk bounds use the AV at τ ≥ this [s] (a tenth of the 10⁴ s records; ≥ 100 s of the 1000 s ones).
LONG_TAU = 100.0


# -- the measured records ----------------------------------------------------------------------------------------

def load_adis_run(run: int, samples: int = 0) -> tuple[np.ndarray, float]:
    """ADIS16405 run ``run``'s rates, shape (N, 6) in :data:`imu_noise_id.core.axes.AXES` order (gyro rad/s, then
    accel m/s²), its first ``samples`` only when non-zero, and the sample period dt [s]."""
    d = np.load(ADIS_DATA / f"adis16405_run{run}.npz")
    data = np.hstack([d["gyro"], d["accel"]])
    return (data[:samples] if samples else data), 1.0 / float(d["fs_hz"])


def adis_data_missing() -> bool:
    """Whether the ADIS16405 runs are absent (said on stderr): the benches then exit with 2."""
    if ADIS_DATA.is_dir():
        return False
    print(f"no data at {ADIS_DATA}", file=sys.stderr)
    return True


def load_broad_rest(trial: int, samples: int = 0) -> tuple[np.ndarray, float]:
    """BROAD trial ``trial``'s rest before its motion (the samples up to :data:`MOTION_MARGIN_S` before the data's
    first ``movement`` flag), shape (N, 6) in :data:`imu_noise_id.core.axes.AXES` order (gyro rad/s, then accel
    m/s²), its first ``samples`` only when non-zero, and the sample period dt [s] (the median stamp step)."""
    path, = BROAD_DATA.glob(f"broad_{trial}_*.npz")
    d = np.load(path)
    dt = float(np.median(np.diff(d["t"])))
    rest = slice(0, int(np.argmax(d["movement"])) - round(MOTION_MARGIN_S / dt))
    data = np.hstack([d["gyro"][rest], d["accel"][rest]])
    return (data[:samples] if samples else data), dt


# -- what the data say without a fit -------------------------------------------------------------------------------

def data_passband_level(y: np.ndarray, dt: float) -> float:
    """The data's white-noise level √S [u/√Hz] (two-sided S, the convention of N): the median over
    :data:`PASSBAND_HZ` of the Welch PSD (4096-sample segments, one-sided, halved)."""
    f, p = signal.welch(y - np.mean(y), fs=1.0 / dt, nperseg=4096)
    band = (f >= PASSBAND_HZ[0]) & (f <= PASSBAND_HZ[1])
    return math.sqrt(float(np.median(p[band])) / 2.0)


def long_tau_rw_bounds(y: np.ndarray, dt: float, random_walk: float | None = None,
                       tau_min: float = LONG_TAU) -> dict[str, float]:
    """The largest RW density [u/s/√Hz] the long-τ AV supports, from the AV at the M octaves τ ≥ ``tau_min`` [s].

    ``rw_bound``: the point bound min_τ √(3·AV_hat(τ)/τ). A minimum over estimates of a few degrees of freedom each
    (one at τ = N/2), biased low: a random walk equal to the truth exceeds it in most records.

    ``rw_bound95_pointwise``: min_τ of √(3·U(τ)/τ) with U(τ) the one-sided 95 % upper confidence limit of AV(τ)
    (χ² with the EDF of a random walk, the null K²τ/3). A minimum over M pointwise 95 % limits is not a 95 % bound:
    a true K exceeds it with probability up to M·5 %.

    ``rw_bound95``: :func:`~imu_noise_id.core.allan.rw_bound.random_walk_bound` (what ``analyze`` flags a final K
    by): each limit at the level 1 − 5 %/M_eff, M_eff the independent estimates the M are worth (calibrated on
    random walks alone), so that the true K exceeds it with probability 5 %. ``loop_measured.py``'s summary judges a
    fitted random walk by it.

    ``rw_p``: how strongly the long-τ AV argues against the fitted ``random_walk`` (its p-value over M_eff,
    :meth:`~imu_noise_id.core.allan.rw_bound.RandomWalkBound.p_value`; 1 for none): that summary also judges the
    accelerometers' random walks as one family (18 tests at 5 % each reject ≈ 0.9 true values).
    """
    from imu_noise_id.core.allan import allan_variance  # here, not above: see the module's docstring
    from imu_noise_id.core.allan.rw_bound import random_walk_bound

    av = allan_variance(y, dt, confidence=0.90, alpha=-2)
    far = av.tau >= tau_min
    if not far.any():
        return {"rw_bound": math.nan, "rw_bound95_pointwise": math.nan, "rw_bound95": math.nan, "rw_p": 1.0}
    bound = random_walk_bound(av, tau_min=tau_min)
    return {"rw_bound": float(np.min(np.sqrt(3.0 * av.variance[far, 0] / av.tau[far]))),
            "rw_bound95_pointwise": float(np.min(np.sqrt(3.0 * av.ci_high[far, 0] / av.tau[far]))),
            "rw_bound95": bound.value, "rw_p": bound.p_value(random_walk) if random_walk else 1.0}


# -- side by side with another checkout ----------------------------------------------------------------------------

#: Appended to the code of :func:`run_in_checkout`: the package the child imported, for the check.
_PACKAGE = "\nimport imu_noise_id as _pkg\nprint(json.dumps({'package': _pkg.__file__}))\n"


#: Code that runs ``analyze``'s stages for one axis in a checkout (:func:`run_in_checkout`): the samples ``y`` saved at
#: ``{path}`` with period ``{dt}`` as gyro_x, through the Allan stage, the model selection (with intervals), the closed
#: loop from its winner, the final model and, where the checkout has it, the resolution of an untrusted model. It
#: leaves ``static``, ``loop``, ``final`` and ``n``, ``k``: the N and K readings ``imu.yaml`` pastes, and ``n_before``:
#: the overbound's N where a failed verdict kept the model's N. A bench appends its own JSON line (braces doubled).
ONE_AXIS_STAGES = """
import json, math
import numpy as np
from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.pipelines.analyze.final import final_model
from imu_noise_id.pipelines.analyze.models import ModelStage, fit_axis
from imu_noise_id.pipelines.analyze.static import analyze_static
from imu_noise_id.pipelines.loop import ImuLoop
y = np.load({path!r})
dt = {dt!r}
data = np.column_stack([y] * 6)
imu = ImuSeries(np.arange(y.size) * dt, data[:, :3], data[:, 3:])
static = analyze_static(imu, kinds=("allan",), allow_motion=True)
allan = static.allan.column(0)
model = fit_axis(imu, "gyro_x", ModelStage(), dt, allan)
loop = ImuLoop(imu, None, intervals=True).run("gyro_x", model.fit)
import inspect
if "selection" in inspect.signature(final_model).parameters:
    final = final_model(model.fit, loop, allan, model.selection)
else:  # a checkout before the selection's structures read K
    final = final_model(model.fit, loop, allan)
n_before = None
try:
    from imu_noise_id.pipelines.analyze.overbound import DEFAULT_HORIZON_S
    from imu_noise_id.pipelines.analyze.resolution import resolve_axis
    judged_by = y  # a checkout before the level was read in the axis's worker takes the record itself
    if "level" in inspect.signature(resolve_axis).parameters:
        from imu_noise_id.core.estimation.readouts.passband import passband_level
        judged_by = passband_level(y, dt, list(final.fit.components))
    resolution = resolve_axis(final, loop, static, "gyro_x", judged_by, horizon_s=DEFAULT_HORIZON_S)
    if resolution is not None:
        final, overbound, _ = resolution
        if final.noise_density.method != "unresolved":
            n_before = overbound.noise_density  # what the rule giving the overbound's N and K pasted
except ImportError:  # a checkout before resolve_axis: the overbound's N and K where the model is not trusted
    from imu_noise_id.pipelines.analyze.overbound import data_overbound
    from imu_noise_id.pipelines.analyze.resolution import resolved, unresolved_reason
    why = unresolved_reason(final, loop, static.slopes["gyro_x"].noise_density)
    if why is not None:
        final = resolved(final, why, data_overbound(static, "gyro_x"))
from imu_noise_id.pipelines.analyze.numbers import axis_readings
n, k = axis_readings(static, "gyro_x", final)  # as imu.yaml pastes them
"""


#: How a child's last line of stderr begins when the package stopped it on its input.
INPUT_ERROR = "imu_noise_id.core.errors.InputError:"


def run_in_checkout(source: Path, code: str, what: str, *, stops: bool = False) -> tuple[float, dict]:
    """(CPU [s] of the child, the JSON object its code printed on the line before the last) of ``python -c code``
    run in ``source`` (PYTHONPATH too, one BLAS thread); SystemExit naming ``what`` if it fails or imported another
    checkout's package. ``stops``: a child stopped by the package's InputError (what a user would read) is a result,
    ``{"stopped": its message}``, not a failure of the bench.

    The child runs with PYTHONPATH and the working directory both set to ``source``: ``python -m`` and ``-c`` put
    the working directory before PYTHONPATH, so run from the repository root every checkout would import the root's
    package. ``code`` must import ``json`` and print its result as one JSON line last; the package check prints
    after it.
    """
    env = dict(os.environ, PYTHONPATH=str(source), OPENBLAS_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-c", code + _PACKAGE], env=env, cwd=source, capture_output=True,
                          text=True, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        last = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ""
        if stops and last.startswith(INPUT_ERROR):
            return cpu, {"stopped": last.removeprefix(INPUT_ERROR).strip()}
        raise SystemExit(f"{what} from {source} failed:\n{done.stderr}")
    *_, result, package = done.stdout.strip().splitlines()
    package = json.loads(package)["package"]
    if not Path(package).is_relative_to(source):
        raise SystemExit(f"run from {source}, {what} imported {package}")
    return cpu, json.loads(result)


def check_imports_own_package(source: Path, what: str) -> None:
    """SystemExit unless a process run in ``source`` with PYTHONPATH=``source`` imports ``source``'s package: the
    check for a command the caller starts itself that way (e.g. ``python -m imu_noise_id analyze``)."""
    run_in_checkout(source, "import json\nprint(json.dumps(None))\n", what)
