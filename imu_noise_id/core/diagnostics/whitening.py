"""Steady-state innovation (whitening) filter of a fitted model (paper 000 eqs. 4–5) for score tests of missing
regressors: e_t i.i.d. N(0, 1) if the model holds; a regressor through the same filter x̃_t, b = Σ e_t x̃_t / Σ
x̃_t², T = Σ e_t x̃_t / √(Σ x̃_t²) ~ N(0, 1) (GLS with state-space errors, de Jong 1991). Approximate near missing
samples (dropped); RR's states left out."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg, signal

from ..errors import InputError
from ..kalman.riccati import steady_prediction_covariance
from ..noise.components import Component


def _stochastic_blocks(components: list[Component], dt: float) -> list:
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


#: Floor of the white-noise variance R the filter uses, as a fraction of h Q hᵀ (reasons: docs/loop.md).
R_FLOOR = 1e-9


def _filter_r(q: np.ndarray, h: np.ndarray, r: float) -> float:
    """R raised to :data:`R_FLOOR` · h Q hᵀ (trace of Q if no state noise reaches the output in one step)."""
    seen = float(h @ q @ h) or float(np.trace(q))
    return max(r, R_FLOOR * seen)


def _steady_state_p(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float) -> np.ndarray:
    """P of the DARE (scipy's solver as fallback); ValueError if neither converges."""
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


#: Lengths whose whitened constant a :class:`WhiteningFilter` keeps (the record's, or the watch's few window lengths).
CONSTANTS_KEPT = 4


@dataclass(frozen=True)
class WhiteningFilter:
    """Steady-state innovation filter x → x̃ = x_t − H x̂_{t|t−1} as ``sos``, ``innovation_variance`` S [u²]."""

    sos: np.ndarray
    innovation_variance: float
    #: :meth:`whitened_constant` by length, the latest :data:`CONSTANTS_KEPT` (a copy made by ``dataclasses.replace``
    #: starts empty)
    _constants: dict[int, np.ndarray] = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def from_components(cls, components: list[Component], dt: float) -> WhiteningFilter:
        """The filter of fitted ``components`` at period ``dt`` [s]; ValueError if the model has no noise."""
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
        # x → x̃ = det(zI − Φ) / det(zI − A), zeros block by block (docs/diagnostics.md, "Why the whitening filter …")
        zeros = np.concatenate([np.linalg.eigvals(b.phi) for b in _stochastic_blocks(list(components), dt)])
        return cls(sos=signal.zpk2sos(zeros, np.linalg.eigvals(a), 1.0), innovation_variance=s)

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """Standardised innovations x̃ / √S of regressor column(s) ``x`` ((N,) or (N, k)), zero initial state."""
        x = np.asarray(x, dtype=float)
        return signal.sosfilt(self.sos, x, axis=0) / math.sqrt(self.innovation_variance)

    def whitened_constant(self, n: int) -> np.ndarray:
        """:meth:`whiten` of ``n`` ones (the bias every score test projects out), computed once per length and kept
        for the latest :data:`CONSTANTS_KEPT` lengths (read-only, shared by the tests that ask for it)."""
        if n not in self._constants:
            if len(self._constants) >= CONSTANTS_KEPT:
                del self._constants[next(iter(self._constants))]
            constant = self.whiten(np.ones(n))
            constant.flags.writeable = False
            self._constants[n] = constant
        return self._constants[n]


@dataclass(frozen=True)
class ScoreTest:
    """Score test of k columns: ``statistic`` e'X̃(X̃'X̃)⁻¹X̃'e ~ χ²_k, ``dof``, ``log10_p``, GLS ``coef``, ``se``."""

    statistic: float
    dof: int
    log10_p: float
    coef: np.ndarray
    se: np.ndarray


def _kept(ok: np.ndarray) -> slice | np.ndarray:
    idx = np.flatnonzero(ok)
    if idx.size and idx[-1] - idx[0] + 1 == idx.size:
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return ok


@dataclass(frozen=True)
class ScoreBasis:
    """Finite innovations ``e`` (at ``kept``) and whitened nuisance columns ``z`` (n, j) or None, for many score
    tests."""

    e: np.ndarray
    kept: slice | np.ndarray
    z: np.ndarray | None

    @classmethod
    def of(cls, e: np.ndarray, nuisance_white: np.ndarray | None = None) -> ScoreBasis:
        e = np.asarray(e, dtype=float)
        kept = _kept(np.isfinite(e))
        z = None if nuisance_white is None else np.asarray(nuisance_white, dtype=float).reshape(e.size, -1)[kept]
        return cls(e[kept], kept, z)

    def test(self, x_white: np.ndarray) -> ScoreTest:
        """Score test of whitened columns ``x_white`` (N, k) less their projection on the nuisance."""
        from .residuals import chi2_log10_sf

        x = np.asarray(x_white, dtype=float).reshape(x_white.shape[0], -1)[self.kept]
        gram, score = x.T @ x, x.T @ self.e
        if self.z is not None and self.z.shape[1] == 1:
            z = self.z[:, 0]
            zz = float(z @ z)
            if zz > 0:
                xz = x.T @ z
                gram = gram - np.outer(xz, xz) / zz
                score = score - xz * float(z @ self.e) / zz
        elif self.z is not None:
            x = x - self.z @ np.linalg.lstsq(self.z, x, rcond=None)[0]
            gram, score = x.T @ x, x.T @ self.e
        if np.linalg.cond(gram) > 1e12:
            raise ValueError("regressors are (nearly) collinear with the model after whitening")
        inv = np.linalg.inv(gram)
        stat = float(score @ inv @ score)
        k = x.shape[1]
        return ScoreTest(statistic=stat, dof=k, log10_p=chi2_log10_sf(stat, k),
                         coef=inv @ score, se=np.sqrt(np.diag(inv)))


def score_test(e: np.ndarray, x_white: np.ndarray, nuisance_white: np.ndarray | None = None) -> ScoreTest:
    """Score test of whitened ``x_white`` against innovations ``e`` (NaN: missing), ``nuisance_white`` projected out."""
    return ScoreBasis.of(e, nuisance_white).test(x_white)
