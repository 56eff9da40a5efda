"""Paper 004's CMKF on a robot: rotated IMU, gravity, odometry slower than the IMU (docs/cmkf.md). Composed of
:class:`~.interval.ImuPropagation` (eqs. 13–17, 22–23), :mod:`.measurement` (eq. 8), the accelerometer
:class:`~.protocol.CmkfFilter` (24)–(35) and :class:`~.gyro.GyroBiasFilter`. Unusable input is dropped and counted;
gaps beyond ``max_odom_gap`` / ``max_imu_gap`` restart the chain / the position and velocity."""

from __future__ import annotations

import math

import numpy as np

from . import rotation as rot
from .agreement import AxisAgreement
from .axis import AxisCmkf
from .config import CmkfConfig
from .estimate import CmkfEstimate, consistency, running_status
from .fast_vel import VelocityAxisCmkf
from .gate import InnovationGate, NisWindow
from .gyro import GyroBiasFilter
from .interval import ImuPropagation
from .measurement import PoseTwistMeasurement, TwistMeasurement
from .protocol import CmkfFilter

COUNTERS = ("imu", "odom", "updates", "imu_dropped_stamp", "imu_dropped_nan", "odom_dropped_stamp",
            "odom_dropped_nan", "odom_dropped_missing", "odom_dropped_late", "odom_dropped_interval", "odom_late",
            "odom_without_imu", "odom_gaps", "imu_gaps", "skipped_updates", "skipped_stacked", "gated_accel",
            "gated_gyro", "odom_dropped_orientation", "odom_orientation_invalid", "imu_orientation_invalid")


def default_filter(config: CmkfConfig) -> CmkfFilter:
    """The accelerometer filter: :class:`VelocityAxisCmkf` for twist, :class:`AxisCmkf` for pose_twist."""
    if config.measurement == "twist":
        return VelocityAxisCmkf(3, config.s_v0, pd_check=config.pd_check, min_samples=config.min_samples)
    return AxisCmkf(3, config.s_v0, mode="pos_vel", pd_check=config.pd_check, min_samples=config.min_samples)


class RobotCmkf:
    """Streaming CMKF for accelerometer bias and S_v, plus the gyro-bias filter (module docstring).

    Parameters
    ----------
    config : the parameters (validated: ValueError); accel_filter : 3 axes, default :func:`default_filter`.

    Attributes
    ----------
    filter, gyro : the two filters (``y``, ``S`` of their last update; :attr:`last_update`: which ones it was).
    counters : messages used and dropped by reason (:data:`COUNTERS`).
    """

    def __init__(self, config: CmkfConfig | None = None, accel_filter: CmkfFilter | None = None) -> None:
        self.config = config = config or CmkfConfig()
        config.validate()
        self.q_bi = rot.normalise(config.imu_rotation_xyzw)
        C_ib = rot.to_matrix(self.q_bi).T
        measurement = TwistMeasurement if config.measurement == "twist" else PoseTwistMeasurement
        self.odometry = measurement(config, C_ib)
        self.filter = accel_filter or default_filter(config)
        if self.filter.n != 3 or self.filter.m != self.odometry.m:
            raise ValueError(f"the accelerometer filter must have 3 axes and {self.odometry.m} measurement "
                             f"component(s) per axis for measurement {config.measurement!r}")
        self.gyro = GyroBiasFilter(config.gyro_bias_tau, config.gyro_bias_sigma, config.s_g0, config.min_samples,
                                   config.pd_check)
        self.imu = ImuPropagation(config.gravity, config.accel_bias_tau, config.accel_bias_sigma,
                                  track_position=self.odometry.m == 2)
        self.counters = dict.fromkeys(COUNTERS, 0)
        self.last_update = (False, False)  # (accelerometer filter, gyro filter) updated by the last odometry
        self.gates = (InnovationGate(3 * self.filter.m, config.nis_gate_probability),
                      InnovationGate(3, config.nis_gate_probability))
        self.last_gated = (False, False)  # (accelerometer, gyro) update of the last odometry rejected by its gate
        self._t_imu: float | None = None
        self._t_odom: float | None = None
        self._t_state: float | None = None
        self._t_update: float | None = None
        self._last_imu: tuple[float, float, float, float, float, float] | None = None
        self._q_ni_imu: rot.Quat | None = None
        self._reinit = True
        self._nis_accel = math.nan
        self._nis_gyro = math.nan
        self.nis_windows = (NisWindow(3 * self.filter.m, config.nis_window), NisWindow(3, config.nis_window))
        self.agreement = (AxisAgreement("velocity"), AxisAgreement("rotation"))
        self._z_prev: tuple[list[float], list[float]] | None = None  # velocity measurement and variance, last epoch
        self._v_post = [0.0, 0.0, 0.0]  # velocity after the last update

    def new_time_line(self) -> None:
        """Input stamps restarted: forget times and the interval, keep the estimates; r, v restart at next odometry."""
        self._t_imu = self._t_odom = self._t_state = self._t_update = None
        self._last_imu = None
        self._reinit = True
        self._z_prev = None
        self.imu.reset_interval()
        self.gyro.reset_chain()
        self.odometry.reset_chain()

    # ------------------------------------------------------------------ IMU path
    def process_imu(
        self,
        t: float,
        gyro: tuple[float, float, float] | np.ndarray,
        accel: tuple[float, float, float] | np.ndarray,
        orientation_xyzw: tuple[float, float, float, float] | np.ndarray | None = None,
    ) -> bool:
        """Propagate with one IMU sample (stamp ``t`` [s], ``gyro`` [rad/s], ``accel`` [m/s²] with gravity) held over
        (t_prev, t]; ``orientation_xyzw`` used for gravity when ``gravity_source == "imu"`` (one that is all-zero or
        not finite is counted and ignored, the sample kept). False if dropped."""
        try:
            t = float(t)
            wx, wy, wz = (float(v) for v in gyro)
            fx, fy, fz = (float(v) for v in accel)
        except (TypeError, ValueError):  # not three numbers each: unusable
            t = wx = wy = wz = fx = fy = fz = math.nan
        if not math.isfinite(t + wx + wy + wz + fx + fy + fz):  # NaN/inf anywhere makes the sum non-finite
            self.counters["imu_dropped_nan"] += 1
            return False
        if self._t_imu is not None and t <= self._t_imu:
            self.counters["imu_dropped_stamp"] += 1
            return False
        if orientation_xyzw is not None and self.config.gravity_source == "imu":
            try:
                self._q_ni_imu = rot.normalise(orientation_xyzw)
            except ValueError:  # all-zero or not finite: gravity from the last valid one, else the propagated one
                self.counters["imu_orientation_invalid"] += 1
        self.counters["imu"] += 1
        self._t_imu = t
        self._last_imu = (wx, wy, wz, fx, fy, fz)
        if self._t_state is None:
            return True  # no odometry yet: nothing to propagate from
        dt = t - self._t_state
        if dt > self.config.max_imu_gap:
            if not self._reinit:
                self.counters["imu_gaps"] += 1
            self._reinit = True
            self._t_state = t
        elif dt > 0.0:
            self._propagate(dt)
            self._t_state = t
        return True

    def _propagate(self, dt: float) -> None:
        """The last IMU sample held over ``dt``; gravity from the IMU's orientation when so configured."""
        q = self._q_ni_imu if self.config.gravity_source == "imu" and self._q_ni_imu is not None else self.imu.q_ni
        self.imu.step(dt, self._last_imu, self.gyro.bias, q)

    # ------------------------------------------------------------------ odometry path
    def process_odometry(
        self,
        t: float,
        *,
        position: np.ndarray | None = None,
        orientation_xyzw: np.ndarray | None = None,
        linear_velocity: np.ndarray | None = None,
        angular_velocity: np.ndarray | None = None,
        pose_cov: np.ndarray | None = None,
        twist_cov: np.ndarray | None = None,
        late: bool = False,
    ) -> bool:
        """One nav_msgs/Odometry message (REP-105; 6×6 row-major covariances, zeros = unknown; ``late``: reordered by a
        :class:`~.merge.StampMerger`). True if it updated (or initialised) the filter."""
        t = float(t)
        self.last_update = (False, False)
        self.last_gated = (False, False)
        checked = self._usable_odometry(t, {"position": position, "orientation_xyzw": orientation_xyzw,
                                            "linear_velocity": linear_velocity, "angular_velocity": angular_velocity})
        if checked is None:
            return False
        self.counters["odom_late"] += late
        self._apply_odometry(t, *checked, pose_cov, twist_cov)
        return True

    def _usable_odometry(self, t: float, fields: dict) -> tuple[dict, rot.Quat | None] | None:
        """The message's values and orientation if it can be used now; None when it is dropped (counted)."""
        cfg = self.config
        checked = self.odometry.values(fields)
        if checked is None or not math.isfinite(t):
            reason = "odom_dropped_nan"  # NaN/inf or malformed: unusable
        elif self._t_odom is not None and t <= self._t_odom:
            reason = "odom_dropped_stamp"
        elif self.odometry.missing(checked[0]):
            # an invalid orientation (all-zero quaternion) is dropped only where it is needed
            reason = "odom_dropped_orientation" if checked[2] else "odom_dropped_missing"
        else:
            self.counters["odom_orientation_invalid"] += checked[2]
            self.counters["odom"] += 1
            self._t_odom = t
            if self._last_imu is None:
                reason = "odom_without_imu"
            elif self._t_update is not None and t - self._t_update < cfg.min_odom_interval:
                reason = "odom_dropped_interval"
            elif t < (self._t_imu if self._t_state is None else self._t_state):
                reason = "odom_dropped_late"  # behind the IMU-propagated state: fed out of stamp order
            else:
                return checked[:2]
        self.counters[reason] += 1
        return None

    def _apply_odometry(self, t: float, vals: dict, q_nb: rot.Quat | None, pose_cov: np.ndarray | None,
                        twist_cov: np.ndarray | None) -> None:
        """Bring the state to ``t`` (not behind it) and update with one checked odometry message."""
        cfg = self.config
        imu = self.imu
        if self._t_state is not None and t > self._t_state:
            if t - self._t_imu > cfg.max_imu_gap:  # the last IMU sample is stale: cannot propagate
                if not self._reinit:
                    self.counters["imu_gaps"] += 1
                self._reinit = True
            else:
                self._propagate(t - self._t_state)
            self._t_state = t
        new_chain = self._t_update is None or (t - self._t_update) > cfg.max_odom_gap
        if new_chain and self._t_update is not None:
            self.counters["odom_gaps"] += 1
        q_ni = rot.multiply(q_nb, self.q_bi) if q_nb is not None else imu.q_ni
        z, R = self.odometry.measure(vals, q_ni, pose_cov, twist_cov)
        if self._reinit or self._t_state is None:
            self._initialise(t, z, R)
        else:
            self._update(t, z, R, new_chain)
            self.last_update = (self.last_update[0], self._gyro_update(vals, q_nb, twist_cov, new_chain))
        if q_nb is not None:
            imu.q_ni = q_ni
        self.odometry.end_epoch(q_nb)
        self._t_update = t
        imu.reset_interval()

    def _update(self, t: float, z: list | np.ndarray, R: list | np.ndarray, new_chain: bool) -> None:
        """Predict (eq. 23) and update (24)–(35) the accelerometer filter; when gated (:mod:`.gate`) r, v restart."""
        f, imu = self.filter, self.imu
        skipped_before = (f.skipped, f.skipped_stacked)
        velocity = ([float(row[-1]) for row in z], [float(r[-1][-1]) for r in R])
        imu_change = [a - b for a, b in zip(imu.v, self._v_post, strict=True)]
        r_pred = self.odometry.position_prior(imu.r, imu.dp)
        f.predict(np.array([r_pred, imu.v, imu.b]).T, imu.interval())
        nis_now = float(f.nis(z, R).sum())
        previous, self._z_prev = self._z_prev, velocity
        if self.gates[0].rejects(nis_now):
            self.counters["gated_accel"] += 1
            self.last_gated = (True, False)
            self._nis_accel = nis_now
            self.nis_windows[0].add(nis_now, gated=True)
            self._initialise(t, z, R, bias=(f.x[:, 2].tolist(), f.P[:, 2, 2].copy()))
            self._z_prev = velocity
            return
        if previous is not None and not new_chain:
            self.agreement[0].add(imu_change, [a - b for a, b in zip(velocity[0], previous[0], strict=True)],
                                  [a + b for a, b in zip(velocity[1], previous[1], strict=True)])
        nis = f.update(z, R, new_chain=new_chain)
        imu.r, imu.v, imu.b = f.x.T.tolist()
        self._v_post = list(imu.v)
        self.counters["skipped_stacked"] += f.skipped_stacked - skipped_before[1]
        if f.skipped > skipped_before[0]:
            self.counters["skipped_updates"] += 1
            self._nis_accel = math.nan
            return
        self._nis_accel = float(nis.sum())
        self.nis_windows[0].add(self._nis_accel, gated=False)
        self.counters["updates"] += 1
        self.last_update = (True, False)

    def _initialise(self, t: float, z: list | np.ndarray, R: list | np.ndarray,
                    bias: tuple[list[float], np.ndarray] | None = None) -> None:
        """(Re-)initialise r, v from the measurement; keep the bias and its grown variance, or take ``bias``."""
        cfg = self.config
        if bias is not None:
            b0, Pbb = bias
        elif self.filter.initialised:
            b0 = list(self.imu.b)
            Pbb = self._bias_var()
            if self._t_update is not None:
                phi2 = math.exp(-2.0 * (t - self._t_update) / cfg.accel_bias_tau)
                Pbb = phi2 * Pbb + (1.0 - phi2) * cfg.accel_bias_sigma**2
        else:
            b0 = [0.0, 0.0, 0.0]
            Pbb = np.full(3, cfg.accel_bias_sigma**2)
        r0, v0, Prr, Pvv = self.odometry.initial(z, R)
        P0 = np.zeros((3, 3, 3))
        P0[:, 0, 0], P0[:, 1, 1], P0[:, 2, 2] = Prr, Pvv, Pbb
        x0 = np.array([r0, v0, b0], dtype=float).T
        self.filter.initialise(x0, P0)
        self.gyro.reset_chain()
        self._z_prev = None
        self.imu.r, self.imu.v, self.imu.b = x0.T.tolist()
        self._v_post = list(self.imu.v)
        self._t_state = t
        self._reinit = False

    def _gyro_update(self, vals: dict, q_nb: rot.Quat | None, twist_cov: np.ndarray | None, new_chain: bool
                     ) -> bool:
        """The gyro-bias filter over the interval: IMU rotation minus the odometry's; True if it updated."""
        T = self.imu.T
        if T <= 0.0:
            return False
        if new_chain:
            self.gyro.reset_chain()
        increment = self.odometry.rotation_increment(vals, q_nb, twist_cov, T, new_chain)
        if increment is None:
            return False
        dtheta_odo, R, shared = increment
        gyro = self.gyro
        gyro.predict(T)
        z = [a - b for a, b in zip(self.imu.dtheta, dtheta_odo, strict=True)]
        nis = gyro.nis(z, R)
        if self.gates[1].rejects(nis):
            self.counters["gated_gyro"] += 1
            self.last_gated = (self.last_gated[0], True)
            self._nis_gyro = nis
            self.nis_windows[1].add(nis, gated=True)
            gyro.coast()
            return False
        self.agreement[1].add([a - b * T for a, b in zip(self.imu.dtheta, gyro.bias, strict=True)], dtheta_odo, R)
        self._nis_gyro = gyro.update(z, R, shared)
        self.nis_windows[1].add(self._nis_gyro, gated=False)
        return True

    # ------------------------------------------------------------------ results
    @property
    def last_nis(self) -> tuple[float, float]:
        """NIS of the last (accelerometer, gyro) update, also when the gate rejected it."""
        return self._nis_accel, self._nis_gyro

    def _bias_var(self) -> np.ndarray:
        """Accelerometer-bias variance per axis, predicted to the current time."""
        f = self.filter
        return (f.predicted_P(self.imu.interval()) if self.imu.T > 0 else f.P)[:, 2, 2]

    def estimate(self) -> CmkfEstimate:
        """Current estimates (cheap; call at any rate). Between updates the covariance is predicted."""
        cfg = self.config
        f, gyro = self.filter, self.gyro
        t = max(x for x in (self._t_imu, self._t_odom, -math.inf) if x is not None)
        observed = (
            self._t_update is not None
            and self._t_state is not None
            and (self._t_state - self._t_update) <= cfg.max_odom_gap
            and (t - self._t_imu) <= cfg.max_imu_gap  # an IMU that stopped while odometry goes on observes nothing
        )
        verdict, reason = consistency(self.nis_windows, self.agreement)
        if self._t_imu is None and self._t_odom is None:
            status = "no_data"
        elif self._t_imu is None:
            status = "no_imu"
        elif not f.initialised:
            status = "imu_only"
        elif not observed:
            status = "unobserved"
        else:
            status = running_status(f.count, cfg.min_samples, verdict)
        if f.initialised:
            bias = np.array(self.imu.b)
            bias_std = np.sqrt(self._bias_var())
            g_var = gyro.predicted_P(self.imu.T)
        else:
            bias = np.zeros(3)
            bias_std = np.full(3, cfg.accel_bias_sigma)
            g_var = np.full(3, cfg.gyro_bias_sigma**2)
        S_v_ls, S_g_ls = f.S_ls, gyro.S_ls
        windows = self.nis_windows
        return CmkfEstimate(
            t=float(t) if math.isfinite(t) else math.nan,
            status=status,
            observed=bool(observed),
            accel_bias=bias,
            accel_bias_std=bias_std,
            S_v=f.S_used.copy(),
            S_v_ls=S_v_ls,
            accel_ls=(S_v_ls, f.matching.standard_error, f.matching.dof),
            gyro_bias=gyro.x,
            gyro_bias_std=np.sqrt(g_var),
            S_g=gyro.S_used,
            S_g_ls=S_g_ls,
            gyro_ls=(S_g_ls, gyro.matching.standard_error, gyro.matching.dof),
            nis_accel=self._nis_accel,
            nis_accel_dof=3 * f.m,
            nis_accel_mean=windows[0].mean,
            nis_gyro=self._nis_gyro,
            nis_gyro_dof=3,
            nis_gyro_mean=windows[1].mean,
            gated=self.last_gated,
            consistency=verdict,
            consistency_reason=reason,
            n_stacked=f.count,
            counters=dict(self.counters),
        )
