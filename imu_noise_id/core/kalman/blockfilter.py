"""The recursion x_{t+1} = T x_t + gain·y_t + const of a quasi-triangular transition T (the steady engine's modal or
real Schur basis, :mod:`.basis`) run as IIR filters (``scipy.signal.lfilter``), one 1 × 1 or 2 × 2 block at a time:
a block's state is a row of adj(zI − B) over its characteristic polynomial, so each output row is one filter of the
input (docs/em.md, "Why the Kalman engines are built as they are")."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from scipy.signal import lfilter

from .basis import blocks


def strictly_proper(num: tuple[float, ...], den: list[float], d: np.ndarray, w0: np.ndarray) -> np.ndarray:
    """Strictly proper filter num/den (num[0] = 0) along the last axis of d, w0 as the initial delay state."""
    return lfilter(num, den, d, axis=-1, zi=np.multiply.outer(w0, num[1:]))[0]


def accumulate(terms: Iterable[np.ndarray]) -> np.ndarray:
    """The sum of ``terms``, added into the first (no new array per term)."""
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
        out[...] = strictly_proper((0.0, 1.0), den, d, w0)
        return
    adj = (((0.0, 1.0, -B[1, 1]), (0.0, 0.0, B[0, 1])), ((0.0, 0.0, B[1, 0]), (0.0, 1.0, -B[0, 0])))
    for r in range(2):
        out[r] = accumulate(strictly_proper(adj[r][c], den, d[c], w0[c])
                             for c in range(2) if adj[r][c][2] != 0 or c == r)


def _adjugate_numerators(B: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(r, s, 3): per row of ``c`` (r, s) and state k of a 1×1 or 2×2 block B, the strictly proper numerator of
    c·adj(zI − B)·e_k in powers of z⁻¹ (denominator :func:`_characteristic`; a 1×1 block's third tap 0)."""
    if B.shape[0] == 1:
        return np.stack([np.zeros_like(c[:, 0]), c[:, 0], np.zeros_like(c[:, 0])], axis=-1)[:, None, :]
    return np.stack([
        np.stack([np.zeros(c.shape[0]), c[:, 0], c[:, 1] * B[1, 0] - c[:, 0] * B[1, 1]], axis=-1),
        np.stack([np.zeros(c.shape[0]), c[:, 1], c[:, 0] * B[0, 1] - c[:, 1] * B[0, 0]], axis=-1)], axis=1)


def driven_block(B: np.ndarray, c: np.ndarray, gain: np.ndarray, y: np.ndarray, *, const: np.ndarray,
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


def run_modes(T: np.ndarray, gain: np.ndarray, y: np.ndarray, const: np.ndarray, w0: np.ndarray) -> np.ndarray:
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


def block_states(T: np.ndarray, gain: np.ndarray, y: np.ndarray, const: np.ndarray, w0: np.ndarray, *,
                  modal: bool) -> np.ndarray:
    """w (p, N) of w_0 = w0, w_{t+1} = T w_t + gain·y_t + const for one input y (N,), const and w0 (p, 1): block by
    block with each state one row of adj(zI − B) where T is block-diagonal (``modal``), else :func:`run_modes`."""
    if not modal:
        return run_modes(T, gain, y[None, :], const, w0)[:, 0, :]
    w = np.empty((T.shape[0], y.size))
    for blk in blocks(T):
        size = blk.stop - blk.start
        rows = driven_block(T[blk, blk], np.eye(size), gain[blk], y[None, :], const=const[blk], w0=w0[blk])
        for r, row in enumerate(rows):
            w[blk.start + r] = row[0]
    return w
