"""Paper 004's CMKF on a robot: three IMU axes, a rotated IMU, gravity, odometry slower than the IMU.

Streaming API (one message per call, the same code for the ROS node and the offline replay)::

    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=...))
    f.process_imu(t, gyro, accel)                       # every IMU message, ~10 µs
    f.process_odometry(t, orientation_xyzw=q, linear_velocity=v, angular_velocity=w, twist_cov=C)
    est = f.estimate()                                  # CmkfEstimate: biases, S_v, noise densities, NIS, counters

Model (per IMU axis i, state ``x_i = [r_i, v_i, b_i]``, all resolved in the IMU frame)
---------------------------------------------------------------------------------------
Frames: ``n`` = odometry frame (z up), ``b`` = base (``child_frame_id``), ``i`` = IMU; ``C_bi`` is the known IMU
mounting rotation (parameter), ``C_nb`` the odometry orientation, ``C_ni = C_nb C_bi``. The IMU measures the specific
force ``f̃ = f + b + n`` (gravity included) and the angular rate ``ω̃``. With ``v = C_in v_n`` (velocity of the IMU
resolved in IMU axes; lever arm neglected) and ``r = C_in (p_n − p_anchor)``::

    v̇ = f + g_i − ω × v,      ṙ = v − ω × r,      g_i = C_in [0, 0, −g]                  (body-frame kinematics)
    ḃ_i = −b_i/τ + w_i                                                                    (eqs. 3–4)

Per IMU sample k (period dt_k, sample value held over its interval) the known input is
``u = f̃ + g_i − ω̂ × v̂`` with ``ω̂ = ω̃ − b̂_g`` and, as in eqs. (13)–(16), ``v ← v + (u − b̂) dt``, ``b̂ ← φ b̂``
and the displacement ``d = v dt + ½ (u − b̂) dt²``, which is accumulated in the odometry frame,
``Δp_n ← Δp_n + C_ni d`` (``C_ni`` propagated with ω̂), and rotated into the IMU axes at the next epoch with the
*measured* orientation: ``r̂⁻_k = C_in,k (C_ni,k−1 r̂⁺_{k−1} + Δp_n)`` — so the gyro's error does not multiply the
distance travelled (the transport term ``ω × r`` of ṙ is never integrated). The transport term ``ω̂ × v̂``, the
rotation of ``r`` and gravity are evaluated with the estimate and treated as known input; this is what makes
the three axes decouple (one ``[r, v, b]`` filter per IMU axis, exactly paper 004's structure). The neglected error
couplings (``ω × δv``, the rotation of δr between epochs) are small whenever velocity is measured every interval
(|ω| T ≪ 1).

The IMU samples between two odometry epochs are accumulated into one interval of length ``T = Σ dt_k``
(``β_j = Π_{l<j} φ_l``, ``m_j`` = mid-time of sample j from the start of the interval)::

    F̂ = [[1, T, −(T·Σβ_j dt_j − Σβ_j dt_j m_j)], [0, 1, −Σβ_j dt_j], [0, 0, Π φ_j]]
    Q_a = S_v · [[T³ − 2T Σdt m + Σdt m², T² − Σdt m, 0], [T² − Σdt m, T, 0], [0, 0, 0]]
    q_b = (1 − (Π φ_j)²) σ_ss²  (bias drive lumped at the end of the interval)

which is the exact accumulation of the paper's per-sample (13)–(16) and (22) for the velocity-random-walk part
(the bias drive inside the interval is lumped, an O(q_b T) approximation). Measurements at the odometry epoch:
``z_v = C_ib^T v_b`` (twist, in ``child_frame_id``) and, in mode ``pose_twist``, ``z_r = C_in (p_n − p_anchor)``;
``R`` = the per-axis diagonal of the rotated odometry covariance (or a parameter). Then the update (24)–(27) and the
stacked estimator (28)–(35) at the odometry rate (:mod:`.stacked`, with time-varying interval matrices).

Reduction to paper 004: for a sensor that does not rotate (``ω = 0``, ``C_ni = I``), one IMU sample per odometry
epoch with period T, gravity on z and position + velocity measured, ``Σβ_j dt_j = T``, ``T·T − T·T/2 = T²/2``,
``Q_a = S_v T [T²/4, T/2; T/2, 1] = S_v T Ĝ Ĝᵀ`` and ``u = Δṽ/T``: the x and y filters are exactly eqs. (13)–(17),
(23)–(35) (tested numerically against :class:`~.paper.PaperCmkf`).

Gyro: :class:`~.gyro.GyroBiasFilter` per IMU axis with ``y = ∫ω̃ dt − C_ib^T ω_b T`` (twist angular velocity) or the
odometry's relative rotation when no angular velocity is given.

Robustness: stamps not increasing (duplicated / out of order) and NaN/inf messages are dropped and counted. Odometry
stamped behind the IMU-propagated state (IMU and odometry come on two topics with different latencies) is applied
at its own stamp when it is at most ``late_odom_tolerance`` late: the filter keeps a copy of its state at the last
update and the IMU samples since, rewinds, processes the odometry and replays the samples — the result equals
in-order processing (counted ``odom_late``); older odometry is dropped (``odom_dropped_late``). Odometry less than
``min_odom_interval`` after the last update (a degenerate interval: M_o singular, divisions by T) is dropped
(``odom_dropped_interval``), and the estimators skip, rather than raise on, any update or stacked step they cannot
compute (``skipped_updates``, ``skipped_stacked``). An odometry gap longer than ``max_odom_gap`` restarts the
stacked-estimator chain (no Δv across a gap); an IMU gap longer than ``max_imu_gap`` cannot be propagated: the
position/velocity states are re-initialised from the next odometry message (bias kept) and the chain restarts.
Without IMU nothing can be estimated; with IMU only the filter propagates, its covariance grows and the estimate is
flagged unobserved.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from . import rotation as rot
from .axis import AxisCmkf
from .config import CmkfConfig
from .fast_vel import VelocityAxisCmkf
from .gyro import GyroBiasFilter
from .stacked import Interval


@dataclass
class CmkfEstimate:
    """What :meth:`RobotCmkf.estimate` returns (IMU frame, SI units).

    Attributes
    ----------
    t : time of the estimate [s] (last processed stamp).
    status : ``no_data``, ``no_imu`` (odometry only: nothing to estimate), ``imu_only`` (no odometry yet),
        ``unobserved`` (no odometry update for longer than ``max_odom_gap``, or no IMU sample for longer than
        ``max_imu_gap`` while odometry continues), ``converging`` (fewer than
        ``min_samples`` stacked samples) or ``tracking``.
    observed : True when an odometry update happened within ``max_odom_gap`` and the IMU is alive.
    accel_bias, accel_bias_std : [m/s²] per IMU axis; S_v : Ŝ_v in use [m²/s³]; S_v_ls : latest least-squares
        value (may be ≤ 0 early on); accel_noise_density : √Ŝ_v [m/s²/√Hz].
    gyro_bias, gyro_bias_std : [rad/s]; S_g, S_g_ls : [rad²/s]; gyro_noise_density : √Ŝ_g [rad/s/√Hz].
    nis_accel, nis_accel_dof : NIS of the last accelerometer-filter update (sum over axes) and its dof;
    nis_accel_mean : mean over the last ``nis_window`` updates; nis_gyro, nis_gyro_dof : the same for the gyro.
    n_stacked : stacked samples in the S_v estimate; counters : messages used and dropped, by reason.
    """

    t: float
    status: str
    observed: bool
    accel_bias: np.ndarray
    accel_bias_std: np.ndarray
    S_v: np.ndarray
    S_v_ls: np.ndarray
    accel_noise_density: np.ndarray
    gyro_bias: np.ndarray
    gyro_bias_std: np.ndarray
    S_g: np.ndarray
    S_g_ls: np.ndarray
    gyro_noise_density: np.ndarray
    nis_accel: float
    nis_accel_dof: int
    nis_accel_mean: float
    nis_gyro: float
    nis_gyro_dof: int
    n_stacked: int
    counters: dict[str, int] = field(default_factory=dict)


def _as_floats(a: np.ndarray | list[float] | tuple[float, ...]) -> list[float]:
    """A message vector as a list of floats (cheap for the 1-D arrays the node and the replay pass)."""
    if isinstance(a, np.ndarray):
        return a.astype(float, copy=False).ravel().tolist()
    return [float(x) for x in a]


def _rotate(rows: tuple[tuple[float, float, float], ...], v: list[float]) -> list[float]:
    """``C v`` with C given by its rows (plain floats)."""
    return [r[0] * v[0] + r[1] * v[1] + r[2] * v[2] for r in rows]


def _clone(value: object) -> object:
    """Copy of a piece of streaming state as deep as it is mutated in place: lists (of numbers), deques and arrays
    are copied, numbers and tuples shared."""
    if isinstance(value, list):
        return list(value)
    if isinstance(value, deque):
        return deque(value, value.maxlen)
    if isinstance(value, np.ndarray):
        return value.copy()
    return value


class _CovDiag:
    """Per-axis diagonal of ``C Σ Cᵀ`` for a 3×3 block of a 6×6 message covariance, cached on (Σ, C).

    Returns None if the covariance is unknown (all zeros, −1 in the first element, NaN). Odometry drivers mostly
    publish the same covariance in every message, so the cache makes this one comparison per message.
    """

    def __init__(self, block: slice) -> None:
        self.block = block
        self._key: bytes | None = None
        self._value: np.ndarray | None = None

    def __call__(self, cov: np.ndarray | None, C: np.ndarray) -> np.ndarray | None:
        cov = None if cov is None else np.asarray(cov, dtype=float)
        if cov is None or cov.size != 36:
            return None
        sub = cov.reshape(6, 6)[self.block, self.block]
        key = sub.tobytes() + C.tobytes()
        if key != self._key:
            self._key = key
            ok = np.all(np.isfinite(sub)) and sub[0, 0] >= 0 and np.any(sub)
            self._value = np.einsum("ij,jk,ik->i", C, sub, C).tolist() if ok else None
        return self._value


class RobotCmkf:
    """Streaming CMKF for accelerometer bias and S_v, plus the gyro-bias filter (see module docstring)."""

    def __init__(self, config: CmkfConfig | None = None) -> None:
        self.config = config = config or CmkfConfig()
        config.validate()
        self.q_bi = rot.normalise(config.imu_rotation_xyzw)
        self.C_bi = rot.to_matrix(self.q_bi)
        self.C_ib = self.C_bi.T
        self._C_ib_rows = tuple(tuple(float(c) for c in row) for row in self.C_ib)
        # twist: the plain-float velocity filter (same equations as AxisCmkf mode "vel", tested equal)
        self._fast = config.measurement == "twist"
        self.filter: AxisCmkf | VelocityAxisCmkf
        if self._fast:
            self.filter = VelocityAxisCmkf(3, config.s_v0, pd_check=config.pd_check, min_samples=config.min_samples)
        else:
            self.filter = AxisCmkf(3, config.s_v0, mode="pos_vel", pd_check=config.pd_check,
                                   min_samples=config.min_samples)
        self.gyro = GyroBiasFilter(config.gyro_bias_tau, config.gyro_bias_sigma, config.s_g0, config.min_samples)
        self.counters = dict.fromkeys(
            ("imu", "odom", "updates", "imu_dropped_stamp", "imu_dropped_nan", "odom_dropped_stamp",
             "odom_dropped_nan", "odom_dropped_missing", "odom_dropped_late", "odom_dropped_interval", "odom_late",
             "odom_without_imu", "odom_gaps", "imu_gaps", "skipped_updates", "skipped_stacked"),
            0,
        )
        self._g = config.gravity
        self._phi_per_s = 1.0 / config.accel_bias_tau
        # Streaming state (plain floats on the per-sample path).
        self._t_imu: float | None = None
        self._t_odom: float | None = None
        self._t_state: float | None = None
        self._t_update: float | None = None
        self._last_imu: tuple[float, float, float, float, float, float] | None = None
        self._q_ni: rot.Quat | None = None
        self._q_ni_imu: rot.Quat | None = None
        self._q_nb_prev: rot.Quat | None = None
        self._w_odo_prev: tuple[np.ndarray, np.ndarray] | None = None
        self._anchor: np.ndarray | None = None
        self._C_ni_epoch: np.ndarray | None = None
        self._reinit = True
        self._r = [0.0, 0.0, 0.0]
        self._v = [0.0, 0.0, 0.0]
        self._b = [0.0, 0.0, 0.0]
        self._reset_interval()
        self._nis_accel = math.nan
        self._nis_gyro = math.nan
        self._nis_hist: deque[float] = deque(maxlen=config.nis_window)
        self._nis_sum = 0.0
        self._twist_lin_cov = _CovDiag(slice(0, 3))
        self._twist_ang_cov = _CovDiag(slice(3, 6))
        self._pose_cov = _CovDiag(slice(0, 3))
        # Late odometry: the streaming state right after the last update and the IMU samples since (before the
        # first update: those of the last late_odom_tolerance; None: too many to keep, see _apply_imu).
        self._snapshot: dict | None = None
        self._replay: list[tuple[float, tuple, rot.Quat | None]] | None = []

    # Not in the snapshot: constants, counters, the last odometry stamp, and the accelerometer and gyro filters,
    # which only odometry updates change (the IMU path only reads them), so between two updates they are the
    # state of the last update.
    _NOT_STATE = frozenset((
        "config", "q_bi", "C_bi", "C_ib", "_C_ib_rows", "_fast", "counters", "_g", "_phi_per_s", "_t_odom",
        "_twist_lin_cov", "_twist_ang_cov", "_pose_cov", "_snapshot", "_replay", "filter", "gyro",
    ))

    def _save_state(self) -> dict:
        """A copy of what the IMU path changes after an update (see ``_NOT_STATE``)."""
        return {k: _clone(v) for k, v in vars(self).items() if k not in self._NOT_STATE}

    def _rewind(self) -> list[tuple[float, tuple, rot.Quat | None]]:
        """Restore the state of the last update; returns the IMU samples processed since (to replay)."""
        samples = self._replay
        vars(self).update({k: _clone(v) for k, v in self._snapshot.items()})
        self._replay = []
        return samples

    # ------------------------------------------------------------------ IMU path
    def _reset_interval(self) -> None:
        self._T = 0.0
        self._beta = 1.0
        self._M0 = self._M1 = self._N1 = self._N2 = 0.0
        self._dtheta = [0.0, 0.0, 0.0]
        self._dp = [0.0, 0.0, 0.0]

    def process_imu(
        self,
        t: float,
        gyro: tuple[float, float, float] | np.ndarray,
        accel: tuple[float, float, float] | np.ndarray,
        orientation_xyzw: tuple[float, float, float, float] | np.ndarray | None = None,
    ) -> bool:
        """Propagate with one IMU sample (stamp ``t`` [s], ``gyro`` [rad/s], ``accel`` [m/s²] with gravity).

        The sample is held over ``(t_prev, t]``. ``orientation_xyzw`` (IMU orientation in a z-up world frame) is
        used for gravity only when ``gravity_source == "imu"``. Returns False if the sample was dropped.
        """
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
        q_imu = None
        if orientation_xyzw is not None and self.config.gravity_source == "imu":
            try:
                q_imu = rot.normalise(orientation_xyzw)
            except ValueError:
                self.counters["imu_dropped_nan"] += 1
                return False
        self.counters["imu"] += 1
        self._apply_imu(t, (wx, wy, wz, fx, fy, fz), q_imu)
        return True

    def _apply_imu(self, t: float, sample: tuple[float, float, float, float, float, float],
                   q_imu: rot.Quat | None) -> None:
        """Process one checked IMU sample (also used to replay the samples after a late odometry message)."""
        if q_imu is not None:
            self._q_ni_imu = q_imu
        self._t_imu = t
        self._last_imu = sample
        replay = self._replay
        if replay is not None:
            cfg = self.config
            if self._t_update is None:  # before the first odometry: only the samples a late first one may need
                replay.append((t, sample, q_imu))
                while t - replay[0][0] > cfg.late_odom_tolerance:
                    del replay[0]
            elif t - self._t_update > cfg.max_odom_gap + cfg.late_odom_tolerance:
                self._replay = None  # odometry stopped: stop keeping samples, late odometry will be dropped
            else:
                replay.append((t, sample, q_imu))
        if self._t_state is None:
            return  # no odometry yet: nothing to propagate from
        dt = t - self._t_state
        if dt > self.config.max_imu_gap:
            if not self._reinit:
                self.counters["imu_gaps"] += 1
            self._reinit = True
            self._t_state = t
            return
        if dt > 0.0:
            self._propagate(dt, self._last_imu)
            self._t_state = t

    def _propagate(self, dt: float, sample: tuple[float, float, float, float, float, float]) -> None:
        """Eqs. (13)–(16) per IMU axis with the gravity- and transport-compensated input; interval accumulators.

        ``sample`` = (gyro x, y, z [rad/s], accel x, y, z [m/s²]) held over ``dt``.
        """
        wx, wy, wz, fx, fy, fz = sample
        bg = self.gyro.b
        ox, oy, oz = wx - bg[0], wy - bg[1], wz - bg[2]
        self._dtheta[0] += wx * dt
        self._dtheta[1] += wy * dt
        self._dtheta[2] += wz * dt
        q = self._q_ni_imu if self.config.gravity_source == "imu" and self._q_ni_imu is not None else self._q_ni
        x, y, z, w = q if q is not None else rot.IDENTITY
        g = self._g  # g_i = C_ni^T [0, 0, -g] = -g * (third row of C_ni)
        gx, gy, gz = -g * 2 * (x * z - y * w), -g * 2 * (y * z + x * w), -g * (1 - 2 * (x * x + y * y))
        v, b = self._v, self._b
        ux = fx + gx - (oy * v[2] - oz * v[1])
        uy = fy + gy - (oz * v[0] - ox * v[2])
        uz = fz + gz - (ox * v[1] - oy * v[0])
        ax, ay, az = ux - b[0], uy - b[1], uz - b[2]
        h = 0.5 * dt * dt
        if self.filter.mode == "pos_vel" and self._q_ni is not None:
            # eq. (13) displacement, accumulated in the odometry frame (rotated back at the update, see _pose_prior)
            dx, dy, dz = v[0] * dt + ax * h, v[1] * dt + ay * h, v[2] * dt + az * h
            qx, qy, qz, qw = self._q_ni
            tx, ty, tz = 2 * (qy * dz - qz * dy), 2 * (qz * dx - qx * dz), 2 * (qx * dy - qy * dx)
            dp = self._dp
            dp[0] += dx + qw * tx + qy * tz - qz * ty
            dp[1] += dy + qw * ty + qz * tx - qx * tz
            dp[2] += dz + qw * tz + qx * ty - qy * tx
        v[0] += ax * dt
        v[1] += ay * dt
        v[2] += az * dt
        phi = math.exp(-dt * self._phi_per_s)
        b[0] *= phi
        b[1] *= phi
        b[2] *= phi
        m = self._T + 0.5 * dt
        bd = self._beta * dt
        self._M0 += bd
        self._M1 += bd * m
        self._N1 += dt * m
        self._N2 += dt * m * m
        self._beta *= phi
        self._T += dt
        if self._q_ni is not None:
            # q_ni ← q_ni ⊗ exp(ω̂ dt / 2), first order in the half angle, renormalised
            ax_, ay_, az_ = 0.5 * ox * dt, 0.5 * oy * dt, 0.5 * oz * dt
            qx, qy, qz, qw = self._q_ni
            nx = qx + qw * ax_ + qy * az_ - qz * ay_
            ny = qy + qw * ay_ + qz * ax_ - qx * az_
            nz = qz + qw * az_ + qx * ay_ - qy * ax_
            nw = qw - qx * ax_ - qy * ay_ - qz * az_
            n = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
            self._q_ni = (nx * n, ny * n, nz * n, nw * n)

    def _vel_interval(self) -> tuple[float, float, float, float]:
        """(T, β_v, φ, q_b) of the current interval for :class:`VelocityAxisCmkf`."""
        return (self._T, self._M0, self._beta, (1.0 - self._beta**2) * self.config.accel_bias_sigma**2)

    def _interval(self) -> Interval:
        T, M0, M1, N1, N2 = self._T, self._M0, self._M1, self._N1, self._N2
        Phi = np.array([[1.0, T, -(T * M0 - M1)], [0.0, 1.0, -M0], [0.0, 0.0, self._beta]])
        qrv = T * T - N1
        Qa1 = np.array([[T**3 - 2.0 * T * N1 + N2, qrv, 0.0], [qrv, T, 0.0], [0.0, 0.0, 0.0]])
        return Interval(Phi, Qa1, (1.0 - self._beta**2) * self.config.accel_bias_sigma**2)

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
    ) -> bool:
        """One nav_msgs/Odometry message: pose in the odom frame, twist in ``child_frame_id`` (REP-105).

        Covariances are the 6×6 row-major message fields (all zeros = unknown). Returns True if the message
        produced a filter update (or initialised the filter).
        """
        cfg = self.config
        t = float(t)
        checked = self._check_odometry(t, {
            "position": position, "orientation_xyzw": orientation_xyzw, "linear_velocity": linear_velocity,
            "angular_velocity": angular_velocity,
        })
        if checked is None:
            return False
        vals, q_nb = checked
        self.counters["odom"] += 1
        self._t_odom = t
        if self._last_imu is None:
            self.counters["odom_without_imu"] += 1
            return False
        if self._t_update is not None and t - self._t_update < cfg.min_odom_interval:
            self.counters["odom_dropped_interval"] += 1
            return False
        covs = (pose_cov, twist_cov)
        t_now = self._t_imu if self._t_state is None else self._t_state
        if t >= t_now:
            return self._apply_odometry(t, vals, q_nb, covs)
        if t_now - t > cfg.late_odom_tolerance or self._replay is None:
            self.counters["odom_dropped_late"] += 1
            return False
        # Late: rewind to the last update (first message: nothing to rewind), replay the IMU samples up to t,
        # update at t, replay the rest.
        samples = self._rewind() if self._snapshot is not None else list(self._replay)
        for sample in samples:
            if sample[0] <= t:  # IMU first on equal stamps, as in stamp order
                self._apply_imu(*sample)
        updated = self._apply_odometry(t, vals, q_nb, covs)
        for sample in samples:
            if sample[0] > t:
                self._apply_imu(*sample)
        self.counters["odom_late"] += 1
        return updated

    def _apply_odometry(self, t: float, vals: dict, q_nb: rot.Quat | None,
                        covs: tuple[np.ndarray | None, np.ndarray | None]) -> bool:
        """Bring the state to ``t`` (not behind the state) and update with one checked odometry message."""
        cfg = self.config
        pose_cov, twist_cov = covs
        # Bring the state to the odometry stamp.
        if self._t_state is not None and t > self._t_state:
            if t - self._t_imu > cfg.max_imu_gap:  # the last IMU sample is stale: cannot propagate
                if not self._reinit:
                    self.counters["imu_gaps"] += 1
                self._reinit = True
            else:
                self._propagate(t - self._t_state, self._last_imu)
            self._t_state = t
        new_chain = self._t_update is None or (t - self._t_update) > cfg.max_odom_gap
        if new_chain and self._t_update is not None:
            self.counters["odom_gaps"] += 1
        q_ni = rot.multiply(q_nb, self.q_bi) if q_nb is not None else self._q_ni
        C_ni = None if self._fast or q_ni is None else rot.to_matrix(q_ni)
        z, R = self._measurement(vals, C_ni, pose_cov, twist_cov)
        if self._reinit or self._t_state is None:
            self._initialise(t, z, R)
        else:
            f = self.filter
            skipped_before = (f.skipped, f.skipped_stacked)
            if self._fast:
                f.predict(self._v, self._b, self._vel_interval())
                self._nis_accel = f.update(z, R, new_chain=new_chain)
                self._v, self._b = list(f.v), list(f.b)
            else:
                self._r = list(C_ni.T @ (self._C_ni_epoch @ np.array(self._r) + np.array(self._dp)))
                f.predict(np.array([self._r, self._v, self._b]).T, self._interval())
                self._nis_accel = float(f.update(z, R, new_chain=new_chain).sum())
                self._r, self._v, self._b = (list(map(float, col)) for col in f.x.T)
            self.counters["skipped_stacked"] += f.skipped_stacked - skipped_before[1]
            if f.skipped > skipped_before[0]:
                self.counters["skipped_updates"] += 1
            else:
                if len(self._nis_hist) == self._nis_hist.maxlen:
                    self._nis_sum -= self._nis_hist[0]
                self._nis_hist.append(self._nis_accel)
                self._nis_sum += self._nis_accel
                self.counters["updates"] += 1
            self._gyro_update(vals, q_nb, twist_cov, new_chain)
        if q_nb is not None:
            self._q_ni = q_ni
            self._q_nb_prev = q_nb
        self._C_ni_epoch = C_ni
        self._t_update = t
        self._reset_interval()
        self._snapshot = self._save_state()
        self._replay = []
        return True

    def _check_odometry(self, t: float, arrays: dict) -> tuple[dict, rot.Quat | None] | None:
        """The message's vectors as float lists and its unit quaternion, or None (dropped, counted)."""
        cfg = self.config
        vals = {k: None if a is None else _as_floats(a) for k, a in arrays.items()}
        lengths = {"position": 3, "orientation_xyzw": 4, "linear_velocity": 3, "angular_velocity": 3}
        # NaN/inf anywhere makes the sum non-finite (values near 1e308 are absurd here anyway)
        bad = not math.isfinite(t + sum(sum(a) for a in vals.values() if a is not None)) or any(
            a is not None and len(a) != lengths[k] for k, a in vals.items()
        )
        q_nb = None
        if not bad and vals["orientation_xyzw"] is not None:
            try:
                q_nb = rot.normalise(vals["orientation_xyzw"])
            except ValueError:  # zero quaternion: as unusable as NaN
                bad = True
        if bad:
            self.counters["odom_dropped_nan"] += 1  # NaN/inf or malformed: unusable
            return None
        if self._t_odom is not None and t <= self._t_odom:
            self.counters["odom_dropped_stamp"] += 1
            return None
        needs = ["linear_velocity", "orientation_xyzw"] if cfg.gravity_source == "odometry" else ["linear_velocity"]
        if cfg.measurement == "pose_twist":
            needs = ["position", "orientation_xyzw", "linear_velocity"]
        if any(vals[k] is None for k in needs):
            self.counters["odom_dropped_missing"] += 1
            return None
        return vals, q_nb

    def _measurement(
        self, vals: dict, C_ni: np.ndarray | None, pose_cov: np.ndarray | None, twist_cov: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per IMU axis: twist mode z, R as lists (3); pose_twist z (3, 2) and R (3, 2, 2) arrays."""
        cfg = self.config
        zv = _rotate(self._C_ib_rows, vals["linear_velocity"])
        if cfg.velocity_noise_std is not None:
            rv = [cfg.velocity_noise_std**2] * 3
        else:
            rv = self._twist_lin_cov(twist_cov, self.C_ib)
            rv = [cfg.default_velocity_noise_std**2] * 3 if rv is None else rv
        if cfg.measurement == "twist":
            return zv, rv
        p = np.array(vals["position"])
        if self._anchor is None:
            self._anchor = p.copy()
        C_in = C_ni.T
        zr = C_in @ (p - self._anchor)
        if cfg.position_noise_std is not None:
            rr = np.full(3, cfg.position_noise_std**2)
        else:
            rr = self._pose_cov(pose_cov, C_in)
            if rr is None:
                rr = np.full(3, cfg.default_position_noise_std**2)
        z = np.column_stack([zr, zv])
        R = np.zeros((3, 2, 2))
        R[:, 0, 0] = rr
        R[:, 1, 1] = rv
        return z, R

    def _initialise(self, t: float, z: np.ndarray, R: np.ndarray) -> None:
        """(Re-)initialise r, v from the measurement; keep the bias and its variance (grown) if known."""
        if self.filter.initialised:
            b0 = np.array(self._b)
            Pbb = self._bias_var()
            if self._t_update is not None:
                phi2 = math.exp(-2.0 * (t - self._t_update) / self.config.accel_bias_tau)
                Pbb = phi2 * Pbb + (1.0 - phi2) * self.config.accel_bias_sigma**2
        else:
            b0 = np.zeros(3)
            Pbb = np.full(3, self.config.accel_bias_sigma**2)
        x0 = np.zeros((3, 3))
        P0 = np.zeros((3, 3, 3))
        if self.filter.mode == "pos_vel":
            x0[:, 0], x0[:, 1] = z[:, 0], z[:, 1]
            P0[:, 0, 0], P0[:, 1, 1] = R[:, 0, 0], R[:, 1, 1]
        else:
            x0[:, 1] = z
            P0[:, 0, 0] = 1.0  # r is not tracked in twist mode
            P0[:, 1, 1] = R
        x0[:, 2] = b0
        P0[:, 2, 2] = Pbb
        if self._fast:
            self.filter.initialise(x0[:, 1], b0, P0[:, 1, 1], Pbb)
        else:
            self.filter.initialise(x0, P0)
        self.gyro.reset_chain()
        self._r, self._v, self._b = (list(map(float, col)) for col in x0.T)
        self._t_state = t
        self._reinit = False

    def _gyro_update(self, vals: dict, q_nb: rot.Quat | None, twist_cov: np.ndarray | None, new_chain: bool) -> None:
        cfg = self.config
        T = self._T
        if T <= 0.0:
            return
        if new_chain:
            self.gyro.reset_chain()
        if vals["angular_velocity"] is not None:
            w_now = _rotate(self._C_ib_rows, vals["angular_velocity"])
            if cfg.angular_velocity_noise_std is not None:
                rw = [cfg.angular_velocity_noise_std**2] * 3
            else:
                rw = self._twist_ang_cov(twist_cov, self.C_ib)
                rw = [cfg.default_angular_velocity_noise_std**2] * 3 if rw is None else rw
            prev, self._w_odo_prev = self._w_odo_prev, (w_now, rw)
            if prev is None or new_chain:
                return  # the trapezoid needs the rate at both ends of the interval
            # trapezoid: the twist is the rate at the stamp
            dtheta_odo = [0.5 * (a + b) * T for a, b in zip(prev[0], w_now, strict=True)]
            R = [0.25 * (a + b) * T * T for a, b in zip(prev[1], rw, strict=True)]
        elif q_nb is not None and self._q_nb_prev is not None:
            dq = rot.multiply(rot.conjugate(self._q_nb_prev), q_nb)
            dtheta_odo = _rotate(self._C_ib_rows, rot.to_rotvec(dq).tolist())
            std = cfg.angular_velocity_noise_std or cfg.default_angular_velocity_noise_std
            R = [(std * T) ** 2] * 3
        else:
            return
        y = [a - b for a, b in zip(self._dtheta, dtheta_odo, strict=True)]
        self._nis_gyro = self.gyro.update(y, T, R)

    # ------------------------------------------------------------------ results
    def _bias_var(self) -> np.ndarray:
        """Accelerometer-bias variance per axis, predicted to the current time."""
        f = self.filter
        if self._fast:
            return f.covariance(self._vel_interval() if self._T > 0 else None)[:, 1, 1]
        return (f.predict_covariance(self._interval()) if self._T > 0 else f.P)[:, 2, 2]

    def estimate(self) -> CmkfEstimate:
        """Current estimates (cheap; call at any rate). Between updates the covariance is predicted."""
        cfg = self.config
        f = self.filter
        n_stacked = f.count if self._fast else f.estimator.count
        t = max(x for x in (self._t_imu, self._t_odom, -math.inf) if x is not None)
        observed = (
            self._t_update is not None
            and self._t_state is not None
            and (self._t_state - self._t_update) <= cfg.max_odom_gap
            and (t - self._t_imu) <= cfg.max_imu_gap  # an IMU that stopped while odometry goes on observes nothing
        )
        if self._t_imu is None and self._t_odom is None:
            status = "no_data"
        elif self._t_imu is None:
            status = "no_imu"
        elif not f.initialised:
            status = "imu_only"
        elif not observed:
            status = "unobserved"
        elif n_stacked < cfg.min_samples:
            status = "converging"
        else:
            status = "tracking"
        if f.initialised:
            bias = np.array(self._b)
            bias_std = np.sqrt(self._bias_var())
            g_var = self.gyro.predicted_variance(self._T)
        else:
            bias = np.zeros(3)
            bias_std = np.full(3, cfg.accel_bias_sigma)
            g_var = np.full(3, cfg.gyro_bias_sigma**2)
        m = 2 if f.mode == "pos_vel" else 1
        return CmkfEstimate(
            t=float(t) if math.isfinite(t) else math.nan,
            status=status,
            observed=bool(observed),
            accel_bias=bias,
            accel_bias_std=bias_std,
            S_v=f.S_used.copy(),
            S_v_ls=f.S_ls if self._fast else f.estimator.estimate,
            accel_noise_density=np.sqrt(f.S_used),
            gyro_bias=self.gyro.b.copy(),
            gyro_bias_std=np.sqrt(g_var),
            S_g=self.gyro.S_used.copy(),
            S_g_ls=self.gyro.S_ls,
            gyro_noise_density=np.sqrt(self.gyro.S_used),
            nis_accel=self._nis_accel,
            nis_accel_dof=3 * m,
            nis_accel_mean=self._nis_sum / len(self._nis_hist) if self._nis_hist else math.nan,
            nis_gyro=self._nis_gyro,
            nis_gyro_dof=3,
            n_stacked=n_stacked,
            counters=dict(self.counters),
        )
