"""The vectorised Kalman-filter bank and the posterior over hypotheses and grid points (paper 002 eqs. 4–14): one
filter per grid point, all F filters and ``L`` streams in one array step; the data-independent recursion (eqs. 5–6,
8) once for all streams, frozen when the gains settle (``gain_tolerance``); weights μ_0 exp(c) (eq. 9) normalised by
log-sum-exp (eqs. 10–12). Only Λ (eq. 8) is inverted, never R (zero measurement noise, case 1)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .model import BankModel
from .subcell import GridAxes, refine

_LOG_2PI = math.log(2.0 * math.pi)
#: Steps between two checks of the gains' convergence.
_FREEZE_CHECK_EVERY = 16


@dataclass
class Posterior:
    """Posterior after each sample of a block (leading axes (T, L)): ``log_prob`` (T, L, K) (eq. 10); ``theta_mean``,
    ``theta_var`` per k (T, L, p_k), θ̂^k_i (eq. 13) and the diagonal of P^θk_i (eq. 14)."""

    log_prob: np.ndarray
    theta_mean: list[np.ndarray]
    theta_var: list[np.ndarray]


class FilterBank:
    """State of the F Kalman filters for L data streams: ``x`` (n, L, F) x̂_i^{kj} (eq. 4), ``c`` (L, F) cumulative
    log-likelihoods, ``P`` (n², F) P_i^{kj} (vec, eq. 6) shared by the streams."""

    def __init__(self, model: BankModel, n_streams: int = 1, gain_tolerance: float = 1e-10) -> None:
        self.model = model
        self.n_streams = int(n_streams)
        self.gain_tolerance = float(gain_tolerance)
        off = model.phi.copy()
        for i in range(model.n):
            off[i, i] = 0.0
        diagonal = not off.any()
        self._diag_phi = np.ascontiguousarray(np.einsum("iif->if", model.phi)) if diagonal else None
        self._phiphi = (np.einsum("if,jf->ijf", self._diag_phi, self._diag_phi).reshape(model.n**2, -1)
                        if diagonal else None)
        self._h_ones = bool(np.all(model.h == 1.0))
        self._phi4 = model.phi[:, :, None, :]
        self._h3 = model.h[:, None, :]
        self._h_mat = model.h[None, :, :]
        # per hypothesis: filter slice, indices of the unknown parameters, their grid values (n_free, F_k), θ row 0
        self._hyp_params = []
        for sl, th in zip(model.slices, model.theta, strict=True):
            free = np.flatnonzero(~np.all(th == th[0], axis=0))
            self._hyp_params.append((sl, free, np.ascontiguousarray(th[:, free].T), th[0].copy()))
        self._grid_axes = [GridAxes.of(th) for th in model.theta]
        self.reset()

    def reset(self) -> None:
        """Back to the prior: x̂₀ = 0, P₀, c = 0."""
        m = self.model
        self.x = np.zeros((m.n, self.n_streams, m.n_filters))
        self.c = np.zeros((self.n_streams, m.n_filters))
        self.P = m.p0.copy()
        self.K = np.zeros((m.n, m.n_filters))
        self.S = np.ones(m.n_filters)
        self.frozen = False
        self.n_steps = 0

    # -- covariance recursion (data independent) -------------------------------------------------------
    def _riccati(self) -> None:
        """One step of eqs. (5), (6), (8) for all filters (Λ > 0 checked by :meth:`advance`)."""
        m = self.model
        n = m.n
        if self._phiphi is not None:
            Pp = self._phiphi * self.P
            Pp += m.q
        else:
            Pp = (m.phi_kron * self.P[None, :, :]).sum(axis=1) + m.q
        if self._h_ones:
            Ph = _sum_leading(Pp.reshape(n, n, -1).swapaxes(0, 1))
            S = _sum_leading(Ph)
            S += m.r
        else:
            Ph = (Pp.reshape(n, n, -1) * self._h_mat).sum(axis=1)
            S = (Ph * m.h).sum(axis=0) + m.r
        K = Ph / S
        Pp -= (K[:, None, :] * Ph[None, :, :]).reshape(n * n, -1)
        self.P = Pp
        if self.gain_tolerance > 0 and self.n_steps % _FREEZE_CHECK_EVERY == 0 and self.n_steps > 0:
            dk = float(np.max(np.abs(K - self.K)))
            ds = float(np.max(np.abs(S - self.S) / S))
            self.frozen = dk <= self.gain_tolerance and ds <= self.gain_tolerance
        self.K, self.S = K, S

    # -- data-dependent part ---------------------------------------------------------------------------
    def advance(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eqs. (4)–(8) over ``y`` (T, L): innovations λ (T, L, F) (eq. 7), variances Λ (T, F) (eq. 8);
        FloatingPointError if some Λ ≤ 0."""
        T = y.shape[0]
        F = self.model.n_filters
        lam = np.empty((T, self.n_streams, F))
        S_out = np.empty((T, F))
        yb = y[:, :, None]
        x = self.x
        xp = np.empty_like(x)
        gain_term = np.empty_like(x)
        diag_phi = self._diag_phi[:, None, :] if self._diag_phi is not None else None
        with np.errstate(divide="ignore", invalid="ignore"):
            for t in range(T):
                if not self.frozen:
                    self._riccati()
                if diag_phi is not None:
                    np.multiply(diag_phi, x, out=xp)
                else:
                    xp = (self._phi4 * x[None]).sum(axis=1)
                innov = lam[t]
                np.subtract(yb[t], _sum_leading(xp) if self._h_ones else (self._h3 * xp).sum(axis=0), out=innov)
                np.multiply(self.K[:, None, :], innov, out=gain_term)
                x = xp + gain_term
                S_out[t] = self.S
                self.n_steps += 1
        if not S_out.min() > 0:
            bad = int(np.argmin(S_out.min(axis=0)))
            raise FloatingPointError(f"innovation variance of filter {bad} is {S_out[:, bad].min()}: a grid point "
                                     "has no process or measurement noise")
        self.x = x
        return lam, S_out

    def gap(self, n_missing: int) -> None:
        """Predict over ``n_missing`` samples: x ← Φᵍx, P ← ΦᵍPΦᵍᵀ + Σ ΦⁱQΦⁱᵀ; likelihoods untouched."""
        if n_missing <= 0:
            return
        m = self.model
        n, F = m.n, m.n_filters
        eye = np.broadcast_to(np.eye(n)[:, :, None], (n, n, F))
        A_r, Q_r = eye.copy(), np.zeros((n, n, F))
        A_b, Q_b = m.phi.copy(), m.q.reshape(n, n, F).copy()
        g = int(n_missing)
        while g:
            if g & 1:
                A_r = np.einsum("ijf,jkf->ikf", A_b, A_r)
                Q_r = np.einsum("ijf,jkf,lkf->ilf", A_b, Q_r, A_b) + Q_b
            g >>= 1
            if g:
                Q_b = np.einsum("ijf,jkf,lkf->ilf", A_b, Q_b, A_b) + Q_b
                A_b = np.einsum("ijf,jkf->ikf", A_b, A_b)
        P = self.P.reshape(n, n, F)
        self.P = (np.einsum("ijf,jkf,lkf->ilf", A_r, P, A_r) + Q_r).reshape(n * n, F)
        self.x = np.einsum("ijf,jlf->ilf", A_r, self.x)
        self.frozen = False

    def accumulate(self, lam: np.ndarray, S: np.ndarray) -> np.ndarray:
        """Add a block's log-likelihoods (eq. 9) sample by sample; c after each sample (T, L, F)."""
        logS = np.log(S)
        ell = -0.5 * ((_LOG_2PI + logS)[:, None, :] + lam * lam / S[:, None, :])
        c = self.c
        for t in range(ell.shape[0]):
            np.add(c, ell[t], out=ell[t])
            c = ell[t]
        self.c = c.copy()
        return ell

    def evaluate(self, c: np.ndarray) -> Posterior:
        """Eqs. (10)–(14) from c (R, L, F) per row; parameters resolved below one cell: :mod:`.subcell` (beyond)."""
        m = self.model
        lead = c.shape[:-1]
        lj = c + m.log_mu0
        lse = np.empty((*lead, len(m.slices)))
        means, variances = [], []
        for k, (sl, free, grid, theta0) in enumerate(self._hyp_params):
            part = lj[..., sl]
            top = part.max(axis=-1, keepdims=True)
            e = np.exp(part - top)
            tot = e.sum(axis=-1, keepdims=True)
            lse[..., k] = (top + np.log(tot))[..., 0]
            mean = np.empty((*lead, theta0.size))
            mean[...] = theta0
            var = np.zeros((*lead, theta0.size))
            if free.size:
                mu = (e / tot)[..., None, :]  # eq. (12)
                mi = (mu * grid).sum(axis=-1)  # eq. (13)
                dev = grid - mi[..., None]
                mean[..., free] = mi
                var[..., free] = (mu * (dev * dev)).sum(axis=-1)  # eq. (14), diagonal
                if self._grid_axes[k] is not None:  # parameters resolved below one cell (beyond the paper)
                    refine(part, self._grid_axes[k], mean, var)
            means.append(mean)
            variances.append(var)
        joint = lse + m.log_prior
        jtop = joint.max(axis=-1, keepdims=True)
        log_prob = joint - (jtop + np.log(np.exp(joint - jtop).sum(axis=-1, keepdims=True)))  # eq. (10)
        return Posterior(log_prob=log_prob, theta_mean=means, theta_var=variances)

    def state_mixture(self, stream: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per hypothesis, the mixture state mean and covariance (eqs. 13–14) of one stream."""
        m = self.model
        n = m.n
        lj = self.c[stream] + m.log_mu0
        out = []
        P = self.P.reshape(n, n, -1)
        for k, sl in enumerate(m.slices):
            part = lj[sl]
            mu = np.exp(part - part.max())
            mu /= mu.sum()
            d = len(m.state_names[k])
            xs = self.x[:d, stream, sl]
            mean = xs @ mu
            second = np.einsum("if,jf,f->ij", xs, xs, mu) + np.einsum("ijf,f->ij", P[:d, :d, sl], mu)
            out.append((mean, second - np.outer(mean, mean)))
        return out


def _sum_leading(a: np.ndarray) -> np.ndarray:
    """``a.sum(axis=0)`` as a chain of adds (same order; fewer calls for short axes)."""
    out = a[0] + a[1] if a.shape[0] > 1 else a[0].copy()
    for row in a[2:]:
        out += row
    return out


def check_samples(y: np.ndarray, what: str = "samples") -> np.ndarray:
    """Float array of finite samples, else :class:`InputError`."""
    arr = np.asarray(y, dtype=float)
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr.ravel()))[0])
        raise InputError(f"{what} contain NaN or inf (first at index {bad}): remove or interpolate them first")
    return arr
