"""Steady-state innovation (whitening) filter of a fitted noise model, for score tests of missing regressors.

A fitted linear-Gaussian model (paper 000 eqs. 4–5: x_{t+1} = Φ x_t + w_t, y_t = H x_t + v_t) turns the
data into standardised innovations e_t that are i.i.d. N(0, 1) if the model holds. Passing a candidate
deterministic regressor x_t (a temperature series, a step, a ramp, a sinusoid) through the *same* filter gives
its whitened version x̃_t; the generalised-least-squares coefficient of x and its Lagrange-multiplier (score)
statistic are then

    b = Σ e_t x̃_t / Σ x̃_t²,        T = Σ e_t x̃_t / √(Σ x̃_t²)  ~ N(0, 1) under "x is not in the data".

This is the augmented-Kalman-filter view of regression with state-space errors (de Jong 1991): the GLS
normal equations are sums over whitened data and regressors. It goes beyond the papers (which fit stochastic
components only) and is what lets the closed loop test deterministic effects without refitting.

The filter uses the steady-state gain (Riccati limit), so it is exact after the initial transient; near missing
samples (where the time-varying filter would skip the update) it is an approximation, and the tests simply drop
those samples from the sums. Deterministic states (the RR ramp integrator, whose process noise is zero) do not
whiten anything and are left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

from ..errors import InputError
from ..kalman.riccati import steady_prediction_covariance
from ..noise.components import Component


def _stochastic_blocks(components: list[Component], dt: float) -> list:
    """The state blocks of the components that have states (RR's deterministic integrator left out)."""
    return [b for b in (c.block(dt) for c in components if c.name not in ("RR", "WN")) if b.n_states > 0]


def _system(components: list[Component], dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    r = float(sum(c.block(dt).r for c in components if c.name == "WN"))
    stoch = _stochastic_blocks(components, dt)
    if not stoch:
        return np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0), r
    phi = linalg.block_diag(*[b.phi for b in stoch])
    q = linalg.block_diag(*[b.q for b in stoch])
    h = np.concatenate([b.h for b in stoch])
    return phi, q, h, r


#: The white-noise variance R the filter uses is at least this fraction of the state noise seen at the output in one
#: step (h Q hᵀ): a fitted white noise below it (the loop's fits beside an LPF or MA that carries the whole
#: high-frequency density reach R ≈ 1e-12 of it) leaves the Riccati equation too ill-conditioned for either solver.
#: Raising R by δ raises the innovation variance S ≥ h Q hᵀ by about √(δ · h Q hᵀ) at most (a random walk beside
#: white noise: S ≈ q + √(q r)), i.e. by ≲ 3·10⁻⁵ of S here.
R_FLOOR = 1e-9


def _filter_r(q: np.ndarray, h: np.ndarray, r: float) -> float:
    """R raised to :data:`R_FLOOR` · h Q hᵀ (the trace of Q if no state noise reaches the output in one step).

    Beyond the papers: with R → 0 the steady-state filter still exists when a state with process noise is
    observed (the singular filtering problem; S → h Q hᵀ), but the doubling's G = hᵀh / R and the symplectic
    pencil of scipy's solver then lose it ("eigenvalues too close to the unit circle"; ADIS16405 run 4 accel_z,
    ``test_whitening_filter_of_a_model_whose_white_noise_went_to_zero``).
    """
    seen = float(h @ q @ h) or float(np.trace(q))
    return max(r, R_FLOOR * seen)


def _steady_state_p(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float) -> np.ndarray:
    """Predicted-state covariance P of the discrete algebraic Riccati equation.

    The doubling algorithm of :func:`imu_noise_id.core.kalman.statespace.steady_prediction_covariance` first (robust
    for the nearly-unit-root random walks of IMU models), scipy's generalised-eigenvalue DARE solver (scaled
    by R) as the fallback.

    Raises
    ------
    ValueError
        If neither converges (a non-detectable or degenerate model).
    """
    try:
        return steady_prediction_covariance(phi, q, h, r)
    except (InputError, np.linalg.LinAlgError):
        pass
    scale = r if r > 0 else float(np.trace(q)) or 1.0
    try:
        p = linalg.solve_discrete_are(phi.T, h[:, None], q / scale, np.array([[max(r / scale, 1e-12)]]))
    except (linalg.LinAlgError, ValueError) as exc:
        raise ValueError(f"no steady-state Kalman filter for this model: {exc}") from None
    if not np.all(np.isfinite(p)):
        raise ValueError("no steady-state Kalman filter for this model (non-finite Riccati solution)")
    return p * scale


@dataclass(frozen=True)
class WhiteningFilter:
    """The fitted model's steady-state innovation filter, as second-order sections.

    Attributes
    ----------
    sos : (n_sections, 6) array
        The LTI filter x → x̃ (innovation of x: x_t − H x̂_{t|t−1}), for :func:`scipy.signal.sosfilt`.
    innovation_variance : float
        Steady-state innovation variance S = H P Hᵀ + R [u²].
    """

    sos: np.ndarray
    innovation_variance: float

    @classmethod
    def from_components(cls, components: list[Component], dt: float) -> WhiteningFilter:
        """Build the filter of a model given as fitted components (see :mod:`imu_noise_id.core.noise.components`).

        Raises
        ------
        ValueError
            If the model has no noise (innovation variance 0).
        """
        phi, q, h, r = _system(list(components), dt)
        if phi.size == 0:
            if r <= 0:
                raise ValueError("model has no stochastic component: nothing to whiten with")
            return cls(sos=np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]]), innovation_variance=r)
        r = _filter_r(q, h, r)
        p = _steady_state_p(phi, q, h, r)
        s = float(h @ p @ h + r)
        if not (s > 0 and math.isfinite(s)):
            raise ValueError("model has a non-positive innovation variance")
        k = phi @ p @ h / s  # predictor gain
        a = phi - np.outer(k, h)
        # x → x̃ is 1 − h (zI − A)⁻¹ k = det(zI − Φ) / det(zI − A) (matrix determinant lemma, A + k h = Φ): its zeros
        # are the eigenvalues of Φ, taken block by block (exact for a GM, RW or flicker ladder, where a generic
        # invariant-zero computation loses the clustered zeros near 1 and the filter blows up), gain 1.
        zeros = np.concatenate([np.linalg.eigvals(b.phi) for b in _stochastic_blocks(list(components), dt)])
        return cls(sos=signal.zpk2sos(zeros, np.linalg.eigvals(a), 1.0), innovation_variance=s)

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """Standardised innovations x̃ / √S of regressor column(s) ``x`` ((N,) or (N, k)), zero initial state."""
        x = np.asarray(x, dtype=float)
        return signal.sosfilt(self.sos, x, axis=0) / math.sqrt(self.innovation_variance)


@dataclass(frozen=True)
class ScoreTest:
    """Score (LM) test of adding regressor columns to a fitted model.

    Attributes
    ----------
    statistic : float
        e'X̃(X̃'X̃)⁻¹X̃'e ~ χ²_k under H0 (k = number of columns); for k = 1, T² with T ~ N(0, 1).
    dof : int
        k.
    log10_p : float
        log10 P(χ²_k ≥ statistic).
    coef : (k,) array
        GLS one-step estimate of the regressors' coefficients [u per regressor unit].
    se : (k,) array
        Their standard errors.
    """

    statistic: float
    dof: int
    log10_p: float
    coef: np.ndarray
    se: np.ndarray


def _projection(z: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Least-squares coefficients of x (N, k) on z (N, j): in closed form for one column z (what every detector
    projects out: the whitened constant), else by ``lstsq``."""
    if z.shape[1] == 1:
        zz = float(z[:, 0] @ z[:, 0])
        return (z[:, 0] @ x)[None, :] / zz if zz > 0 else np.zeros((1, x.shape[1]))
    return np.linalg.lstsq(z, x, rcond=None)[0]


def score_test(e: np.ndarray, x_white: np.ndarray, nuisance_white: np.ndarray | None = None) -> ScoreTest:
    """Score test of whitened regressors ``x_white`` against standardised innovations ``e`` (NaN = missing).

    ``nuisance_white`` (whitened columns already in the model, e.g. the constant) are projected out of
    ``x_white`` first, so the test is for what the new columns add beyond them.
    """
    from .residuals import chi2_log10_sf

    e = np.asarray(e, dtype=float)
    x = np.asarray(x_white, dtype=float).reshape(e.size, -1)
    ok = np.isfinite(e)
    every = bool(ok.all())  # no missing sample: the arrays as they are, no copies
    e0, x0 = (e, x) if every else (e[ok], x[ok])
    if nuisance_white is not None:
        z = np.asarray(nuisance_white, dtype=float).reshape(e.size, -1)
        z = z if every else z[ok]
        x0 = x0 - z @ _projection(z, x0)
    gram = x0.T @ x0
    if np.linalg.cond(gram) > 1e12:
        raise ValueError("regressors are (nearly) collinear with the model after whitening")
    score = x0.T @ e0
    inv = np.linalg.inv(gram)
    stat = float(score @ inv @ score)
    k = x.shape[1]
    return ScoreTest(statistic=stat, dof=k, log10_p=chi2_log10_sf(stat, k),
                     coef=inv @ score, se=np.sqrt(np.diag(inv)))
