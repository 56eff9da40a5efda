"""The online identification composed of its parts (docs/node.md, "What happens per message"): per IMU sample
:class:`~.inputs.Input` value and stamp checks and :class:`~.inputs.SaturationCheck`, then :class:`~.cmkf_feed.CmkfFeed`
(in stamp order with the odometry), :class:`~.stationarity.StationaryGate`, and for stationary samples
:class:`~.noise.StationaryNoise`, :class:`~.bank.BankFeed`, :class:`~.watch.ReferenceWatch`; out comes the
bias-corrected sample with covariance N²·f. Plain numbers in, dataclasses out."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ...core.axes import AXES
from ...core.cmkf.config import CmkfConfig
from ...core.quality import IMU_MAX_ABS
from .bank import BankFeed
from .cmkf_feed import CmkfFeed
from .config import OnlineConfig
from .events import EventLog
from .inputs import Input, SaturationCheck
from .noise import StationaryNoise
from .results import CorrectedImu, Estimates, HypothesesReport
from .stationarity import StationaryGate
from .status import (
    DiagnosticStatus,
    WindowStats,
    cmkf_noise_status,
    consistency_status,
    hypotheses_status,
    input_status,
    noise_status,
    processing_status,
    range_status,
    stamp_status,
    stationarity_status,
)
from .watch import ReferenceWatch


class OnlineIdentifier:
    """Streaming identification of a robot's IMU errors (module docstring).

    Parameters
    ----------
    config : validated parameters; hypotheses : (mapping, source) of the hypothesis set, or None (no bank);
    watch : the :mod:`.watch` against this IMU's reference, or None; cmkf : the CMKF's parameters instead of those of
    ``config``'s ``cmkf.*`` and ``nis.window`` (the replay's); on_cmkf_odometry : ``on_cmkf_odometry(t, updated)``
    after every odometry message the CMKF processed (the replay records its estimate there).

    Attributes
    ----------
    imu, odom, temperature : the inputs; cmkf_feed, stationarity, noise, bank : the parts; processing_time,
    identification_time : callback and bank-batch times; restarts : new IMU time lines; last_imu_t : last IMU stamp.

    Raises
    ------
    InputError
        If the CMKF or innovation parameters or the hypothesis set are invalid.
    """

    def __init__(self, config: OnlineConfig | None = None,
                 hypotheses: tuple[Mapping[str, Any], str] | None = None, watch: ReferenceWatch | None = None, *,
                 cmkf: CmkfConfig | None = None,
                 on_cmkf_odometry: Callable[[float, bool], None] | None = None) -> None:
        self.config = config = config or OnlineConfig()
        self._hypotheses = hypotheses
        self._cmkf, self._on_cmkf_odometry = cmkf, on_cmkf_odometry
        self.watch = watch
        self.events = EventLog()
        self.imu = Input("imu", config, self.events)
        self.odom = Input("odom", config, self.events)
        self.temperature = Input("temperature", config, self.events)
        self.saturation = SaturationCheck(config)
        self.processing_time = WindowStats()
        self.identification_time = WindowStats(size=256)
        self.temperature_celsius = math.nan
        self.restarts = 0
        self._start_estimation()

    def _start_estimation(self) -> None:
        """The estimators, empty."""
        config = self.config
        self.cmkf_feed = CmkfFeed(config, self.events, self._cmkf, self._on_cmkf_odometry)
        self.stationarity = StationaryGate(config)
        self.noise = StationaryNoise()
        self.bank = None if self._hypotheses is None else BankFeed(*self._hypotheses, config.hypotheses_bank_rate,
                                                                  self.events)
        self.last_imu_t = math.nan
        self._variance_cache: tuple[tuple[float, ...] | None, tuple[float, ...] | None] | None = None

    def set_config(self, config: OnlineConfig) -> None:
        """Apply a new (validated) configuration at runtime; the estimates are kept."""
        self.config = config
        for source in (self.imu, self.odom, self.temperature):
            source.configure(config)
        self.saturation.configure(config)
        self.stationarity.configure(config)
        self.cmkf_feed.set_latency(config.cmkf_input_latency)

    def pop_events(self) -> list[tuple[str, str]]:
        """Input problems seen since the last call, as (key, message); the node logs them rate-limited by key."""
        return self.events.pop()

    # -- inputs -----------------------------------------------------------------------------------------------------
    def process_imu(
        self, t: float, gyro: tuple[float, float, float], accel: tuple[float, float, float],
        frame_id: str = "", wall_time: float | None = None, *,
        orientation_xyzw: tuple[float, float, float, float] | None = None, source: Any = None,
    ) -> list[CorrectedImu]:
        """One IMU message: stamp ``t`` [s], angular rate [rad/s], specific force [m/s²]; ``orientation_xyzw`` for
        ``cmkf.gravity_source: imu``; ``source`` returned with the sample. Returns the bias-corrected samples released,
        in stamp order (none when rejected or held after a jump; the held one first when this one confirmed it)."""
        sample = np.array((*gyro, *accel), dtype=float)
        # The offline reader's physical limits (|ω| ≤ 1e3 rad/s, |a| ≤ 1e4 m/s²): one absurd sample must not
        # become a bias that lasts for the filters' correlation time.
        with np.errstate(invalid="ignore"):
            usable = bool(np.isfinite(sample).all() and np.abs(sample[:3]).max() <= IMU_MAX_ABS[0]
                          and np.abs(sample[3:]).max() <= IMU_MAX_ABS[1])
        released = self.imu.receive(t, usable, frame_id, wall_time,
                                    f"or implausible angular rate or acceleration (limits {IMU_MAX_ABS[0]:g} rad/s, "
                                    f"{IMU_MAX_ABS[1]:g} m/s²)", payload=(t, sample, orientation_xyzw, source))
        return [self._imu_sample(verdict, *payload) for verdict, payload in released]

    def _imu_sample(self, verdict: str, t: float, sample: np.ndarray,
                    orientation_xyzw: tuple[float, float, float, float] | None, source: Any) -> CorrectedImu:
        """One accepted IMU sample through the CMKF, the stationarity and the noise identification."""
        gyro, accel = sample[:3].tolist(), sample[3:].tolist()
        saturated = self.saturation.check(gyro + accel)
        if saturated:
            self._saturated(t, sample, saturated)
        if verdict == "restart":
            self.restarts += 1
            self._new_time_line()
        elif verdict == "gap":  # no difference across it; a short one (a driver's pause between bursts of host-
            self.noise.break_chain()  # stamped messages) leaves the stationarity and the bank's stretch alone
            if self.watch is not None:
                self.watch.break_chain()
            if t - self.last_imu_t > self.config.stationary_window:
                self._end_stationary()
                self.stationarity.interrupt()
        if self.imu.stats.accepted % 100 == 0:
            self._variance_cache = None
        self.last_imu_t = t
        if self.cmkf_feed.cmkf.config.gravity_source != "imu":
            orientation_xyzw = None
        self.cmkf_feed.imu(t, gyro, accel, orientation_xyzw)
        ended, released = self.stationarity.update(t, sample, self.cmkf_feed.gyro_bias)
        if ended:
            self._end_stationary()
        for t_s, y in released:
            self.noise.add(t_s, y)
            if self.bank is not None:
                self.bank.add(t_s, y)
            if self.watch is not None:
                self.watch.add(t_s, y, self.imu.stamps.period)
        return self._corrected(t, sample, source)

    def _new_time_line(self) -> None:
        """Stamps went back and on (a restarted source): a gap of unknown length; no estimate is forgotten."""
        self._end_stationary()
        self.stationarity.interrupt()
        self.cmkf_feed.new_time_line()

    def _saturated(self, t: float, sample: np.ndarray, axes: list[str]) -> None:
        """Count and report a sample at the sensor's full scale (it is used: the CMKF's gate guards the biases)."""
        stats = self.imu.stats
        stats.saturated += 1
        stats.window_saturated += 1
        self.events.count("imu_saturated")
        values = ", ".join(f"{axis} = {sample[AXES.index(axis)]:.6g}" for axis in axes)
        self.events.event("imu_saturated", f"imu: sample at t = {t:.6f} s at the sensor's full scale ({values}): "
                          "saturated (a bump or a turn beyond the range); set imu_range.* to the datasheet range")

    def _end_stationary(self) -> None:
        """Motion or a gap: the difference chain is broken and the bank's stretch ends."""
        self.noise.break_chain()
        if self.bank is not None:
            self.bank.end_stretch()
        if self.watch is not None:
            self.watch.break_chain()

    def process_odometry(
        self, t: float, linear_velocity: tuple[float, float, float],
        angular_velocity: tuple[float, float, float] | None, frame_id: str = "", wall_time: float | None = None, *,
        position: tuple[float, float, float] | None = None,
        orientation_xyzw: tuple[float, float, float, float] | None = None,
        pose_covariance: np.ndarray | None = None, twist_covariance: np.ndarray | None = None,
    ) -> bool:
        """One odometry message (pose in the odom frame, twist in the child frame; ``angular_velocity`` None: not
        measured, a recording's: the stationarity judges the linear speed alone); False when rejected."""
        measured = angular_velocity is not None
        v = np.array((*linear_velocity, *(angular_velocity if measured else (0.0, 0.0, 0.0))), dtype=float)
        fields = {"angular_velocity": v[3:] if measured else None, "position": position,
                  "orientation_xyzw": orientation_xyzw,
                  "pose_cov": None if pose_covariance is None else np.array(pose_covariance, dtype=float),
                  "twist_cov": None if twist_covariance is None else np.array(twist_covariance, dtype=float)}
        before = self.odom.stats.accepted
        for verdict, (t_m, v_m, fields_m) in self.odom.receive(t, bool(np.isfinite(v).all()), frame_id, wall_time,
                                                               "twist", payload=(t, v, fields)):
            self._odometry(verdict, t_m, v_m, fields_m)
        return self.odom.stats.accepted > before or self.odom.stamps.held == t

    def _odometry(self, verdict: str, t: float, v: np.ndarray, fields: dict[str, Any]) -> None:
        """One accepted odometry message to the stationarity and the CMKF."""
        detector = self.stationarity.detector
        if verdict == "restart":
            detector.odom_t = None
            self.cmkf_feed.new_time_line()
        detector.update_odometry(t, math.sqrt(float(v[:3] @ v[:3])), math.sqrt(float(v[3:] @ v[3:])))
        self.cmkf_feed.odometry(t, linear_velocity=v[:3], **fields)

    def process_temperature(self, t: float, celsius: float, frame_id: str = "",
                            wall_time: float | None = None) -> bool:
        """One temperature message [°C]; False when it was rejected."""
        released = self.temperature.receive(t, math.isfinite(celsius), frame_id, wall_time, "value",
                                           payload=celsius)
        for _, value in released:
            self.temperature_celsius = value
        return bool(released) or self.temperature.stamps.held == t

    def finish(self) -> None:
        """The end of the input (a recording's): the messages the CMKF's stamp merger still holds are processed."""
        self.cmkf_feed.flush()

    # -- outputs ----------------------------------------------------------------------------------------------------
    def _corrected(self, t: float, sample: np.ndarray, source: Any = None) -> CorrectedImu:
        gyro = sample[:3] - self.cmkf_feed.gyro_bias
        accel = sample[3:] - self.cmkf_feed.accel_bias
        if self._variance_cache is None:
            self._refresh_variance()
        gyro_var, accel_var = self._variance_cache
        return CorrectedImu(t, (float(gyro[0]), float(gyro[1]), float(gyro[2])),
                            (float(accel[0]), float(accel[1]), float(accel[2])), gyro_var, accel_var, source)

    def _refresh_variance(self) -> None:
        """Cache the corrected samples' covariance (every 100 IMU samples and in :meth:`update_identification`)."""
        variance, _ = self._covariance()
        if variance is None:
            self._variance_cache = (None, None)
        else:
            v = variance.tolist()
            self._variance_cache = (tuple(v[:3]), tuple(v[3:]))

    def _covariance(self) -> tuple[np.ndarray | None, str]:
        return self.noise.covariance(self.imu.stamps.rate, self.config.noise_min_samples,
                                     lambda: self.cmkf_feed.estimate)

    def update_identification(self) -> None:
        """Feed the queued stationary samples to the banks and refresh the CMKF status (at ``publish_rate``)."""
        self._variance_cache = None
        self.cmkf_feed.refresh()
        if self.bank is None:
            return
        start = time.perf_counter()
        if self.bank.feed(self.imu.stamps.rate):
            self.identification_time.add(time.perf_counter() - start)

    def hypotheses(self) -> HypothesesReport | None:
        """Posterior probabilities and decisions per axis, or None before the banks exist."""
        return None if self.bank is None else self.bank.report()

    def estimates(self) -> Estimates:
        """The current estimates (copies)."""
        min_samples = self.config.noise_min_samples
        est = self.cmkf_feed.estimate
        known = self.cmkf_feed.cmkf.filter.initialised
        nan3 = np.full(3, math.nan)
        nan6 = np.full(6, math.nan)
        identified = np.concatenate([est.gyro_psd.identified, est.accel_psd.identified])
        values = np.concatenate([est.gyro_psd.value, est.accel_psd.value])
        covariance, source = self._covariance()
        return Estimates(
            t=self.last_imu_t,
            cmkf_status=est.status,
            gyro_bias=est.gyro_bias.copy() if known else nan3.copy(),
            gyro_bias_std=est.gyro_bias_std.copy() if known else nan3.copy(),
            accel_bias=est.accel_bias.copy() if known else nan3.copy(),
            accel_bias_std=est.accel_bias_std.copy() if known else nan3.copy(),
            noise_density=self.noise.density(min_samples, self.imu.stamps.period),
            noise_density_rstd=self.noise.relative_std(min_samples),
            noise_samples=self.noise.n,
            psd=np.where(identified, values, math.nan) if known else nan6.copy(),
            psd_se=np.concatenate([est.gyro_psd.se, est.accel_psd.se]) if known else nan6.copy(),
            psd_upper=np.concatenate([est.gyro_psd.density_upper95(), est.accel_psd.density_upper95()]) ** 2
            if known else nan6.copy(),
            covariance=covariance if covariance is not None else np.full(6, math.nan),
            covariance_source=source,
            imu_rate=self.imu.stamps.rate,
            stationary=self.stationarity.stationary,
            bank_theta={} if self.bank is None else self.bank.theta(),
        )

    def _cmkf_density_ci(self) -> np.ndarray | None:
        """(6, 2) the CMKF's 95 % density intervals [u/√Hz] (NaN where not identified), or None before it runs."""
        est = self.cmkf_feed.estimate
        if est.status in ("no_data", "no_imu", "imu_only") or not self.cmkf_feed.cmkf.filter.initialised:
            return None
        return np.vstack([est.gyro_psd.density_ci95(), est.accel_psd.density_ci95()])

    def diagnostics(self, wall_now: float, window_s: float) -> list[DiagnosticStatus]:
        """Statuses at steady-clock ``wall_now`` over the last ``window_s`` seconds; resets the per-window counters."""
        cfg = self.config
        feed = self.cmkf_feed
        est = self.estimates()
        imu_status = input_status("IMU input", self.imu, wall_now, window_s, cfg.expected_imu_rate, True,
                                  cfg.stale_timeout)
        statuses = [
            imu_status,
            input_status("Odometry input", self.odom, wall_now, window_s, cfg.expected_odom_rate,
                         cfg.stationary_require_odometry, cfg.stale_timeout),
        ]
        if self.temperature.stats.received:
            statuses.append(input_status("Temperature input", self.temperature, wall_now, window_s, 0.0, False,
                                         cfg.stale_timeout))
        counts = self.events.window_counts
        statuses += [
            stamp_status(counts, (self.imu, self.odom), self.restarts),
            stationarity_status(self.stationarity, self.last_imu_t, self.imu.stats.window_received > 0),
            consistency_status(feed.estimate, counts, feed.errors, feed.too_late),
            cmkf_noise_status(feed.estimate),
            feed.innovations.status(),
            noise_status(est, cfg.noise_min_samples),
            hypotheses_status(self.hypotheses(), self.bank is not None,
                              [] if self.bank is None else self.bank.decision_changes),
            range_status(cfg, est),
            processing_status(self.processing_time, self.identification_time),
            *(self.watch.statuses(self._cmkf_density_ci()) if self.watch is not None else []),
        ]
        for source in (self.imu, self.odom, self.temperature):
            source.stats.window_received = 0
            source.stats.window_frame_changes = 0
            source.stats.window_saturated = 0
        self.events.new_period()
        if self.bank is not None:
            self.bank.decision_changes = []
        return statuses
