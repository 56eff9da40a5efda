"""Online identification, one message at a time: the ROS-free logic behind ``imu_noise_id_node``.

:class:`OnlineIdentifier` takes plain numbers per message (header stamp in seconds, angular rate, specific
force, odometry twist, temperature) and returns plain results: the bias-corrected IMU sample with its
covariance N²·f, the current estimates, the hypothesis probabilities and the diagnostics statuses as
dataclasses. The rclpy node (:mod:`imu_noise_id.node`) only converts messages to numbers and back, so every
decision made here is unit-tested without ROS.

What happens per IMU sample
---------------------------
1. Stamp and value checks (:class:`StampChecker`): non-finite values, zero, duplicated or backward stamps are
   rejected and counted; a gap (period larger than ``gap_factor`` × the nominal period) is accepted but restarts
   the stationarity detection; a sustained jump of time backwards (a restarted source, a looped bag) restarts
   the whole identification.
2. The CMKF (:class:`~imu_noise_id.core.cmkf.robot.RobotCmkf`, paper 004 on a robot) receives the sample after
   ``cmkf.input_latency`` seconds, merged in stamp order with the odometry (two topics, two latencies) by
   :class:`~imu_noise_id.core.cmkf.stream.CmkfStream`.
3. Stationarity with hysteresis (:class:`StationarityDetector`): the odometry twist (when fresh) and
   exponentially weighted IMU statistics must both say "still" for ``stationary.enter_delay`` seconds; any
   sign of motion ends the stationary state at once.
4. Stationary samples pass a delay line of ``stationary.guard`` seconds before they reach the noise
   identification, and the line is emptied when motion is detected, so the last samples before a start —
   already disturbed but not yet detected — never reach it.
5. Noise density per axis from the stationary samples (the Allan variance at τ₀,
   :class:`~imu_noise_id.core.white_noise.FirstDifferences`); the samples are also
   queued for the hypothesis bank (paper 002), which :meth:`OnlineIdentifier.update_identification` feeds in
   batches.
6. Bias correction and the covariance N²·f of the corrected sample (None while unknown).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.axes import ACCEL_AXES, AXES, GYRO_AXES
from ..core.cmkf.merge import TOO_LATE
from ..core.cmkf.robot import RobotCmkf
from ..core.cmkf.stream import CmkfStream
from ..core.diagnostics.consistency import nis_bounds
from ..core.hypotheses.axis import AxisIdentifier
from ..core.hypotheses.config import hypothesis_set_factory
from ..core.white_noise import FirstDifferences
from ..resources import read_hypotheses_file
from .online_blocks import StampChecker, StationarityDetector, WindowStats
from .online_config import OnlineConfig, cmkf_config

# Diagnostic levels, equal to diagnostic_msgs/DiagnosticStatus.{OK, WARN, ERROR, STALE}.
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}


# --------------------------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------------------------
@dataclass
class CorrectedImu:
    """One bias-corrected IMU sample; variances are N²·f per axis, or None while no estimate exists."""

    t: float
    gyro: tuple[float, float, float]
    accel: tuple[float, float, float]
    gyro_variance: tuple[float, float, float] | None
    accel_variance: tuple[float, float, float] | None


@dataclass
class Estimates:
    """Current estimates, SI units; per-axis arrays in :data:`~imu_noise_id.core.axes.AXES` order.

    Attributes
    ----------
    t : header stamp of the last IMU sample used [s]
    cmkf_status : the CMKF's status (``no_data``, ``imu_only``, ``unobserved``, ``converging``, ``tracking``)
    gyro_bias, gyro_bias_std : (3,) [rad/s] from the gyro-bias filter (NaN before the first odometry update)
    accel_bias, accel_bias_std : (3,) [m/s²] from the CMKF (NaN before the first odometry update)
    noise_density : (6,) white-noise density [u/√Hz] from stationary samples (NaN before ``noise.min_samples``)
    noise_density_rstd : relative standard deviation of ``noise_density``
    noise_samples : number of stationary sample differences used
    psd : (6,) the CMKF's Ŝ_g per gyro axis [rad²/s] and Ŝ_v per accelerometer axis [m²/s³]
    covariance : (6,) the variance N²·f [u²] written into ``~/imu_corrected`` (NaN while unknown)
    covariance_source : ``stationary`` (Allan τ₀ density), ``cmkf`` (√Ŝ) or ``none``
    imu_rate : nominal IMU rate from the header stamps [Hz]
    stationary : whether the platform is stationary now
    bank_theta : parameter name → (6,) θ̂ of each axis's most probable hypothesis (NaN where that hypothesis
        has no such parameter or the axis has no bank yet)
    """

    t: float
    cmkf_status: str
    gyro_bias: np.ndarray
    gyro_bias_std: np.ndarray
    accel_bias: np.ndarray
    accel_bias_std: np.ndarray
    noise_density: np.ndarray
    noise_density_rstd: float
    noise_samples: int
    psd: np.ndarray
    covariance: np.ndarray
    covariance_source: str
    imu_rate: float
    stationary: bool
    bank_theta: dict[str, np.ndarray]

    #: Column labels of :meth:`noise_table` before the bank's parameter names.
    NOISE_FIELDS: tuple[str, ...] = (
        "noise_density", "noise_density_rstd", "covariance", "bias", "bias_std", "cmkf_psd",
        "cmkf_noise_density", "stationary_samples",
    )

    def noise_table(self) -> tuple[tuple[str, ...], np.ndarray]:
        """Column labels and the (6, columns) table of ``~/noise`` (rows in AXES order).

        Columns: :attr:`NOISE_FIELDS`, then ``bank_<parameter>`` per parameter of the hypothesis set.
        """
        fields = self.NOISE_FIELDS + tuple(f"bank_{name}" for name in self.bank_theta)
        table = np.full((6, len(fields)), math.nan)
        table[:, 0] = self.noise_density
        table[:, 1] = self.noise_density_rstd
        table[:, 2] = self.covariance
        table[:3, 3] = self.gyro_bias
        table[3:, 3] = self.accel_bias
        table[:3, 4] = self.gyro_bias_std
        table[3:, 4] = self.accel_bias_std
        table[:, 5] = self.psd
        table[:, 6] = np.sqrt(self.psd)
        table[:, 7] = self.noise_samples
        for j, values in enumerate(self.bank_theta.values()):
            table[:, len(self.NOISE_FIELDS) + j] = values
        return fields, table


@dataclass
class HypothesesReport:
    """Posterior probabilities per axis (rows in AXES order) and hypothesis (columns in ``names`` order).

    ``decision`` holds the index of the decided hypothesis per axis (−1: undecided or no bank yet);
    ``updates`` the number of bank samples per axis; probabilities are NaN for axes without a bank yet.
    """

    names: tuple[str, ...]
    probabilities: np.ndarray
    decision: np.ndarray
    updates: np.ndarray

    def table(self) -> tuple[tuple[str, ...], np.ndarray]:
        """Column labels (hypothesis names, ``decision``, ``bank_updates``) and the (6, columns) table."""
        return (*self.names, "decision", "bank_updates"), np.column_stack(
            [self.probabilities, self.decision, self.updates]
        )


@dataclass
class DiagnosticStatus:
    """One diagnostics entry: ``name``, ``level`` (OK, WARN, ERROR, STALE), ``message`` and key–value details."""

    name: str
    level: int
    message: str
    values: dict[str, str] = field(default_factory=dict)


@dataclass
class InputStats:
    """Counters of one input stream; ``received`` and ``accepted`` grow forever, the window ones are reset."""

    received: int = 0
    accepted: int = 0
    rejected_values: int = 0
    window_received: int = 0
    last_wall: float | None = None
    frame_id: str | None = None
    frame_changes: int = 0


@dataclass
class _Stretch:
    """Stationary samples of one uninterrupted stretch waiting for the hypothesis bank."""

    t: list[float] = field(default_factory=list)
    y: list[np.ndarray] = field(default_factory=list)
    closed: bool = False
    accel_offset: np.ndarray | None = None


# --------------------------------------------------------------------------------------------------------------
# The identifier
# --------------------------------------------------------------------------------------------------------------
class OnlineIdentifier:
    """Streaming identification of a robot's IMU errors; see the module docstring for the per-sample steps.

    Estimators (not re-implemented here):

    - :class:`~imu_noise_id.core.cmkf.robot.RobotCmkf` (paper 004 on a robot): every accepted IMU and odometry
      message; it gives the accelerometer bias and Ŝ_v and, from its gyro-bias filter, the gyro bias.
    - :class:`~imu_noise_id.core.hypotheses.axis.AxisIdentifier` per axis (paper 002's bank with the
      warm-up offset): fed in batches by :meth:`update_identification` with the stationary samples that passed
      the guard. Pauses are declared with ``gap`` (the filters predict over them). For the gyro axes the warm-up
      offset of the first stretch stays (the Earth rate and turn-on bias are constant); for the accelerometer
      axes, whose gravity component changes whenever the robot stops in another attitude, each stretch's own
      warm-up mean is removed (and the first stretch's added back), so an attitude change never looks like a
      bias random walk.

    Parameters
    ----------
    config : OnlineConfig
        Validated parameters (:data:`PARAMETERS`).

    Raises
    ------
    InputError
        If the CMKF parameters or the hypothesis file are invalid.
    """

    def __init__(self, config: OnlineConfig | None = None) -> None:
        self.config = config or OnlineConfig()
        self.imu_stats = InputStats()
        self.odom_stats = InputStats()
        self.temp_stats = InputStats()
        self.imu_stamps = StampChecker(self.config.gap_factor, self.config.backward_reset_count)
        self.odom_stamps = StampChecker(self.config.gap_factor, self.config.backward_reset_count)
        self.temp_stamps = StampChecker(self.config.gap_factor, self.config.backward_reset_count)
        self.processing_time = WindowStats()
        self.identification_time = WindowStats(size=256)
        self.temperature = math.nan
        self.restarts = 0
        self.cmkf_errors = 0
        self.odom_too_late = 0
        self._window_stamp_counts: dict[str, int] = {}
        self._events: deque[tuple[str, str]] = deque(maxlen=100)
        self._hypothesis_data = self._load_hypotheses()
        self._reset_estimation()

    # -- configuration ---------------------------------------------------------------------------------------
    def set_config(self, config: OnlineConfig) -> None:
        """Apply a new (validated) configuration at runtime; the estimates are kept."""
        self.config = config
        self.stationarity.config = config
        self._cmkf.merger.latency = config.cmkf_input_latency
        for checker in (self.imu_stamps, self.odom_stamps, self.temp_stamps):
            checker.gap_factor = config.gap_factor
            checker.backward_reset_count = config.backward_reset_count

    def _load_hypotheses(self) -> dict[str, Any] | None:
        """The hypothesis-set mapping (validated for both sensors now, so a bad file fails at start-up)."""
        if not self.config.hypotheses_enabled:
            return None
        data, source = read_hypotheses_file(self.config.hypotheses_file or None)
        for sensor in ("gyro", "accel"):
            hypothesis_set_factory(data, 0.01, sensor, source)
        return {"data": data, "source": source}

    def _reset_estimation(self) -> None:
        self.stationarity = StationarityDetector(self.config)
        self.noise = FirstDifferences(6)
        self._guard: deque[tuple[float, np.ndarray]] = deque()
        self._cmkf = CmkfStream(cmkf_config(self.config), on_odometry=self._on_cmkf_odometry)
        self._cmkf_est = self._cmkf.estimate()
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.last_imu_t = math.nan
        self.stationary_transitions = 0
        self._stretches: list[_Stretch] = []
        self._banks: list[AxisIdentifier] | None = None
        self._bank_dt = math.nan
        self._bank_warmup = 0
        self._bank_last_t: float | None = None
        self._accel_first_offset: np.ndarray | None = None
        self._decisions: list[str | None] = [None] * 6
        self.decision_changes: list[str] = []
        self._variance_cache: tuple[tuple[float, ...] | None, tuple[float, ...] | None] | None = None

    # -- events for the node's (rate-limited) log -----------------------------------------------------------------
    def _event(self, key: str, text: str) -> None:
        self._events.append((key, text))

    def pop_events(self) -> list[tuple[str, str]]:
        """Input problems seen since the last call, as (key, message); the node logs them rate-limited by key."""
        if not self._events:
            return []
        events = list(self._events)
        self._events.clear()
        return events

    # -- inputs -----------------------------------------------------------------------------------------------------
    def _note_frame(self, stats: InputStats, frame_id: str, what: str) -> None:
        if stats.frame_id != frame_id:
            if stats.frame_id is not None:
                stats.frame_changes += 1
                self._event(f"{what}_frame", f"{what} frame_id changed from {stats.frame_id!r} to {frame_id!r}")
            stats.frame_id = frame_id

    def _receive(self, stats: InputStats, frame_id: str, wall_time: float | None, what: str) -> None:
        """Book-keeping shared by every input message: counters, arrival (steady clock) and frame changes."""
        stats.received += 1
        stats.window_received += 1
        stats.last_wall = wall_time
        self._note_frame(stats, frame_id, what)

    def _usable_stamp(self, checker: StampChecker, t: float, what: str) -> str | None:
        """The stamp verdict of an input message, or None when the stamp makes it unusable (bad, duplicated,
        backward): counted and reported by :meth:`_stamp_verdict`."""
        verdict = self._stamp_verdict(checker, t, what)
        return None if verdict in ("bad_stamp", "duplicate", "backward") else verdict

    def _count(self, key: str) -> None:
        self._window_stamp_counts[key] = self._window_stamp_counts.get(key, 0) + 1

    def _stamp_verdict(self, checker: StampChecker, t: float, what: str) -> str:
        verdict = checker.check(t)
        if verdict != "ok":
            key = f"{what}_{verdict}"
            self._count(key)
            if verdict == "gap":
                self._event(key, f"{what}: gap in header stamps before t = {t:.6f} s")
            elif verdict == "restart":
                self._event(key, f"{what}: stamps jumped back to t = {t:.6f} s and stayed there: restarting")
            else:
                self._event(key, f"{what}: message dropped ({verdict.replace('_', ' ')} stamp {t!r})")
        return verdict

    def process_imu(
        self, t: float, gyro: tuple[float, float, float], accel: tuple[float, float, float],
        frame_id: str = "", wall_time: float | None = None, *,
        orientation_xyzw: tuple[float, float, float, float] | None = None,
    ) -> CorrectedImu | None:
        """One IMU message: header stamp ``t`` [s], angular rate [rad/s], specific force [m/s²].

        ``orientation_xyzw`` is used by the CMKF only with ``cmkf.gravity_source: imu``. Returns the
        bias-corrected sample, or None when the message was rejected (counted, and reported through
        :meth:`pop_events` and the diagnostics).
        """
        stats = self.imu_stats
        self._receive(stats, frame_id, wall_time, "imu")
        sample = np.array((*gyro, *accel), dtype=float)
        if not np.isfinite(sample).all():
            stats.rejected_values += 1
            self._count("imu_nonfinite")
            self._event("imu_nonfinite", f"imu: message with non-finite angular rate or acceleration at t = {t!r}")
            return None
        verdict = self._usable_stamp(self.imu_stamps, t, "imu")
        if verdict is None:
            return None
        if verdict == "restart":
            self.restarts += 1
            self._reset_estimation()
        elif verdict == "gap":
            self._end_stationary()
            self.stationarity.reset()
        stats.accepted += 1
        if stats.accepted % 100 == 0:
            self._variance_cache = None
        self.last_imu_t = t
        if self.config.cmkf_gravity_source != "imu":
            orientation_xyzw = None
        self._feed_cmkf(self._cmkf.process_imu, t, gyro, accel, orientation_xyzw)
        was_stationary = self.stationarity.stationary
        stationary = self.stationarity.update_imu(t, sample, self.gyro_bias)
        if stationary != was_stationary:
            self.stationary_transitions += 1
            if not stationary:
                self._end_stationary()
        if stationary:
            self._guard.append((t, sample))
            horizon = t - self.config.stationary_guard
            while self._guard and self._guard[0][0] <= horizon:
                self._release(*self._guard.popleft())
        return self._corrected(t, sample)

    def _release(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample that survived the guard: to the noise density and the bank's queue."""
        self.noise.add(t, sample)
        if self._hypothesis_data is None:
            return
        if not self._stretches or self._stretches[-1].closed:
            self._stretches.append(_Stretch())
        stretch = self._stretches[-1]
        stretch.t.append(t)
        stretch.y.append(sample)

    def _end_stationary(self) -> None:
        """Motion or a gap: the guarded samples are discarded and the difference chain is broken."""
        self._guard.clear()
        self.noise.break_chain()
        if self._stretches:
            self._stretches[-1].closed = True

    def _corrected(self, t: float, sample: np.ndarray) -> CorrectedImu:
        gyro = sample[:3] - self.gyro_bias
        accel = sample[3:] - self.accel_bias
        if self._variance_cache is None:
            self._refresh_variance()
        gyro_var, accel_var = self._variance_cache
        return CorrectedImu(t, (float(gyro[0]), float(gyro[1]), float(gyro[2])),
                            (float(accel[0]), float(accel[1]), float(accel[2])), gyro_var, accel_var)

    def _refresh_variance(self) -> None:
        """Cache the covariance written into the corrected samples (refreshed every 100 IMU samples, by
        :meth:`update_identification` and after every odometry update, not per sample)."""
        variance, _ = self._covariance()
        if variance is None:
            self._variance_cache = (None, None)
        else:
            v = variance.tolist()
            self._variance_cache = (tuple(v[:3]), tuple(v[3:]))

    def _covariance(self) -> tuple[np.ndarray | None, str]:
        """N²·f per axis [u²] and its source: the stationary density once ``noise.min_samples`` differences
        exist, else the CMKF's √Ŝ while it is tracking, else None."""
        rate = self.imu_stamps.rate
        if not math.isfinite(rate):
            return None, "none"
        if self.noise.n >= self.config.noise_min_samples:
            return self.noise.density() ** 2 * rate, "stationary"
        est = self._cmkf_est
        if est.status == "tracking":
            return np.concatenate([est.S_g, est.S_v]) * rate, "cmkf"
        return None, "none"

    def process_odometry(
        self, t: float, linear_velocity: tuple[float, float, float], angular_velocity: tuple[float, float, float],
        frame_id: str = "", wall_time: float | None = None, *,
        position: tuple[float, float, float] | None = None,
        orientation_xyzw: tuple[float, float, float, float] | None = None,
        pose_covariance: np.ndarray | None = None, twist_covariance: np.ndarray | None = None,
    ) -> bool:
        """One odometry message (pose in the odom frame, twist in the child frame); False when rejected."""
        stats = self.odom_stats
        self._receive(stats, frame_id, wall_time, "odom")
        v = np.array((*linear_velocity, *angular_velocity), dtype=float)
        if not np.isfinite(v).all():
            stats.rejected_values += 1
            self._count("odom_nonfinite")
            self._event("odom_nonfinite", f"odom: message with non-finite twist at t = {t!r}")
            return False
        verdict = self._usable_stamp(self.odom_stamps, t, "odom")
        if verdict is None:
            return False
        stats.accepted += 1
        if verdict == "restart":
            self.stationarity.odom_t = None
        self.stationarity.update_odometry(
            t, math.sqrt(float(v[:3] @ v[:3])), math.sqrt(float(v[3:] @ v[3:]))
        )
        self._feed_cmkf(
            self._cmkf.process_odometry, t, position=position, orientation_xyzw=orientation_xyzw,
            linear_velocity=v[:3], angular_velocity=v[3:],
            pose_cov=None if pose_covariance is None else np.array(pose_covariance, dtype=float),
            twist_cov=None if twist_covariance is None else np.array(twist_covariance, dtype=float),
        )
        return True

    @property
    def cmkf(self) -> RobotCmkf:
        """The CMKF (fed through a stamp merger, ``cmkf.input_latency`` behind the newest IMU stamp)."""
        return self._cmkf.cmkf

    def _feed_cmkf(self, process: Callable[..., bool], *args: Any, **kwargs: Any) -> None:
        """One message to the CMKF's stamp merger, which passes on what is due (IMU and odometry arrive on two
        topics with different latencies); any error from the filter restarts it and is reported."""
        try:
            updated = process(*args, **kwargs)
        except (np.linalg.LinAlgError, ArithmeticError, ValueError) as exc:
            self.cmkf_errors += 1
            self._count("cmkf_error")
            self._event("cmkf_error", f"CMKF failed ({type(exc).__name__}: {exc}): restarting it")
            self._cmkf.restart()
            updated = True
        if updated:
            est = self.cmkf.estimate()
            self._cmkf_est = est
            if self.cmkf.filter.initialised:
                self.gyro_bias = est.gyro_bias
                self.accel_bias = est.accel_bias
            self._variance_cache = None

    def _on_cmkf_odometry(self, t: float, order: int) -> None:
        if order == TOO_LATE:  # the CMKF has propagated past it: not used
            self.odom_too_late += 1
            self._count("odom_too_late")
            self._event("odom_too_late", f"odom: message at t = {t:.6f} s arrived more than "
                        "cmkf.input_latency after the IMU: not used by the CMKF")

    def process_temperature(self, t: float, celsius: float, frame_id: str = "",
                            wall_time: float | None = None) -> bool:
        """One temperature message [°C]; False when it was rejected."""
        stats = self.temp_stats
        self._receive(stats, frame_id, wall_time, "temperature")
        if not math.isfinite(celsius):
            stats.rejected_values += 1
            self._event("temperature_nonfinite", f"temperature: non-finite value at t = {t!r}")
            return False
        if self._usable_stamp(self.temp_stamps, t, "temperature") is None:
            return False
        stats.accepted += 1
        self.temperature = celsius
        return True

    # -- the hypothesis bank (batched) ------------------------------------------------------------------------------
    def update_identification(self) -> None:
        """Feed the queued stationary samples to the per-axis hypothesis banks and refresh the CMKF status (the
        node calls it at ``publish_rate``; a batch costs much less than the same samples one by one)."""
        self._variance_cache = None
        self._cmkf_est = self.cmkf.estimate()  # its status changes without odometry updates too
        if self._hypothesis_data is None or not self._stretches:
            return
        rate = self.imu_stamps.rate
        if not math.isfinite(rate):
            return
        start = time.perf_counter()
        if self._banks is None:
            self._create_banks(1.0 / rate)
        keep: list[_Stretch] = []
        for stretch in self._stretches:
            if not stretch.t:
                if not stretch.closed:
                    keep.append(stretch)
                continue
            if stretch.accel_offset is None:
                if len(stretch.t) < self._bank_warmup and not stretch.closed:
                    keep.append(stretch)  # wait for its warm-up
                    continue
                n_warm = max(1, min(len(stretch.t), self._bank_warmup))
                stretch.accel_offset = np.mean(np.array(stretch.y[:n_warm])[:, 3:], axis=0)
                if self._accel_first_offset is None:
                    self._accel_first_offset = stretch.accel_offset
            self._feed_banks(np.array(stretch.t), np.array(stretch.y), stretch)
            stretch.t, stretch.y = [], []
            if not stretch.closed:
                keep.append(stretch)
        self._stretches = keep
        self.identification_time.add(time.perf_counter() - start)

    def _create_banks(self, dt: float) -> None:
        data, source = self._hypothesis_data["data"], self._hypothesis_data["source"]
        block = max(1, round(1.0 / (dt * self.config.hypotheses_bank_rate)))
        banks = []
        examples = []
        for axis in AXES:
            sensor = "gyro" if axis in GYRO_AXES else "accel"
            factory, warmup = hypothesis_set_factory(data, dt, sensor, source)

            def make(wn_estimate: float | None, factory: Any = factory) -> Any:
                return dataclasses.replace(factory(wn_estimate), block=block)

            banks.append(AxisIdentifier(make, warmup, dt=dt))
            examples.append(make(1.0))  # for the names only (an ``auto`` range needs some estimate)
            self._bank_warmup = banks[-1].n_warmup
        self._banks = banks
        self._bank_dt = dt
        names: list[str] = []
        params: list[str] = []
        for hset in examples:
            for hyp in hset.hypotheses:
                if hyp.name not in names:
                    names.append(hyp.name)
                for p in hyp.parameter_names:
                    if p not in params:
                        params.append(p)
        self._hypothesis_names = tuple(names)
        self._bank_parameters = tuple(params)

    def _feed_banks(self, t: np.ndarray, y: np.ndarray, stretch: _Stretch) -> None:
        dt = self._bank_dt
        if self._bank_last_t is not None:
            missing = round((t[0] - self._bank_last_t) / dt) - 1
            if missing > 0:
                for bank in self._banks:
                    bank.gap(missing)
        self._bank_last_t = float(t[-1])
        y = y.copy()
        y[:, 3:] += self._accel_first_offset - stretch.accel_offset
        for i, bank in enumerate(self._banks):
            column = y[:, i]
            if bank.bank is None and column.size < bank.n_warmup:
                column = np.concatenate([np.full(bank.n_warmup - column.size, column.mean()), column])
            bank.run(column)
            decision = bank.bank.snapshot().decision
            previous = self._decisions[i]
            if decision != previous:
                if previous is not None:
                    text = f"{AXES[i]}: hypothesis decision changed from {previous} to {decision or 'undecided'}"
                    self.decision_changes.append(text)
                    self._event(f"decision_{AXES[i]}", text)
                self._decisions[i] = decision

    def hypotheses(self) -> HypothesesReport | None:
        """Posterior probabilities and decisions per axis, or None before the banks exist."""
        if self._banks is None:
            return None
        names = self._hypothesis_names
        probs = np.full((6, len(names)), math.nan)
        decision = np.full(6, -1.0)
        updates = np.zeros(6)
        for i, bank in enumerate(self._banks):
            if bank.bank is None:
                continue
            snap = bank.bank.snapshot()
            updates[i] = snap.n_updates
            if snap.n_updates == 0:
                continue
            for name, p in snap.probabilities.items():
                probs[i, names.index(name)] = p
            if snap.decision is not None:
                decision[i] = names.index(snap.decision)
        return HypothesesReport(names, probs, decision, updates)

    def _bank_theta(self) -> dict[str, np.ndarray]:
        if self._banks is None:
            return {}
        theta = {p: np.full(6, math.nan) for p in self._bank_parameters}
        for i, bank in enumerate(self._banks):
            if bank.bank is None:
                continue
            snap = bank.bank.snapshot()
            if snap.n_updates == 0:
                continue
            best = max(snap.probabilities, key=snap.probabilities.get)
            for p, value in snap.hypotheses[best].theta.items():
                theta[p][i] = value
        return theta

    # -- outputs ----------------------------------------------------------------------------------------------------
    def estimates(self) -> Estimates:
        """The current estimates (copies)."""
        enough = self.noise.n >= self.config.noise_min_samples
        est = self._cmkf_est
        known = self.cmkf.filter.initialised
        nan3 = np.full(3, math.nan)
        covariance, source = self._covariance()
        return Estimates(
            t=self.last_imu_t,
            cmkf_status=est.status,
            gyro_bias=est.gyro_bias.copy() if known else nan3.copy(),
            gyro_bias_std=est.gyro_bias_std.copy() if known else nan3.copy(),
            accel_bias=est.accel_bias.copy() if known else nan3.copy(),
            accel_bias_std=est.accel_bias_std.copy() if known else nan3.copy(),
            noise_density=self.noise.density() if enough else np.full(6, math.nan),
            noise_density_rstd=self.noise.relative_std() if enough else math.nan,
            noise_samples=self.noise.n,
            psd=np.concatenate([est.S_g, est.S_v]) if known else np.full(6, math.nan),
            covariance=covariance if covariance is not None else np.full(6, math.nan),
            covariance_source=source,
            imu_rate=self.imu_stamps.rate,
            stationary=self.stationarity.stationary,
            bank_theta=self._bank_theta(),
        )

    def diagnostics(self, wall_now: float, window_s: float) -> list[DiagnosticStatus]:
        """Statuses per function, computed at steady-clock time ``wall_now`` over the last ``window_s`` seconds.

        Resets the per-window counters (received messages, stamp problems, decision changes).
        """
        cfg = self.config
        statuses = [
            self._input_status("IMU input", self.imu_stats, self.imu_stamps, wall_now, window_s,
                               cfg.expected_imu_rate, required=True),
            self._input_status("Odometry input", self.odom_stats, self.odom_stamps, wall_now, window_s,
                               cfg.expected_odom_rate, required=cfg.stationary_require_odometry),
        ]
        if self.temp_stats.received:
            statuses.append(self._input_status("Temperature input", self.temp_stats, self.temp_stamps, wall_now,
                                               window_s, 0.0, required=False))
        statuses.append(self._stamp_status())
        statuses.append(self._stationarity_status())
        statuses.append(self._consistency_status())
        statuses.append(self._noise_status())
        statuses.append(self._hypotheses_status())
        statuses.append(self._range_status())
        statuses.append(self._processing_status())
        for stats in (self.imu_stats, self.odom_stats, self.temp_stats):
            stats.window_received = 0
        self._window_stamp_counts = {}
        self.decision_changes = []
        return statuses

    def _input_status(self, name: str, stats: InputStats, stamps: StampChecker, wall_now: float,  # noqa: PLR0917
                      window_s: float, expected_rate: float, required: bool) -> DiagnosticStatus:
        rate = stats.window_received / window_s if window_s > 0 else math.nan
        values = {
            "received": str(stats.received),
            "accepted": str(stats.accepted),
            "rate_received_hz": f"{rate:.2f}",
            "rate_header_hz": f"{stamps.rate:.3f}",
            "rejected_nonfinite": str(stats.rejected_values),
            "frame_id": stats.frame_id or "",
            "frame_id_changes": str(stats.frame_changes),
        }
        if stats.last_wall is None:
            level = STALE if required else WARN
            message = "no message received yet"
            if name.startswith("Odometry"):
                message += ": no CMKF update; stationarity from the IMU alone"
            return DiagnosticStatus(name, level, message, values)
        silent = wall_now - stats.last_wall
        values["seconds_since_last"] = f"{silent:.2f}"
        if silent > self.config.stale_timeout:
            return DiagnosticStatus(name, STALE if required else WARN, f"no message for {silent:.1f} s", values)
        if expected_rate > 0 and rate < 0.8 * expected_rate:
            return DiagnosticStatus(name, WARN, f"rate {rate:.1f} Hz below the expected {expected_rate:g} Hz",
                                    values)
        if stats.frame_changes:
            return DiagnosticStatus(name, WARN, f"frame_id changed {stats.frame_changes} time(s), now "
                                    f"{stats.frame_id!r}", values)
        return DiagnosticStatus(name, OK, f"{rate:.1f} Hz", values)

    def _stamp_status(self) -> DiagnosticStatus:
        counts = self._window_stamp_counts
        values = {f"window_{k}": str(v) for k, v in sorted(counts.items())}
        for what, checker in (("imu", self.imu_stamps), ("odom", self.odom_stamps)):
            for k, v in checker.counts.items():
                if k != "ok":
                    values[f"total_{what}_{k}"] = str(v)
        values["restarts"] = str(self.restarts)
        if counts:
            summary = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in sorted(counts.items()))
            return DiagnosticStatus("Time stamps", WARN, f"in the last period: {summary}", values)
        return DiagnosticStatus("Time stamps", OK, "monotonic, no gaps", values)

    def _stationarity_status(self) -> DiagnosticStatus:
        st = self.stationarity
        values = {
            "stationary": str(st.stationary).lower(),
            "imu_still": str(st.imu_still).lower(),
            "odometry_fresh": str(st.odom_fresh).lower(),
            "odometry_still": str(st.odom_still).lower(),
            "transitions": str(self.stationary_transitions),
        }
        if st.stationary:
            held = self.last_imu_t - st.stationary_since
            values["stationary_for_s"] = f"{held:.1f}"
            return DiagnosticStatus("Stationarity", OK, f"stationary for {held:.1f} s: identification running",
                                    values)
        return DiagnosticStatus("Stationarity", OK, "moving or settling: identification paused", values)

    def _consistency_status(self) -> DiagnosticStatus:  # noqa: PLR0911 - one return per verdict
        """Normalised innovation squared of the CMKF over its last ``nis.window`` updates against χ² bounds."""
        est = self._cmkf_est
        n = min(est.counters.get("updates", 0), self.config.nis_window)
        values = {"cmkf_status": est.status, "updates": str(est.counters.get("updates", 0)),
                  "stacked_samples": str(est.n_stacked), "nis_accel_mean": f"{est.nis_accel_mean:.3f}",
                  "nis_accel_dof": str(est.nis_accel_dof), "nis_gyro_last": f"{est.nis_gyro:.3f}"}
        for key, count in est.counters.items():
            if count and key not in ("imu", "odom", "updates"):
                values[f"cmkf_{key}"] = str(count)
        name = "Filter consistency"
        values["cmkf_restarts_after_errors"] = str(self.cmkf_errors)
        values["odom_too_late_for_cmkf"] = str(self.odom_too_late)
        if self._window_stamp_counts.get("cmkf_error"):
            return DiagnosticStatus(name, ERROR, "the CMKF raised an error and was restarted (see the log)", values)
        if est.status in ("no_data", "no_imu", "imu_only"):
            return DiagnosticStatus(name, WARN, f"CMKF not running ({est.status.replace('_', ' ')}): it needs "
                                    "IMU and odometry", values)
        if est.status == "unobserved":
            return DiagnosticStatus(name, WARN, "no odometry update recently: biases are predicted only", values)
        if n < 10 or not math.isfinite(est.nis_accel_mean):
            return DiagnosticStatus(name, OK, f"converging ({n} updates)", values)
        low, high = nis_bounds(est.nis_accel_dof, n)
        values["nis_bounds_95"] = f"[{low:.3f}, {high:.3f}]"
        mean = est.nis_accel_mean
        if mean > 10.0 * est.nis_accel_dof:
            return DiagnosticStatus(name, ERROR, f"NIS mean {mean:.2f} ≫ {est.nis_accel_dof}: the filter's noise "
                                    "model does not fit the data (check cmkf.* and the odometry covariance)", values)
        if not low <= mean <= high:
            return DiagnosticStatus(name, WARN, f"NIS mean {mean:.2f} outside its 95 % bounds [{low:.2f}, "
                                    f"{high:.2f}] over {n} updates", values)
        return DiagnosticStatus(name, OK, f"NIS mean {mean:.2f} inside [{low:.2f}, {high:.2f}]", values)

    def _noise_status(self) -> DiagnosticStatus:
        n = self.noise.n
        need = self.config.noise_min_samples
        _, source = self._covariance()
        values = {"stationary_samples": str(n), "needed": str(need), "covariance_source": source}
        if n < need:
            return DiagnosticStatus("Noise density", WARN, f"collecting stationary samples ({n}/{need}); "
                                    f"corrected IMU covariance from: {source}", values)
        density = self.noise.density()
        for axis, value in zip(AXES, density, strict=True):
            values[f"{axis}_noise_density"] = f"{value:.4g}"
        values["relative_std"] = f"{self.noise.relative_std():.3g}"
        return DiagnosticStatus("Noise density", OK, f"estimated from {n} stationary samples", values)

    def _hypotheses_status(self) -> DiagnosticStatus:
        name = "Hypotheses"
        if self._hypothesis_data is None:
            return DiagnosticStatus(name, OK, "hypothesis bank disabled (hypotheses.enabled: false)")
        report = self.hypotheses()
        if report is None:
            return DiagnosticStatus(name, OK, "waiting for stationary samples")
        values = {}
        decided = []
        for i, axis in enumerate(AXES):
            k = int(report.decision[i])
            values[f"{axis}_decision"] = report.names[k] if k >= 0 else "undecided"
            values[f"{axis}_updates"] = str(int(report.updates[i]))
            if k >= 0:
                decided.append(f"{axis} {report.names[k]}")
        if self.decision_changes:
            return DiagnosticStatus(name, WARN, "; ".join(self.decision_changes), values)
        if len(decided) == 6:
            return DiagnosticStatus(name, OK, "decided: " + ", ".join(decided), values)
        return DiagnosticStatus(name, OK, f"{len(decided)}/6 axes decided", values)

    def _range_status(self) -> DiagnosticStatus:
        cfg = self.config
        est = self.estimates()
        problems = []
        for axis, value in zip(GYRO_AXES, est.gyro_bias, strict=True):
            if abs(value) > cfg.expected_gyro_bias_max:
                problems.append(f"{axis} bias {value:.3g} rad/s > {cfg.expected_gyro_bias_max:g}")
        for axis, value in zip(ACCEL_AXES, est.accel_bias, strict=True):
            if abs(value) > cfg.expected_accel_bias_max:
                problems.append(f"{axis} bias {value:.3g} m/s^2 > {cfg.expected_accel_bias_max:g}")
        for axis, value in zip(AXES, est.noise_density, strict=True):
            limit = cfg.expected_gyro_noise_density_max if axis in GYRO_AXES else cfg.expected_accel_noise_density_max
            if value > limit:
                problems.append(f"{axis} noise density {value:.3g} > {limit:g}")
        values = {"problems": str(len(problems))}
        if problems:
            return DiagnosticStatus("Estimate ranges", WARN, "; ".join(problems), values)
        return DiagnosticStatus("Estimate ranges", OK, "estimates inside the expected ranges", values)

    def _processing_status(self) -> DiagnosticStatus:
        pt = self.processing_time
        it = self.identification_time
        values = {
            "callbacks": str(pt.count),
            "callback_p50_us": f"{pt.percentile(50) * 1e6:.1f}",
            "callback_p99_us": f"{pt.percentile(99) * 1e6:.1f}",
            "callback_max_us": f"{float(pt.values().max()) * 1e6:.1f}" if pt.count else "nan",
            "bank_batches": str(it.count),
            "bank_batch_p50_us": f"{it.percentile(50) * 1e6:.1f}",
            "bank_batch_max_us": f"{float(it.values().max()) * 1e6:.1f}" if it.count else "nan",
        }
        return DiagnosticStatus("Processing", OK, f"p99 {values['callback_p99_us']} us per IMU callback", values)
