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
2. Stationarity with hysteresis (:class:`StationarityDetector`): the odometry twist (when fresh) and
   exponentially weighted IMU statistics must both say "still" for ``stationary.enter_delay`` seconds; any
   sign of motion ends the stationary state at once.
3. Stationary samples pass a delay line of ``stationary.guard`` seconds before they reach the noise
   identification, and the line is emptied when motion is detected, so the last samples before a start —
   already disturbed but not yet detected — never reach it.
4. Noise density per axis from the stationary samples (:class:`AllanTau0NoiseDensity`).
5. Bias correction and the covariance N²·f of the corrected sample (REP-145: zeros mean "unknown").
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.axes import ACCEL_AXES, AXES, GYRO_AXES
from ..core.errors import InputError

# Diagnostic levels, equal to diagnostic_msgs/DiagnosticStatus.{OK, WARN, ERROR, STALE}.
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}


# --------------------------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ParamSpec:
    """One tunable: ROS parameter name, default, closed range, unit and whether it may change at runtime."""

    name: str
    default: float | int | bool | str
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    runtime: bool = True

    @property
    def attr(self) -> str:
        """Attribute name in :class:`OnlineConfig` (dots become underscores)."""
        return self.name.replace(".", "_")

    def check(self, value: Any) -> str | None:
        """The reason ``value`` is not acceptable, or None when it is."""
        kind = type(self.default)
        if kind is bool:
            if not isinstance(value, bool):
                return f"{self.name} must be true or false, got {value!r}"
            return None
        if kind is str:
            return None if isinstance(value, str) else f"{self.name} must be a string, got {value!r}"
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"{self.name} must be a number, got {value!r}"
        if kind is int and not float(value).is_integer():
            return f"{self.name} must be an integer, got {value!r}"
        if not math.isfinite(float(value)):
            return f"{self.name} must be finite, got {value!r}"
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            return f"{self.name} = {value!r} is outside its range [{self.low}, {self.high}] {self.unit}".rstrip()
        return None


PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("stationary.max_linear_speed", 0.02, "odometry |linear twist| below which the base is still",
              "m/s", 0.0, 10.0),
    ParamSpec("stationary.max_angular_speed", 0.02, "odometry |angular twist| below which the base is still",
              "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_gyro_rate", 0.05, "|mean angular rate − gyro bias| below which the IMU is still",
              "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_gyro_std", 0.05, "per-axis angular-rate standard deviation (over "
              "stationary.window) below which the IMU is still", "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_accel_std", 0.3, "per-axis specific-force standard deviation (over "
              "stationary.window) below which the IMU is still", "m/s^2", 0.0, 100.0),
    ParamSpec("stationary.window", 0.5, "time constant of the exponentially weighted IMU statistics", "s",
              0.01, 60.0),
    ParamSpec("stationary.enter_delay", 1.0, "hysteresis: the evidence must say 'still' this long before the "
              "platform counts as stationary", "s", 0.0, 600.0),
    ParamSpec("stationary.guard", 0.5, "stationary samples wait this long before the noise identification "
              "uses them; they are dropped if motion starts meanwhile", "s", 0.0, 60.0),
    ParamSpec("stationary.require_odometry", False, "true: never stationary without fresh odometry; false: "
              "decide from the IMU statistics alone when odometry is absent"),
    ParamSpec("odom_timeout", 0.5, "odometry older than this (header stamps, against the IMU stamp) counts "
              "as absent", "s", 0.01, 60.0),
    ParamSpec("gap_factor", 10.0, "a period longer than gap_factor × the nominal IMU period is a gap", "",
              1.5, 1000.0),
    ParamSpec("backward_reset_count", 50, "this many consecutive backward stamps mean the source restarted: "
              "the identification restarts on the new time base", "messages", 2, 100000),
    ParamSpec("stale_timeout", 2.0, "no message for this long (steady clock) makes an input STALE", "s",
              0.1, 3600.0),
    ParamSpec("expected_imu_rate", 0.0, "IMU rate expected [Hz]; a received rate below 80 % of it is a "
              "warning (0: not checked)", "Hz", 0.0, 100000.0),
    ParamSpec("expected_odom_rate", 0.0, "odometry rate expected; a received rate below 80 % of it is a "
              "warning (0: not checked)", "Hz", 0.0, 100000.0),
    ParamSpec("expected.gyro_bias_max", 0.1, "|gyro bias| above this on any axis is reported", "rad/s",
              0.0, 100.0),
    ParamSpec("expected.accel_bias_max", 0.5, "|accelerometer bias| above this on any axis is reported",
              "m/s^2", 0.0, 100.0),
    ParamSpec("expected.gyro_noise_density_max", 0.01, "gyro noise density above this is reported",
              "rad/s/sqrt(Hz)", 0.0, 100.0),
    ParamSpec("expected.accel_noise_density_max", 0.1, "accelerometer noise density above this is reported",
              "m/s^2/sqrt(Hz)", 0.0, 1000.0),
    ParamSpec("noise.min_samples", 200, "stationary samples needed before a noise density is published and "
              "used for the corrected IMU covariance", "samples", 10, 10000000),
    ParamSpec("nis.window", 100, "number of filter updates in the normalised-innovation-squared window",
              "updates", 10, 100000),
    ParamSpec("publish_rate", 10.0, "rate of ~/accel_bias, ~/gyro_bias, ~/noise and ~/hypotheses (steady "
              "clock)", "Hz", 0.1, 1000.0, runtime=False),
    ParamSpec("diagnostics_period", 1.0, "period of /diagnostics (steady clock)", "s", 0.05, 60.0,
              runtime=False),
    ParamSpec("log_throttle", 5.0, "minimum time between two log lines about the same input problem", "s",
              0.0, 3600.0),
    ParamSpec("imu_queue_depth", 200, "subscription queue depth of the IMU topic (sensor-data QoS)",
              "messages", 100, 100000, runtime=False),
    ParamSpec("odom_queue_depth", 100, "subscription queue depth of the odometry and temperature topics",
              "messages", 1, 100000, runtime=False),
)

PARAMETER_BY_NAME: dict[str, ParamSpec] = {p.name: p for p in PARAMETERS}


@dataclass
class OnlineConfig:
    """Validated parameter values; attribute names are the parameter names with dots replaced by ``_``."""

    values: dict[str, Any] = field(default_factory=lambda: {p.name: p.default for p in PARAMETERS})

    def __post_init__(self) -> None:
        merged = {p.name: p.default for p in PARAMETERS}
        unknown = sorted(set(self.values) - set(merged))
        if unknown:
            raise InputError(f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(merged))}")
        merged.update(self.values)
        for name, value in merged.items():
            spec = PARAMETER_BY_NAME[name]
            if type(spec.default) is float and isinstance(value, int) and not isinstance(value, bool):
                value = float(value)
                merged[name] = value
            reason = spec.check(value)
            if reason:
                raise InputError(f"parameter {reason}")
        self.values = merged

    def __getattr__(self, attr: str) -> Any:
        values = self.__dict__.get("values")
        if values is not None:
            name = _ATTR_TO_NAME.get(attr)
            if name is not None:
                return values[name]
        raise AttributeError(attr)

    def updated(self, changes: dict[str, Any]) -> OnlineConfig:
        """A new configuration with ``changes`` applied.

        Raises
        ------
        InputError
            If a name is unknown, a value is invalid or the parameter cannot change at runtime.
        """
        for name in changes:
            spec = PARAMETER_BY_NAME.get(name)
            if spec is not None and not spec.runtime:
                raise InputError(f"parameter {name} cannot change at runtime: restart the node to change it")
        return OnlineConfig({**self.values, **changes})


_ATTR_TO_NAME = {p.attr: p.name for p in PARAMETERS}


# --------------------------------------------------------------------------------------------------------------
# Building blocks
# --------------------------------------------------------------------------------------------------------------
@dataclass
class StampChecker:
    """Header-stamp checks for one input stream.

    ``check(t)`` returns ``"ok"``, ``"gap"`` (accepted, after a period longer than ``gap_factor`` × the
    nominal period), ``"restart"`` (accepted: ``backward_reset_count`` consecutive backward stamps mean the
    source restarted), or the reason for rejecting the message: ``"bad_stamp"`` (zero or not finite),
    ``"duplicate"`` or ``"backward"``.
    """

    gap_factor: float = 10.0
    backward_reset_count: int = 50
    last: float | None = None
    period: float | None = None
    consecutive_backward: int = 0
    counts: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(("ok", "gap", "restart", "bad_stamp", "duplicate", "backward"), 0)
    )

    def check(self, t: float) -> str:
        verdict = self._verdict(t)
        self.counts[verdict] += 1
        return verdict

    def _verdict(self, t: float) -> str:
        if not math.isfinite(t) or t <= 0.0:
            return "bad_stamp"
        last = self.last
        if last is None:
            self.last = t
            return "ok"
        dt = t - last
        if dt == 0.0:
            return "duplicate"
        if dt < 0.0:
            self.consecutive_backward += 1
            if self.consecutive_backward >= self.backward_reset_count:
                self.consecutive_backward = 0
                self.last = t
                self.period = None
                return "restart"
            return "backward"
        self.consecutive_backward = 0
        self.last = t
        period = self.period
        if period is None:
            self.period = dt
            return "ok"
        if dt > self.gap_factor * period:
            return "gap"
        self.period = period + 0.01 * (dt - period)
        return "ok"

    @property
    def rate(self) -> float:
        """Nominal rate from the header stamps [Hz] (NaN until two stamps were seen)."""
        return 1.0 / self.period if self.period else math.nan


@dataclass
class StationarityDetector:
    """Stationary / moving decision from the odometry twist and the IMU statistics, with hysteresis.

    The IMU says "still" when the exponentially weighted (time constant ``window``) standard deviation of every
    gyro axis is below ``max_gyro_std``, of every accelerometer axis below ``max_accel_std``, and the weighted
    mean angular rate minus the current gyro bias estimate is below ``max_gyro_rate`` in norm (a constant turn
    has a small standard deviation). Fresh odometry (stamp within ``odom_timeout`` of the IMU stamp) says
    "still" when its linear and angular speeds are below their thresholds; without fresh odometry the IMU
    decides alone unless ``require_odometry``. The platform becomes stationary after the evidence said "still"
    for ``enter_delay`` seconds without interruption and stops being stationary at the first contrary sample.
    """

    config: OnlineConfig
    stationary: bool = False
    still_since: float | None = None
    stationary_since: float | None = None
    odom_t: float | None = None
    odom_still: bool = False
    odom_fresh: bool = False
    imu_still: bool = False
    _mean: np.ndarray | None = None
    _var: np.ndarray | None = None
    _last_t: float | None = None

    def reset(self) -> None:
        """Forget the IMU statistics and the hysteresis (after a gap or a restart); keep the odometry."""
        self.stationary = False
        self.still_since = None
        self.stationary_since = None
        self._mean = None
        self._var = None
        self._last_t = None

    def update_odometry(self, t: float, linear_speed: float, angular_speed: float) -> None:
        if self.odom_t is not None and t < self.odom_t:
            return
        cfg = self.config
        self.odom_t = t
        self.odom_still = (linear_speed <= cfg.stationary_max_linear_speed
                           and angular_speed <= cfg.stationary_max_angular_speed)

    def update_imu(self, t: float, sample: np.ndarray, gyro_bias: np.ndarray) -> bool:
        """Add one IMU sample (6 values in :data:`~imu_noise_id.core.axes.AXES` order); the new state."""
        cfg = self.config
        if self._mean is None:
            self._mean = sample.copy()
            self._var = np.zeros(6)
            self._last_t = t
            self.imu_still = False
        else:
            alpha = min(1.0, (t - self._last_t) / cfg.stationary_window)
            self._last_t = t
            delta = sample - self._mean
            self._mean += alpha * delta
            self._var = (1.0 - alpha) * (self._var + alpha * delta * delta)
            std = np.sqrt(self._var)
            turn = self._mean[:3] - gyro_bias
            self.imu_still = bool(
                std[0] <= cfg.stationary_max_gyro_std and std[1] <= cfg.stationary_max_gyro_std
                and std[2] <= cfg.stationary_max_gyro_std and std[3] <= cfg.stationary_max_accel_std
                and std[4] <= cfg.stationary_max_accel_std and std[5] <= cfg.stationary_max_accel_std
                and math.sqrt(float(turn @ turn)) <= cfg.stationary_max_gyro_rate
            )
        self.odom_fresh = self.odom_t is not None and abs(t - self.odom_t) <= cfg.odom_timeout
        if self.odom_fresh:
            still = self.imu_still and self.odom_still
        else:
            still = self.imu_still and not cfg.stationary_require_odometry
        if not still:
            self.still_since = None
            self.stationary = False
            self.stationary_since = None
            return False
        if self.still_since is None:
            self.still_since = t
        if not self.stationary and t - self.still_since >= cfg.stationary_enter_delay:
            self.stationary = True
            self.stationary_since = t
        return self.stationary


@dataclass
class AllanTau0NoiseDensity:
    """White-noise density per axis from consecutive stationary samples: the Allan variance at τ = Δt.

    σ²_A(Δt) = ½·E[(y_{k+1} − y_k)²] equals the per-sample white-noise variance σ² (IEEE Std 952), and the
    density is N = √(σ²·Δt) (:func:`imu_noise_id.core.units.white_noise_density`). Differences remove the bias
    and attenuate slow drifts (RW, GM with τ ≫ Δt); quantisation noise and vibration present while the platform
    stands still are included, which is what the covariance of the corrected IMU must carry. Only differences of
    samples from one uninterrupted stationary stretch are used (:meth:`break_chain` between stretches).
    """

    sum_d2: np.ndarray = field(default_factory=lambda: np.zeros(6))
    n: int = 0
    sum_dt: float = 0.0
    _prev: np.ndarray | None = None
    _prev_t: float = 0.0

    def add(self, t: float, sample: np.ndarray) -> None:
        prev = self._prev
        if prev is not None:
            d = sample - prev
            self.sum_d2 += d * d
            self.n += 1
            self.sum_dt += t - self._prev_t
        self._prev = sample
        self._prev_t = t

    def break_chain(self) -> None:
        self._prev = None

    def noise_density(self) -> np.ndarray:
        """N per axis [u/√Hz] (NaN before the first difference)."""
        if self.n == 0:
            return np.full(6, math.nan)
        sigma2 = 0.5 * self.sum_d2 / self.n
        return np.sqrt(sigma2 * (self.sum_dt / self.n))

    def relative_std(self) -> float:
        """Approximate relative standard deviation of N for white noise: √(3/n)/2.

        For Gaussian white noise d_k = y_{k+1} − y_k has var(d_k²) = 8σ⁴ and cov(d_k², d_{k+1}²) = 2σ⁴, so
        var(σ̂²) = var(Σd²/2n) ≈ 12nσ⁴/4n² = 3σ⁴/n; N ∝ √σ̂² halves the relative error.
        """
        return math.sqrt(3.0 / self.n) / 2.0 if self.n else math.nan


@dataclass
class WindowStats:
    """Percentiles over the last ``size`` values of a stream of numbers (processing times, NIS)."""

    size: int = 4096
    _buf: np.ndarray | None = None
    _i: int = 0
    count: int = 0

    def add(self, value: float) -> None:
        if self._buf is None or self._buf.shape[0] != self.size:
            self._buf = np.empty(self.size)
            self._i = 0
        self._buf[self._i] = value
        self._i = (self._i + 1) % self.size
        self.count += 1

    def values(self) -> np.ndarray:
        if self._buf is None:
            return np.empty(0)
        return self._buf[: min(self.count, self.size)]

    def percentile(self, q: float) -> float:
        v = self.values()
        return float(np.percentile(v, q)) if v.size else math.nan


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
    """Current estimates, SI units, axes in :data:`~imu_noise_id.core.axes.AXES` order where per axis.

    Attributes
    ----------
    t : header stamp of the last IMU sample used [s]
    gyro_bias, gyro_bias_std : (3,) [rad/s] (NaN when not estimated)
    accel_bias, accel_bias_std : (3,) [m/s²] (NaN when not estimated)
    noise_density : (6,) white-noise density [u/√Hz] from stationary samples (NaN before ``noise.min_samples``)
    noise_density_rstd : relative standard deviation of ``noise_density``
    noise_samples : number of stationary sample differences used
    imu_rate : nominal IMU rate from the header stamps [Hz]
    velocity_random_walk_psd : (3,) S_v per accelerometer axis [m²/s³] (NaN when not estimated)
    velocity_random_walk_psd_std : (3,) its standard deviation [m²/s³]
    stationary : whether the platform is stationary now
    """

    t: float
    gyro_bias: np.ndarray
    gyro_bias_std: np.ndarray
    accel_bias: np.ndarray
    accel_bias_std: np.ndarray
    noise_density: np.ndarray
    noise_density_rstd: float
    noise_samples: int
    imu_rate: float
    velocity_random_walk_psd: np.ndarray
    velocity_random_walk_psd_std: np.ndarray
    stationary: bool

    #: Column labels of :meth:`noise_table`, in order.
    NOISE_FIELDS: tuple[str, ...] = (
        "noise_density", "noise_density_rstd", "covariance", "bias", "bias_std", "S_v", "S_v_std",
        "stationary_samples",
    )

    def noise_table(self) -> np.ndarray:
        """(6, len(NOISE_FIELDS)) array: per axis (rows in AXES order) the fields of :attr:`NOISE_FIELDS`.

        ``covariance`` is N²·f [u²]; ``S_v`` and ``S_v_std`` are NaN on gyro axes.
        """
        table = np.full((6, len(self.NOISE_FIELDS)), math.nan)
        table[:, 0] = self.noise_density
        table[:, 1] = self.noise_density_rstd
        table[:, 2] = self.noise_density**2 * self.imu_rate
        table[:3, 3] = self.gyro_bias
        table[3:, 3] = self.accel_bias
        table[:3, 4] = self.gyro_bias_std
        table[3:, 4] = self.accel_bias_std
        table[3:, 5] = self.velocity_random_walk_psd
        table[3:, 6] = self.velocity_random_walk_psd_std
        table[:, 7] = self.noise_samples
        return table


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


# --------------------------------------------------------------------------------------------------------------
# The identifier
# --------------------------------------------------------------------------------------------------------------
class OnlineIdentifier:
    """Streaming identification of a robot's IMU errors; see the module docstring for the per-sample steps.

    Parameters
    ----------
    config : OnlineConfig
        Validated parameters (:data:`PARAMETERS`).
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
        self.temperature = math.nan
        self.restarts = 0
        self._window_stamp_counts: dict[str, int] = {}
        self._events: deque[tuple[str, str]] = deque(maxlen=100)
        self._reset_estimation()

    # -- configuration ---------------------------------------------------------------------------------------
    def set_config(self, config: OnlineConfig) -> None:
        """Apply a new (validated) configuration at runtime; the estimates are kept."""
        self.config = config
        self.stationarity.config = config
        for checker in (self.imu_stamps, self.odom_stamps, self.temp_stamps):
            checker.gap_factor = config.gap_factor
            checker.backward_reset_count = config.backward_reset_count

    def _reset_estimation(self) -> None:
        self.stationarity = StationarityDetector(self.config)
        self.noise = AllanTau0NoiseDensity()
        self._guard: deque[tuple[float, np.ndarray]] = deque()
        self.gyro_bias = np.zeros(3)
        self.last_imu_t = math.nan
        self.stationary_transitions = 0

    # -- events for the node's (rate-limited) log -----------------------------------------------------------------
    def _event(self, key: str, text: str) -> None:
        self._events.append((key, text))

    def pop_events(self) -> list[tuple[str, str]]:
        """Input problems seen since the last call, as (key, message); the node logs them rate-limited by key."""
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

    def _stamp_verdict(self, checker: StampChecker, t: float, what: str) -> str:
        verdict = checker.check(t)
        if verdict not in ("ok",):
            key = f"{what}_{verdict}"
            self._window_stamp_counts[key] = self._window_stamp_counts.get(key, 0) + 1
            if verdict == "gap":
                self._event(key, f"{what}: gap in header stamps before t = {t:.6f} s")
            elif verdict == "restart":
                self._event(key, f"{what}: stamps jumped back to t = {t:.6f} s and stayed there: restarting")
            else:
                self._event(key, f"{what}: message dropped ({verdict.replace('_', ' ')} stamp {t!r})")
        return verdict

    def process_imu(
        self, t: float, gyro: tuple[float, float, float], accel: tuple[float, float, float],
        frame_id: str = "", wall_time: float | None = None,
    ) -> CorrectedImu | None:
        """One IMU message: header stamp ``t`` [s], angular rate [rad/s], specific force [m/s²].

        Returns the bias-corrected sample, or None when the message was rejected (counted, and reported through
        :meth:`pop_events` and the diagnostics).
        """
        stats = self.imu_stats
        stats.received += 1
        stats.window_received += 1
        stats.last_wall = wall_time
        self._note_frame(stats, frame_id, "imu")
        sample = np.array((*gyro, *accel), dtype=float)
        if not np.isfinite(sample).all():
            stats.rejected_values += 1
            self._window_stamp_counts["imu_nonfinite"] = self._window_stamp_counts.get("imu_nonfinite", 0) + 1
            self._event("imu_nonfinite", f"imu: message with non-finite angular rate or acceleration at t = {t!r}")
            return None
        verdict = self._stamp_verdict(self.imu_stamps, t, "imu")
        if verdict in ("bad_stamp", "duplicate", "backward"):
            return None
        if verdict == "restart":
            self.restarts += 1
            self._reset_estimation()
        elif verdict == "gap":
            self._end_stationary()
            self.stationarity.reset()
        stats.accepted += 1
        self.last_imu_t = t
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
                ts, s = self._guard.popleft()
                self.noise.add(ts, s)
        return self._corrected(t, sample)

    def _end_stationary(self) -> None:
        """Motion or a gap: the guarded samples are discarded and the difference chain is broken."""
        self._guard.clear()
        self.noise.break_chain()

    def _corrected(self, t: float, sample: np.ndarray) -> CorrectedImu:
        gyro = sample[:3] - self.gyro_bias
        accel = sample[3:]
        variance = self.covariance_diagonal()
        gyro_var = accel_var = None
        if variance is not None:
            gyro_var = (float(variance[0]), float(variance[1]), float(variance[2]))
            accel_var = (float(variance[3]), float(variance[4]), float(variance[5]))
        return CorrectedImu(t, (float(gyro[0]), float(gyro[1]), float(gyro[2])),
                            (float(accel[0]), float(accel[1]), float(accel[2])), gyro_var, accel_var)

    def covariance_diagonal(self) -> np.ndarray | None:
        """N²·f per axis [u²] from the current noise densities, or None before ``noise.min_samples``."""
        if self.noise.n < self.config.noise_min_samples:
            return None
        rate = self.imu_stamps.rate
        if not math.isfinite(rate):
            return None
        return self.noise.noise_density() ** 2 * rate

    def process_odometry(
        self, t: float, linear_velocity: tuple[float, float, float], angular_velocity: tuple[float, float, float],
        frame_id: str = "", wall_time: float | None = None,
    ) -> bool:
        """One odometry message (twist in the child frame); False when it was rejected."""
        stats = self.odom_stats
        stats.received += 1
        stats.window_received += 1
        stats.last_wall = wall_time
        self._note_frame(stats, frame_id, "odom")
        v = np.array((*linear_velocity, *angular_velocity), dtype=float)
        if not np.isfinite(v).all():
            stats.rejected_values += 1
            self._window_stamp_counts["odom_nonfinite"] = self._window_stamp_counts.get("odom_nonfinite", 0) + 1
            self._event("odom_nonfinite", f"odom: message with non-finite twist at t = {t!r}")
            return False
        verdict = self._stamp_verdict(self.odom_stamps, t, "odom")
        if verdict in ("bad_stamp", "duplicate", "backward"):
            return False
        stats.accepted += 1
        if verdict == "restart":
            self.stationarity.odom_t = None
        self.stationarity.update_odometry(
            t, math.sqrt(float(v[:3] @ v[:3])), math.sqrt(float(v[3:] @ v[3:]))
        )
        return True

    def process_temperature(self, t: float, celsius: float, frame_id: str = "",
                            wall_time: float | None = None) -> bool:
        """One temperature message [°C]; False when it was rejected."""
        stats = self.temp_stats
        stats.received += 1
        stats.window_received += 1
        stats.last_wall = wall_time
        self._note_frame(stats, frame_id, "temperature")
        if not math.isfinite(celsius):
            stats.rejected_values += 1
            self._event("temperature_nonfinite", f"temperature: non-finite value at t = {t!r}")
            return False
        if self._stamp_verdict(self.temp_stamps, t, "temperature") in ("bad_stamp", "duplicate", "backward"):
            return False
        stats.accepted += 1
        self.temperature = celsius
        return True

    # -- outputs ----------------------------------------------------------------------------------------------------
    def estimates(self) -> Estimates:
        """The current estimates (copies)."""
        enough = self.noise.n >= self.config.noise_min_samples
        nan3 = np.full(3, math.nan)
        return Estimates(
            t=self.last_imu_t,
            gyro_bias=nan3.copy(),
            gyro_bias_std=nan3.copy(),
            accel_bias=nan3.copy(),
            accel_bias_std=nan3.copy(),
            noise_density=self.noise.noise_density() if enough else np.full(6, math.nan),
            noise_density_rstd=self.noise.relative_std() if enough else math.nan,
            noise_samples=self.noise.n,
            imu_rate=self.imu_stamps.rate,
            velocity_random_walk_psd=nan3.copy(),
            velocity_random_walk_psd_std=nan3.copy(),
            stationary=self.stationarity.stationary,
        )

    def diagnostics(self, wall_now: float, window_s: float) -> list[DiagnosticStatus]:
        """Statuses per function, computed at steady-clock time ``wall_now`` over the last ``window_s`` seconds.

        Resets the per-window counters (received messages, stamp problems).
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
        statuses.append(self._noise_status())
        statuses.append(self._range_status())
        statuses.append(self._processing_status())
        for stats in (self.imu_stats, self.odom_stats, self.temp_stats):
            stats.window_received = 0
        self._window_stamp_counts = {}
        return statuses

    def _input_status(self, name: str, stats: InputStats, stamps: StampChecker, wall_now: float,
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
            if not required and name.startswith("Odometry"):
                message += ": stationarity is decided from the IMU alone"
            return DiagnosticStatus(name, level, message, values)
        silent = wall_now - stats.last_wall
        values["seconds_since_last"] = f"{silent:.2f}"
        if silent > self.config.stale_timeout:
            return DiagnosticStatus(name, STALE if required else WARN,
                                    f"no message for {silent:.1f} s", values)
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

    def _noise_status(self) -> DiagnosticStatus:
        n = self.noise.n
        need = self.config.noise_min_samples
        values = {"stationary_samples": str(n), "needed": str(need)}
        if n < need:
            return DiagnosticStatus("Noise density", WARN, f"collecting stationary samples ({n}/{need}); "
                                    "corrected IMU covariances unknown (zeros)", values)
        density = self.noise.noise_density()
        for axis, value in zip(AXES, density, strict=True):
            values[f"{axis}_noise_density"] = f"{value:.4g}"
        values["relative_std"] = f"{self.noise.relative_std():.3g}"
        return DiagnosticStatus("Noise density", OK, f"estimated from {n} stationary samples", values)

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
        values = {
            "callbacks": str(pt.count),
            "callback_p50_us": f"{pt.percentile(50) * 1e6:.1f}",
            "callback_p99_us": f"{pt.percentile(99) * 1e6:.1f}",
            "callback_max_us": f"{float(pt.values().max()) * 1e6:.1f}" if pt.count else "nan",
        }
        return DiagnosticStatus("Processing", OK, f"p99 {values['callback_p99_us']} us per callback", values)
