"""Fast Kalman engine for time-invariant models in steady state (Σ = P̄, paper 000 appendix at its fixed point; no
missing samples): constant K, F, J make filter and smoother IIR filters in the modal or real Schur basis
(:func:`.basis.decoupled_basis`; why: docs/em.md, "Why the Kalman engines …")

    predicted state  x_{t+1} = A x_t + ΦK y_t + u,        A = Φ(I − K H)          (forward, causal)
    smoothed state   x_t^N = x_t^{t−1} + P̄ r_{t−1},  r_{t−1} = Hᵀ e_t / F + Aᵀ r_t   (backward, anti-causal)

P_{t−1}^N = J P_t^N Jᵀ + (P_f − J P̄ Jᵀ) (:func:`affine_power_sum`); P_{t,t−1}^N = P_t^N Jᵀ (de Jong 1989)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from ..errors import InputError
from . import harmonic
from .basis import Basis, blocks, decoupled_basis
from .common import LOG_2PI, Columns, DisturbanceSums, InnovationResult, ProfileResult, SmootherStats, profile
from .statespace import StateSpace


@dataclass(frozen=True)
class SteadyGains:
    """Constant gains: ``p_pred`` P̄, ``p_filt`` P_t^t, ``k`` K, ``f`` F, ``a`` Φ(I − K H), ``j`` P_f Φᵀ P̄⁻¹."""

    p_pred: np.ndarray  # P̄ = P_t^{t−1}
    p_filt: np.ndarray  # P_t^t
    k: np.ndarray  # Kalman gain on the predicted state
    f: float  # innovation variance
    a: np.ndarray  # Φ(I − K H)
    j: np.ndarray  # smoother gain P_f Φᵀ P̄⁻¹


def gains(model: StateSpace) -> SteadyGains:
    """Steady-state gains of ``model`` (DARE); InputError if the innovation variance is not positive and finite."""
    P = model.steady_prediction_covariance()
    h = model.h
    Ph = P @ h
    f = float(h @ Ph) + float(model.r)
    if not (math.isfinite(f) and f > 0.0):
        raise InputError(f"the steady-state innovation variance is {f:.3g}; no Kalman filter at these parameters")
    k = Ph / f
    Pf = P - np.outer(k, Ph)
    Pf = 0.5 * (Pf + Pf.T)
    a = model.phi @ (np.eye(model.n_states) - np.outer(k, h))
    j = np.linalg.lstsq(P.T, (Pf @ model.phi.T).T, rcond=None)[0].T
    return SteadyGains(P, Pf, k, f, a, j)


def _strictly_proper(num: tuple[float, ...], den: list[float], d: np.ndarray, w0: np.ndarray) -> np.ndarray:
    """Strictly proper filter num/den (num[0] = 0) along the last axis of d, w0 as the initial delay state."""
    return lfilter(num, den, d, axis=-1, zi=np.multiply.outer(w0, num[1:]))[0]


def _accumulate(terms: Iterable[np.ndarray]) -> np.ndarray:
    it = iter(terms)
    out = next(it)
    for term in it:
        out += term
    return out


def _characteristic(B: np.ndarray) -> list[float]:
    if B.shape[0] == 1:
        return [1.0, -B[0, 0]]
    return [1.0, -(B[0, 0] + B[1, 1]), B[0, 0] * B[1, 1] - B[0, 1] * B[1, 0]]


def _run_block(B: np.ndarray, d: np.ndarray, w0: np.ndarray, out: np.ndarray) -> None:
    """x_0 = w0, x_{t+1} = B x_t + d_t for one 1×1 or 2×2 block into ``out``; d, out (s, m, N), w0 (s, m)."""
    den = _characteristic(B)
    if B.shape[0] == 1:
        out[...] = _strictly_proper((0.0, 1.0), den, d, w0)
        return
    adj = (((0.0, 1.0, -B[1, 1]), (0.0, 0.0, B[0, 1])), ((0.0, 0.0, B[1, 0]), (0.0, 1.0, -B[0, 0])))
    for r in range(2):
        out[r] = _accumulate(_strictly_proper(adj[r][c], den, d[c], w0[c])
                             for c in range(2) if adj[r][c][2] != 0 or c == r)


def _adjugate_numerators(B: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(r, s, 3): per row of ``c`` (r, s) and state k of a 1×1 or 2×2 block B, the strictly proper numerator of
    c·adj(zI − B)·e_k in powers of z⁻¹ (denominator :func:`_characteristic`; a 1×1 block's third tap 0)."""
    if B.shape[0] == 1:
        return np.stack([np.zeros_like(c[:, 0]), c[:, 0], np.zeros_like(c[:, 0])], axis=-1)[:, None, :]
    return np.stack([
        np.stack([np.zeros(c.shape[0]), c[:, 0], c[:, 1] * B[1, 0] - c[:, 0] * B[1, 1]], axis=-1),
        np.stack([np.zeros(c.shape[0]), c[:, 1], c[:, 0] * B[0, 1] - c[:, 1] * B[0, 0]], axis=-1)], axis=1)


def _driven_block(B: np.ndarray, c: np.ndarray, gain: np.ndarray, y: np.ndarray, *, const: np.ndarray,
                  w0: np.ndarray) -> list[np.ndarray]:
    """c·x_t, one (m, N) array per row of c (r, s), of one block's recursion x_0 = w0,
    x_{t+1} = B x_t + gain·y_t + const, y (m, N), const and w0 (s, m). Every state's input is a multiple of y plus a
    constant, so by linearity each row is one filter of y with numerator Σ_k gain_k·num_k (not one per state), its
    initial delay states Σ_k w0_k·num_k, plus the constants' step responses from the block's all-pole step response
    q = lfilter(1, den, 1) shifted by each tap; a 1×1 block filters its input directly."""
    den = _characteristic(B)
    nums = _adjugate_numerators(B, c)
    n = y.shape[1]
    if B.shape[0] == 1:
        d, scale = (gain[0] * y + const[0][:, None], 1.0) if np.any(const) else (y, gain[0])
        return [lfilter(scale * num[0, :2], den, d, axis=-1, zi=np.multiply.outer(w0[0], num[0, 1:2]))[0]
                for num in nums]
    outputs = []
    q = None
    for num in nums:
        out = lfilter(gain @ num, den, y, axis=-1, zi=w0.T @ num[:, 1:])[0]
        outputs.append(out)
        num_c = const.T @ num  # (m, 3): the constants' numerators per column
        rows = np.flatnonzero(np.any(num_c != 0.0, axis=1))
        if not rows.size:
            continue
        if q is None:
            q = lfilter([1.0], den, np.ones(n))
        for tap in range(1, num_c.shape[1]):
            out[rows, tap:] += num_c[rows, tap, None] * q[: n - tap]
    return outputs


def _run_modes(T: np.ndarray, gain: np.ndarray, y: np.ndarray, const: np.ndarray, w0: np.ndarray) -> np.ndarray:
    """w_0 = w0, w_{t+1} = T w_t + gain·y_t + const (p, m, N) for quasi-triangular T, block by block from the last;
    y (m, N), gain (p,), const and w0 (p, m). Each block's input is built when its turn comes (not p × m × N at
    once)."""
    m, n = y.shape
    w = np.empty((T.shape[0], m, n))
    for blk in reversed(blocks(T)):
        drive = gain[blk, None, None] * y[None]
        drive += const[blk, :, None]
        later = slice(blk.stop, T.shape[0])
        if later.start < later.stop and np.any(T[blk, later]):
            drive += np.tensordot(T[blk, later], w[later], axes=1)
        _run_block(T[blk, blk], drive, w0[blk], out=w[blk])
    return w


#: Sinusoidal columns go in closed form when their free responses cost less than this share of
#: filtering the columns through every block.
CLOSED_FORM_SHARE = 0.5


def _predicted_output(model: StateSpace, g: SteadyGains, cols: Columns) -> tuple[np.ndarray, Basis | None]:
    """H x_t^{t−1} (m, N) of every column (affine columns and, where cheaper, sinusoids in closed form) and the basis
    (None: no states)."""
    p = model.n_states
    m, n = cols.y.shape
    if p == 0:
        return np.zeros((m, n)), None
    b = decoupled_basis(g.a)
    declared = np.flatnonzero(np.isfinite(cols.omega))
    poles = np.linalg.eigvals(g.a) if declared.size else np.zeros(0)  # (no sinusoid: nothing more per evaluation)
    closed = np.zeros(m, bool)
    closed[declared] = [harmonic.obeys(cols.y[c], cols.omega[c]) and harmonic.usable(poles, cols.omega[c])
                        for c in declared]
    affine = closed & (cols.omega == 0.0)  # one step response serves them all: always cheaper than filtering
    closed &= ~affine
    k, n_blocks = int(closed.sum()), len(blocks(b.t))
    length = harmonic.free_response_length(poles, n) if k else n
    free_cost = p * length if b.modal else min(k, p) * length * n_blocks  # one block over one column: 1 per sample
    if k and free_cost >= CLOSED_FORM_SHARE * k * n * n_blocks:  # the free responses would cost what they save
        closed[:] = False
    # a column of zeros without input or initial mean (the data's in a pass for the adjustment alone) stays zero
    zero = ~closed & ~affine & ~np.any(cols.g, axis=0) & ~np.any(cols.m0, axis=0)
    zero[zero] = [cols.y[r, 0] == 0.0 and not np.any(cols.y[r]) for r in np.flatnonzero(zero)]
    if not np.any(closed | affine | zero):
        return _filtered_output(model, g, b, cols.y, u=cols.g, m0=cols.m0), b
    out = np.empty((m, n))
    out[zero] = 0.0
    rows = np.flatnonzero(~closed & ~affine & ~zero)
    if rows.size:
        # consecutive rows (the data's): a view, not a copy
        plain = slice(int(rows[0]), int(rows[-1]) + 1) if rows[-1] - rows[0] == rows.size - 1 else rows
        out[plain] = _filtered_output(model, g, b, cols.y[plain], u=cols.g[:, plain], m0=cols.m0[:, plain])
    if np.any(affine):
        _affine_output(model, g, b, cols.y, rows=np.flatnonzero(affine), out=out)
    if np.any(closed):
        _sinusoid_output(model, g, b, cols, rows=np.flatnonzero(closed), out=out, length=length)
    return out, b


def _filtered_output(model: StateSpace, g: SteadyGains, b: Basis, y: np.ndarray, *, u: np.ndarray,
                     m0: np.ndarray) -> np.ndarray:
    """H x_t^{t−1} (m, N) of columns with inputs y (m, N), u (p, m) and initial means m0 (p, m)."""
    p = model.n_states
    m, n = y.shape
    gain_w = b.u_inv @ (model.phi @ g.k)
    g_w, w0, hu = b.u_inv @ u, b.u_inv @ m0, model.h @ b.u
    if not b.modal:
        w = _run_modes(b.t, gain_w, y, g_w, w0)
        return (hu @ w.reshape(p, -1)).reshape(m, n)
    outputs = (_driven_block(b.t[blk, blk], hu[blk][None, :], gain_w[blk], y, const=g_w[blk], w0=w0[blk])[0]
               for blk in blocks(b.t))
    return _accumulate(outputs)


def _sinusoid_output(model: StateSpace, g: SteadyGains, b: Basis, cols: Columns, *, rows: np.ndarray,
                     out: np.ndarray, length: int) -> None:
    """H x_t^{t−1} of sinusoidal columns into ``out[rows]``: steady response less the free response."""
    p, k = model.n_states, rows.size
    start = harmonic.steady_parts(g.a, model.phi @ g.k, model.h, cols.y, cols.omega, rows=rows, out=out)
    if b.modal:
        free = (b.u_inv @ start).T @ _modal_free_responses(b, model.h @ b.u, length)
    elif k <= p:
        free = _filtered_output(model, g, b, np.zeros((k, length)), u=np.zeros((p, k)), m0=start)
    else:
        free = start.T @ _filtered_output(model, g, b, np.zeros((p, length)), u=np.zeros((p, p)), m0=np.eye(p))
    for i, r in enumerate(rows):
        out[r, :length] -= free[i]


def _affine_output(model: StateSpace, g: SteadyGains, b: Basis, y: np.ndarray, *, rows: np.ndarray,
                   out: np.ndarray) -> None:
    """H x_t^{t−1} of the affine columns y_t = c₀ + c₁t (:func:`.harmonic.affine_coefficients`; no input u, no
    initial mean) into ``out[rows]``: c₀·s_t + c₁·Σ_{u<t} s_u, s the step response (:func:`_step_response`), since
    t = Σ_{u≥1} 1[t ≥ u] and the filter is linear and time-invariant."""
    step = _step_response(model, g, b, y.shape[1])
    summed = None
    for r in rows:
        c0, c1 = harmonic.affine_coefficients(y[r])
        np.multiply(step, c0, out=out[r])
        if c1 != 0.0:
            if summed is None:
                summed = np.empty_like(step)
                summed[0] = 0.0
                np.cumsum(step[:-1], out=summed[1:])
            out[r] += c1 * summed


def _step_response(model: StateSpace, g: SteadyGains, b: Basis, n: int) -> np.ndarray:
    """s_t = H x_t (N,) of x_{t+1} = A x_t + ΦK, x_0 = 0: in the modal basis in closed form from each mode's
    eigenvalue μ and weight κ (a 2 × 2 block [[a, β], [−β, a]] acts on w₀ + j w₁ as μ = a − jβ; κ = η γ / (1 − μ) with
    γ, η its input and output weights; :func:`.harmonic.step_response`); in the Schur basis a filtered column of
    ones."""
    gain_w = b.u_inv @ (model.phi @ g.k)
    if not b.modal:
        p = model.n_states
        return _filtered_output(model, g, b, np.ones((1, n)), u=np.zeros((p, 1)), m0=np.zeros((p, 1)))[0]
    hu = model.h @ b.u
    modes = []
    for blk in blocks(b.t):
        i = blk.start
        if blk.stop - i == 1:
            mu, gamma, eta = complex(b.t[i, i]), complex(gain_w[i]), complex(hu[i])
        else:
            mu = complex(b.t[i, i], -b.t[i, i + 1])
            gamma, eta = complex(gain_w[i], gain_w[i + 1]), complex(hu[i], -hu[i + 1])
        modes.append((mu, eta * gamma / (1.0 - mu)))
    return harmonic.step_response(modes, n)


def _modal_free_responses(b: Basis, hu: np.ndarray, length: int) -> np.ndarray:
    """R (p, length), R[j, t] = (H U)_blk T_blk^t e_j; the free response from w_0 = U⁻¹x_0 is w_0ᵀR."""
    out = np.empty((b.t.shape[0], length))
    for blk in blocks(b.t):
        s = blk.stop - blk.start
        out[blk] = _driven_block(b.t[blk, blk], hu[blk][None, :], np.zeros(s), np.zeros((s, length)),
                                 const=np.zeros((s, s)), w0=np.eye(s))[0]
    return out


def _block_states(T: np.ndarray, gain: np.ndarray, y: np.ndarray, const: np.ndarray, w0: np.ndarray, *,
                  modal: bool) -> np.ndarray:
    """w (p, N) of w_0 = w0, w_{t+1} = T w_t + gain·y_t + const for one input y (N,), const and w0 (p, 1): block by
    block with each state one row of adj(zI − B) where T is block-diagonal (``modal``), else :func:`_run_modes`."""
    if not modal:
        return _run_modes(T, gain, y[None, :], const, w0)[:, 0, :]
    w = np.empty((T.shape[0], y.size))
    for blk in blocks(T):
        size = blk.stop - blk.start
        rows = _driven_block(T[blk, blk], np.eye(size), gain[blk], y[None, :], const=const[blk], w0=w0[blk])
        for r, row in enumerate(rows):
            w[blk.start + r] = row[0]
    return w


def _predicted_modes(model: StateSpace, g: SteadyGains, b: Basis, y: np.ndarray, u: np.ndarray, *,
                     m0: np.ndarray) -> np.ndarray:
    """w_t = U⁻¹ x_t^{t−1} (p, N), the predicted states of one column in the basis ``b``: inputs y (N,), u (p,),
    initial mean m0 (p,)."""
    gain_w, g_w, w0 = b.u_inv @ (model.phi @ g.k), (b.u_inv @ u)[:, None], (b.u_inv @ m0)[:, None]
    return _block_states(b.t, gain_w, y, g_w, w0, modal=b.modal)


def _adjoint_modes(model: StateSpace, g: SteadyGains, b: Basis, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smoother's adjoint r in the basis ``b``, driven by the innovations e (N,) alone, in reversed time.

    Bryson–Frazier / de Jong (1989) in steady state (Durbin & Koopman 2012, eq. 4.44 with L_t = A):

        r_{t−1} = Hᵀ e_t / F + Aᵀ r_t,   r_{N−1} = 0,        x_t^N = x_t^{t−1} + P̄ r_{t−1}.

    With v = Uᵀ r (Aᵀ = U⁻ᵀ Tᵀ Uᵀ) the recursion runs block by block through Tᵀ, one filter of e per block row;
    reversed in time, σ_0 = 0 and σ_{k+1} = Tᵀ σ_k + Uᵀ Hᵀ e_{N−1−k} / F, so v_t = σ_{N−t}. Returns (σ (p, N) as
    σ_0 … σ_{N−1}, σ_N = v_0); ``U⁻ᵀ v_t`` is r_{t−1}."""
    gain = b.u.T @ model.h / g.f
    tt = b.t.T
    zero = np.zeros((tt.shape[0], 1))
    if b.modal:
        sigma = _block_states(tt, gain, e[::-1], zero, zero, modal=True)
    else:  # Tᵀ is lower quasi-triangular: run it with the states' order reversed (upper again)
        sigma = _block_states(tt[::-1, ::-1], gain[::-1], e[::-1], zero, zero, modal=False)[::-1]
    return sigma, tt @ sigma[:, -1] + gain * e[0]


def _innovations(model: StateSpace, g: SteadyGains, cols: Columns) -> tuple[InnovationResult, Basis | None]:
    """Every column's innovations (their constant variance F) and the basis the filters ran in (None: no states)."""
    hx, b = _predicted_output(model, g, cols)
    n = cols.y.shape[1]
    e = np.subtract(cols.y, hx, out=hx)
    return InnovationResult(e, np.full(n, g.f), np.ones(n, bool), constant_f=True), b


def innovations(model: StateSpace, cols: Columns) -> InnovationResult:
    """Innovations and their (constant) variance for every column; no missing samples allowed."""
    return _innovations(model, gains(model), cols)[0]


def affine_power_sum(J: np.ndarray, C: np.ndarray, P0: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Σ_{k=0}^{n−1} T^k(P0) and T^{n−1}(P0) for T(P) = J P Jᵀ + C by binary doubling (O(p³ log n)).

    With X_k(P) = Σ_{j<k} J^j P J^jᵀ, M_j = J^j C J^jᵀ, W_k = Σ_{j<k} j·M_j:

        Σ_{k<n} T^k(P0) = X_n(P0) + (n − 1)·X_n(C) − W_n,        T^{n−1}(P0) = J^{n−1} P0 J^{n−1}ᵀ + X_{n−1}(C),

    combining as A_{a+b} = A_a A_b, X_{a+b} = X_a + A_a X_b A_aᵀ, W_{a+b} = W_a + A_a (W_b + a·X_b) A_aᵀ; n ≥ 1.
    """

    def combine(first, second):
        (ka, Aa, Xpa, Xca, Wa), (kb, Ab, Xpb, Xcb, Wb) = first, second
        return (ka + kb, Aa @ Ab, Xpa + Aa @ Xpb @ Aa.T, Xca + Aa @ Xcb @ Aa.T, Wa + Aa @ (Wb + ka * Xcb) @ Aa.T)

    zero = np.zeros_like(J)
    one = (1, J, P0, C, zero)  # the sums over a single term

    def power(k):
        result = (0, np.eye(J.shape[0]), zero, zero, zero)
        step = one
        while k:
            if k & 1:
                result = combine(result, step)
            k >>= 1
            if k:  # (squared once more after the last bit, J^(2^m) could overflow and be thrown away)
                step = combine(step, step)
        return result

    head = power(n - 1)  # the sums to n follow from those to n − 1 by one more step (not a second doubling)
    _, a_last, _, xc_last, _ = head
    _, _, xp, xc, w = combine(head, one)
    total = xp + (n - 1) * xc - w
    last = a_last @ P0 @ a_last.T + xc_last
    return 0.5 * (total + total.T), 0.5 * (last + last.T)


def _smoothed(model: StateSpace, g: SteadyGains, b: Basis | None, w: np.ndarray, e: np.ndarray) -> SmootherStats:
    """Smoothed states and covariance sums from the predicted states w (p, N) in the basis ``b`` (overwritten: its
    memory holds the adjoint's part) and the innovations e (N,): x_t^N = U w_t + P̄ U⁻ᵀ v_t (:func:`_adjoint_modes`),
    two p × p products over the record, and two more for the score's sums (:func:`_disturbance_sums`)."""
    n = e.size
    disturbances = DisturbanceSums.none(0)
    if b is None:
        xs = np.zeros((0, n))
    else:
        xs = b.u @ w
        sigma, v_first = _adjoint_modes(model, g, b, e)
        back = g.p_pred @ b.u_inv.T
        reversed_part = np.matmul(back, sigma, out=w)  # w's memory, no longer needed
        xs[:, 1:] += reversed_part[:, :0:-1]
        xs[:, 0] += back @ v_first
        disturbances = _disturbance_sums(model, g, b, sigma, xs)
    J = g.j
    const = g.p_filt - J @ g.p_pred @ J.T
    with np.errstate(over="ignore", invalid="ignore"):
        sum_p, p_first = affine_power_sum(J, const, g.p_filt, n)
    if not (np.all(np.isfinite(sum_p)) and np.all(np.isfinite(p_first))):
        # J = P_f Φᵀ P̄⁻¹ with P̄ singular to rounding (a state the data pin down exactly): its powers overflow.
        raise InputError("the steady-state smoother's covariance sums overflow (a smoother gain on or outside the "
                         "unit circle); the model's variances are too far apart")
    sum_lag = (sum_p - p_first) @ J.T
    loglik = -0.5 * (n * (LOG_2PI + np.log(g.f)) + float(e @ e) / g.f)
    return SmootherStats(
        xs, sum_p, p_first, g.p_filt.copy(), sum_lag, sum_p.copy(), float(loglik), np.ones(n, bool), disturbances,
    )


def _disturbance_sums(model: StateSpace, g: SteadyGains, b: Basis, sigma: np.ndarray,
                      xs: np.ndarray) -> DisturbanceSums:
    """:class:`~.common.DisturbanceSums` from the adjoint in the basis ``b`` (σ of :func:`_adjoint_modes`; in 0-based
    time r_t = U⁻ᵀ σ_{N−1−t} for the disturbances t = 0 … N − 2) and the smoothed states ``xs``; N_t by
    N_{t−1} = Hᵀ H / F + Aᵀ N_t A from N_{N−1} = 0 (Durbin & Koopman 2012, eq. 4.42), summed by
    :func:`affine_power_sum`; L P̄ = Φ P_f. Two p × p products over the record."""
    n = xs.shape[1]
    if n < 2:
        return DisturbanceSums.none(xs.shape[0])
    ahead = sigma[:, 1:]  # σ_1 … σ_{N−1}: r_{N−2} … r_0
    rr = b.u_inv.T @ (ahead @ ahead.T) @ b.u_inv
    rx = b.u_inv.T @ _reversed_products(sigma, xs)
    info = np.outer(model.h, model.h) / g.f
    with np.errstate(over="ignore", invalid="ignore"):  # overflowed sums read as NaN by the score's users
        n_sum, _ = affine_power_sum(g.a.T, info, info, n - 1)
    return DisturbanceSums(0.5 * (rr + rr.T), rx, n_sum, n_sum @ (model.phi @ g.p_filt))


#: Samples per chunk of :func:`_reversed_products` (a copy of p × this many floats at a time).
REVERSED_CHUNK = 1 << 16


def _reversed_products(sigma: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Σ_{t=0}^{N−2} σ_{N−1−t} x_tᵀ for σ, x (p, N), chunk by chunk: a reversed view is not a BLAS operand, and
    reversing the whole of σ would copy p × N floats."""
    n = xs.shape[1]
    out = np.zeros((sigma.shape[0], xs.shape[0]))
    for start in range(0, n - 1, REVERSED_CHUNK):
        end = min(start + REVERSED_CHUNK, n - 1)
        out += np.ascontiguousarray(sigma[:, n - end:n - start][:, ::-1]) @ xs[:, start:end].T
    return out


def smooth(model: StateSpace, cols: Columns) -> SmootherStats:
    """E-step statistics of the data column (column 0) with constant gains."""
    g = gains(model)
    y = cols.y[0]
    if model.n_states == 0:
        return _smoothed(model, g, None, np.zeros((0, y.size)), y.copy())
    b = decoupled_basis(g.a)
    w = _predicted_modes(model, g, b, y, cols.g[:, 0], m0=cols.m0[:, 0])
    return _smoothed(model, g, b, w, y - (model.h @ b.u) @ w)


def profile_and_smooth(model: StateSpace, cols: Columns) -> tuple[ProfileResult, SmootherStats]:
    """GLS profile of the free mean parameters and the smoother at their estimate."""
    g = gains(model)
    inn, b = _innovations(model, g, cols)
    prof = profile(inn, cols.names)
    if b is None:
        return prof, _smoothed(model, g, None, np.zeros((0, cols.y.shape[1])), prof.innovations)
    weights = np.concatenate([[1.0], prof.beta])
    w = _predicted_modes(model, g, b, weights @ cols.y, cols.g @ weights, m0=cols.m0 @ weights)
    return prof, _smoothed(model, g, b, w, prof.innovations)
