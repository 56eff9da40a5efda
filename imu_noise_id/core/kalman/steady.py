"""Fast Kalman engine for time-invariant models in steady state (Σ = P̄, paper 000 appendix at its fixed point; no
missing samples): constant K, F, J make filter and smoother IIR filters in the modal or real Schur basis
(:func:`.basis.decoupled_basis`; why: docs/em.md, "Why the Kalman engines …")

    predicted state  x_{t+1} = A x_t + ΦK y_t + u,        A = Φ(I − K H)          (forward, causal)
    smoothed state   x_t^N = x_t^{t−1} + P̄ r_{t−1},  r_{t−1} = Hᵀ e_t / F + Aᵀ r_t   (backward, anti-causal)

P_{t−1}^N = J P_t^N Jᵀ + (P_f − J P̄ Jᵀ) (:func:`affine_power_sum`); P_{t,t−1}^N = P_t^N Jᵀ (de Jong 1989)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from . import blockfilter, harmonic
from .basis import Basis, blocks, decoupled_basis
from .common import (
    LOG_2PI,
    Columns,
    DisturbanceSums,
    InnovationResult,
    ProfileResult,
    SmootherStats,
    StateSums,
    profile,
)
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
        w = blockfilter.run_modes(b.t, gain_w, y, g_w, w0)
        return (hu @ w.reshape(p, -1)).reshape(m, n)
    outputs = (blockfilter.driven_block(b.t[blk, blk], hu[blk][None, :], gain_w[blk], y, const=g_w[blk], w0=w0[blk])[0]
               for blk in blocks(b.t))
    return blockfilter.accumulate(outputs)


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
        out[blk] = blockfilter.driven_block(b.t[blk, blk], hu[blk][None, :], np.zeros(s), np.zeros((s, length)),
                                 const=np.zeros((s, s)), w0=np.eye(s))[0]
    return out


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


#: Largest p × N the smoother holds whole: up to it the sweep is one span (its memory a few p × N arrays, 256 MiB
#: each at this size), beyond it spans of :data:`SPAN_FLOATS` whose forward filter runs twice (:func:`_sweep`): the
#: memory stops growing with N (10–15 % more time at 10⁶ samples, less time over 24 h; docs/em.md, "Why the Kalman
#: engines are built as they are").
WHOLE_FLOATS = 1 << 25
#: Floats of one p × L span where the record is longer than :data:`WHOLE_FLOATS` allows (8 MiB).
SPAN_FLOATS = 1 << 20


def span_length(p: int, n: int) -> int:
    """Samples per span of the smoother's sweep over ``n`` samples of ``p`` states (:data:`WHOLE_FLOATS`,
    :data:`SPAN_FLOATS`)."""
    return n if p * n <= WHOLE_FLOATS else max(1, SPAN_FLOATS // p)


@dataclass(frozen=True)
class _Forward:
    """The predicted states' recursion w_{t+1} = T w_t + gain·d_t + const in the basis ``b``, d the column the
    smoother runs on."""

    b: Basis
    gain: np.ndarray  # U⁻¹ Φ K (p,)
    const: np.ndarray  # U⁻¹ u (p, 1)

    def run(self, d: np.ndarray, w0: np.ndarray) -> np.ndarray:
        """w (p, L) over the span d (L,) from its first state w0 (p,)."""
        return blockfilter.block_states(self.b.t, self.gain, d, self.const, w0[:, None], modal=self.b.modal)

    def after(self, w: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The state after the span whose states are w and inputs d."""
        return self.b.t @ w[:, -1] + self.gain * d[-1] + self.const[:, 0]


def _adjoint_span(model: StateSpace, g: SteadyGains, b: Basis, e: np.ndarray,
                  sigma0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smoother's adjoint in the basis ``b`` over one span of reversed time, driven by the innovations alone.

    Bryson–Frazier / de Jong (1989) in steady state (Durbin & Koopman 2012, eq. 4.44 with L_t = A):

        r_{t−1} = Hᵀ e_t / F + Aᵀ r_t,   r_{N−1} = 0,        x_t^N = x_t^{t−1} + P̄ r_{t−1}.

    With v = Uᵀ r (Aᵀ = U⁻ᵀ Tᵀ Uᵀ) the recursion runs block by block through Tᵀ, one filter of e per block row;
    reversed in time, σ_0 = 0 and σ_{k+1} = Tᵀ σ_k + Uᵀ Hᵀ e_{N−1−k} / F, so v_t = σ_{N−t} and U⁻ᵀ v_t is r_{t−1}.
    ``e`` (L,) are the span's innovations e_s … e_{s+L−1} in time order and ``sigma0`` (p,) is σ_{N−s−L} (0 for the
    record's last span); returns (σ_{N−s−L} … σ_{N−s−1} (p, L), σ_{N−s}: the next span's ``sigma0``, v_0 after the
    first)."""
    gain = b.u.T @ model.h / g.f
    tt = b.t.T
    zero = np.zeros((tt.shape[0], 1))
    if b.modal:
        sigma = blockfilter.block_states(tt, gain, e[::-1], zero, sigma0[:, None], modal=True)
    else:  # Tᵀ is lower quasi-triangular: run it with the states' order reversed (upper again)
        sigma = blockfilter.block_states(tt[::-1, ::-1], gain[::-1], e[::-1], zero, sigma0[::-1, None],
                                         modal=False)[::-1]
    return sigma, tt @ sigma[:, -1] + gain * e[0]


def _sweep(model: StateSpace, g: SteadyGains, forward: _Forward, d: np.ndarray, *, e: np.ndarray | None,
           w_first: np.ndarray, y: np.ndarray, z: np.ndarray,
           moments: bool) -> tuple[StateSums, DisturbanceSums, np.ndarray]:
    """The smoothed means' sums (:class:`~.common.StateSums`), the adjoint's sums (:func:`_disturbance_sums`) and the
    innovations, in spans of :func:`span_length` samples. Forward: each span's predicted states w from the state it
    starts in (``w_first`` at t = 0), its innovations e = d − H U w when ``e`` is None, the state it ends in. Backward
    from the last span: its w again from its first state (one span: kept), its adjoint σ (:func:`_adjoint_span`),
    then its means and their sums block by block (:func:`_reduce_span`). A record of several spans costs one forward
    pass more; the memory is then a few p × span arrays beside the N-length vectors, whatever N."""
    b = forward.b
    n = d.size
    length = span_length(model.n_states, n)
    spans = [(s, min(s + length, n)) for s in range(0, n, length)]
    given = e is not None
    if not given:
        e = np.empty(n)
    hu = model.h @ b.u
    firsts, kept, w0 = [], None, w_first
    for s, stop in spans:
        w = forward.run(d[s:stop], w0)
        if not given:
            np.subtract(d[s:stop], hu @ w, out=e[s:stop])
        kept = w if len(spans) == 1 else None
        firsts.append(w0)
        w0 = forward.after(w, d[s:stop])
    p = model.n_states
    back = g.p_pred @ b.u_inv.T  # σ's share of the means
    rr, rx = np.zeros((p, p)), np.zeros((p, p))  # in the basis: Σ σ_k σ_kᵀ, Σ σ_{N−1−t} x_tᵀ
    sigma, states = np.zeros(p), None
    for (s, stop), w_start in zip(reversed(spans), reversed(firsts), strict=True):
        w = kept if kept is not None else forward.run(d[s:stop], w_start)
        adjoint, sigma = _adjoint_span(model, g, b, e[s:stop], sigma)  # σ_{N−stop} … σ_{N−s−1}; σ_{N−s}
        rr += adjoint @ adjoint.T  # σ_0 = 0 adds nothing
        part, part_rx = _reduce_span(model, b, w, adjoint, after=sigma, back=back, y=y[s:stop], z=z[s:stop],
                                     d=d[s:stop], moments=moments)
        rx += part_rx
        states = part if states is None else StateSums.joined(part, states)
    return states, _disturbance_sums(model, g, b, rr=rr, rx=rx, n=n), e


#: Samples per block of :func:`_reduce_span` (a few p × block arrays stay in cache).
REDUCE_BLOCK = 1 << 14


def _reduce_span(model: StateSpace, b: Basis, w: np.ndarray, adjoint: np.ndarray, *, after: np.ndarray,
                 back: np.ndarray, y: np.ndarray, z: np.ndarray, d: np.ndarray,
                 moments: bool) -> tuple[StateSums, np.ndarray]:
    """One span's means x_t^N = U w_t + ``back`` σ_{N−t} (``back`` = P̄ U⁻ᵀ) reduced to their sums
    (:class:`~.common.StateSums`) and to Σ σ_{N−1−t} x_tᵀ, block by block of :data:`REDUCE_BLOCK` samples: w (p, L)
    the span's predicted states, ``adjoint`` (p, L) its σ_{N−s−L} … σ_{N−s−1} (:func:`_adjoint_span`), ``after``
    σ_{N−s}; y, z, d the span's. Each block reverses its σ into a contiguous copy (a reversed view is no BLAS
    operand)."""
    length = w.shape[1]
    states, rx = None, np.zeros((w.shape[0], w.shape[0]))
    for first in range(0, length, REDUCE_BLOCK):
        last = min(first + REDUCE_BLOCK, length)  # times s + first … s + last − 1
        lo, hi = length - last, length - first  # their σ_{N−t} and σ_{N−1−t}: adjoint columns lo … hi
        ext = adjoint[:, lo:hi + 1] if hi < length else np.column_stack([adjoint[:, lo:], after])
        ext = np.ascontiguousarray(ext[:, ::-1])  # column i: σ_{N−t} at t = s + first + i
        xs = b.u @ w[:, first:last]
        xs += back @ ext[:, :-1]
        rx += ext[:, 1:] @ xs.T  # σ_{N−1−t} x_tᵀ (t = N − 1 meets σ_0 = 0)
        part = StateSums.of(xs, y=y[first:last], z=z[first:last], d=d[first:last], h=model.h, moments=moments)
        states = part if states is None else StateSums.joined(states, part)
    return states, rx


def _disturbance_sums(model: StateSpace, g: SteadyGains, b: Basis, *, rr: np.ndarray, rx: np.ndarray,
                      n: int) -> DisturbanceSums:
    """:class:`~.common.DisturbanceSums` from the adjoint's sums in the basis ``b`` (``rr`` Σ σ_k σ_kᵀ, ``rx``
    Σ σ_{N−1−t} x_tᵀ of :func:`_sweep`; r_t = U⁻ᵀ σ_{N−1−t} for the disturbances t = 0 … N − 2); N_t by
    N_{t−1} = Hᵀ H / F + Aᵀ N_t A from N_{N−1} = 0 (Durbin & Koopman 2012, eq. 4.42), summed by
    :func:`affine_power_sum`; L P̄ = Φ P_f."""
    if n < 2:
        return DisturbanceSums.none(model.n_states)
    rr = b.u_inv.T @ rr @ b.u_inv
    info = np.outer(model.h, model.h) / g.f
    with np.errstate(over="ignore", invalid="ignore"):  # overflowed sums read as NaN by the score's users
        n_sum, _ = affine_power_sum(g.a.T, info, info, n - 1)
    return DisturbanceSums(0.5 * (rr + rr.T), b.u_inv.T @ rx, n_sum, n_sum @ (model.phi @ g.p_filt))


def _smoothed(model: StateSpace, g: SteadyGains, states: StateSums, disturbances: DisturbanceSums,
              e: np.ndarray) -> SmootherStats:
    """The smoother's statistics from its means' and adjoint's sums and the innovations e (N,): the covariance sums in
    closed form (:func:`affine_power_sum`; P_{t,t−1}^N = P_t^N Jᵀ)."""
    n = e.size
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
        states, sum_p, p_first, g.p_filt.copy(), sum_lag, sum_p.copy(), float(loglik), np.ones(n, bool), disturbances,
    )


def _smooth_column(model: StateSpace, g: SteadyGains, b: Basis | None, d: np.ndarray, *, e: np.ndarray | None,
                   u: np.ndarray, m0: np.ndarray, y: np.ndarray, z: np.ndarray, moments: bool) -> SmootherStats:
    """The statistics of the column d (N,) the smoother runs on in the basis ``b`` (None: no states; input u (p,),
    initial mean m0 (p,); its innovations ``e``, or None to form them), summed against the data y and regressors z
    (N, k), the p × p sums with ``moments``."""
    if b is None:
        states = StateSums.of(np.zeros((0, d.size)), y=y, z=z, d=d, h=model.h, moments=moments)
        return _smoothed(model, g, states, DisturbanceSums.none(0), d.copy() if e is None else e)
    forward = _Forward(b, b.u_inv @ (model.phi @ g.k), (b.u_inv @ u)[:, None])
    states, disturbances, e = _sweep(model, g, forward, d, e=e, w_first=b.u_inv @ m0, y=y, z=z, moments=moments)
    return _smoothed(model, g, states, disturbances, e)


def smooth(model: StateSpace, cols: Columns, y: np.ndarray, z: np.ndarray, *, moments: bool = True) -> SmootherStats:
    """E-step statistics of the data column (column 0) with constant gains, its means summed against the data y (N,)
    and regressors z (N, k) (:class:`~.common.StateSums`; the p × p sums with ``moments``)."""
    g = gains(model)
    b = decoupled_basis(g.a) if model.n_states else None
    return _smooth_column(model, g, b, cols.y[0], e=None, u=cols.g[:, 0], m0=cols.m0[:, 0], y=y, z=z,
                          moments=moments)


def profile_and_smooth(model: StateSpace, cols: Columns, y: np.ndarray, z: np.ndarray, *,
                       moments: bool = True) -> tuple[ProfileResult, SmootherStats]:
    """GLS profile of the free mean parameters and the smoother at their estimate (its means summed against y, z;
    the p × p sums with ``moments``)."""
    g = gains(model)
    inn, b = _innovations(model, g, cols)
    prof = profile(inn, cols.names)
    weights = np.concatenate([[1.0], prof.beta])
    return prof, _smooth_column(model, g, b, weights @ cols.y, e=prof.innovations, u=cols.g @ weights,
                                m0=cols.m0 @ weights, y=y, z=z, moments=moments)
