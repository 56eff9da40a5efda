"""Posterior mean and variance of a parameter the grid cannot resolve (beyond paper 002 eqs. 13–14; method and
reasons: docs/hypotheses.md, "Sub-cell posteriors"): a Laplace reading of the log weights' local cubic per grid
line, mixed by line masses; jointly collapsed parameters via −H⁻¹; an edge maximum: point mass + δ²/12."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GridAxes:
    """The product grid of one hypothesis (:meth:`~.model.Hypothesis.grid` order, last parameter fastest): ``shape``
    (cells each), ``u0``, ``step`` (grid coordinate u of the first cell, δ; u = log θ on log grids), ``log``."""

    shape: tuple[int, ...]
    u0: np.ndarray
    step: np.ndarray
    log: np.ndarray

    @classmethod
    def of(cls, theta: np.ndarray) -> GridAxes | None:
        """The axes of a product grid θ (M, p), or None when θ is not an evenly spaced (linear or log) product."""
        columns = [np.unique(theta[:, d]) for d in range(theta.shape[1])]
        shape = tuple(c.size for c in columns)
        if int(np.prod(shape)) != theta.shape[0]:
            return None
        u0, step, log = np.zeros(len(shape)), np.zeros(len(shape)), np.zeros(len(shape), bool)
        for d, v in enumerate(columns):
            if v.size < 2:
                u0[d] = v[0]
                continue
            if v[0] > 0 and np.allclose(np.diff(np.log(v)), np.log(v[1] / v[0]), rtol=1e-6, atol=0.0):
                log[d], u0[d], step[d] = True, np.log(v[0]), np.log(v[1] / v[0])
            elif np.allclose(np.diff(v), v[1] - v[0], rtol=1e-6, atol=0.0):
                u0[d], step[d] = v[0], v[1] - v[0]
            else:
                return None
        expected = np.stack(np.meshgrid(*columns, indexing="ij"), axis=-1).reshape(-1, len(shape))
        if not np.allclose(expected, theta, rtol=1e-12, atol=0.0):
            return None
        return cls(shape, u0, step, log)


def _plane_laplace(L: np.ndarray, dims: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sub-grid along ``dims`` of log weights L: argmax (…, c), covariance (…, c, c) in cells, log mass (…)."""
    c = len(dims)
    moved = np.moveaxis(L, dims, tuple(range(L.ndim - c, L.ndim)))
    shape = moved.shape[-c:]
    flat = moved.reshape(*moved.shape[:-c], -1)
    top = flat.max(axis=-1)
    e = np.exp(flat - top[..., None])
    mass = e.sum(axis=-1)
    idx = np.stack(np.unravel_index(np.argmax(flat, axis=-1), shape), axis=-1)  # (…, c)
    n = np.array(shape)
    strides = np.array([int(np.prod(shape[d + 1:])) for d in range(c)])

    # Every cell the differences read, as offsets from the largest cell (clipped to the grid), gathered at once:
    # the centre, ±1 and ±2 along each axis, then (+,+), (+,−), (−,+), (−,−) for each pair of axes.
    unit = np.eye(c, dtype=int)
    offsets = [np.zeros(c, int)] + [o * unit[d] for d in range(c) for o in (-2, -1, 1, 2)]
    pairs = [(d, d2) for d in range(c) for d2 in range(d)]
    offsets += [s1 * unit[d] + s2 * unit[d2] for d, d2 in pairs for s1, s2 in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    cells = np.clip(idx[..., None, :] + np.array(offsets), 0, n - 1) @ strides  # (…, K)
    values = np.take_along_axis(flat, cells, axis=-1)
    v0 = values[..., 0]
    g, H = np.zeros((*v0.shape, c)), np.zeros((*v0.shape, c, c))
    t = np.zeros((*v0.shape, c))
    five = (idx >= 2) & (idx <= n - 3)
    inner = np.all((idx >= 1) & (idx <= n - 2), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for d in range(c):
            vm2, vm1, vp1, vp2 = (values[..., 1 + 4 * d + i] for i in range(4))
            f5 = five[..., d]
            g[..., d] = np.where(f5, (vm2 - 8.0 * vm1 + 8.0 * vp1 - vp2) / 12.0, 0.5 * (vp1 - vm1))
            H[..., d, d] = np.where(f5, (-vm2 + 16.0 * vm1 - 30.0 * v0 + 16.0 * vp1 - vp2) / 12.0, vp1 - 2.0 * v0 + vm1)
            t[..., d] = np.where(f5, 0.5 * (vp2 - 2.0 * vp1 + 2.0 * vm1 - vm2), 0.0)
        for i, (d, d2) in enumerate(pairs):
            pp, pm, mp, mm = (values[..., 1 + 4 * c + 4 * i + j] for j in range(4))
            H[..., d, d2] = H[..., d2, d] = 0.25 * (pp - pm - mp + mm)
        if c == 1:  # Newton on the cubic's derivative g + h x + t x²/2 = 0
            h, tt, gg = H[..., 0, 0], t[..., 0], g[..., 0]
            x = np.clip(-gg / h, -1.0, 1.0)
            for _ in range(3):
                x = np.clip(x - (gg + h * x + 0.5 * tt * x * x) / (h + tt * x), -1.0, 1.0)
            curv = h + tt * x
            ok = inner & np.isfinite(curv) & (curv < 0) & np.isfinite(x)
            pos = (idx[..., 0] + x)[..., None]
            cov = (-1.0 / np.where(ok, curv, -1.0))[..., None, None]
        else:
            negdef = np.all(np.linalg.eigvalsh(np.where(np.isfinite(H), H, 0.0)) < 0, axis=-1)
            ok = inner & negdef & np.all(np.isfinite(H), axis=(-1, -2)) & np.all(np.isfinite(g), axis=-1)
            Hs = np.where(ok[..., None, None], H, -np.eye(c))
            cov = -np.linalg.inv(Hs)
            x = np.clip(np.einsum("...ij,...j->...i", cov, np.where(ok[..., None], g, 0.0)), -1.0, 1.0)
            pos = idx + x
        # Sub-grids without a usable maximum: their point-mass summary and the variance of a uniform cell.
        grids = np.stack(np.unravel_index(np.arange(flat.shape[-1]), shape), axis=-1)  # (M_c, c)
        w = e / mass[..., None]
        m_pm = w @ grids
        dev = grids - m_pm[..., None, :]
        v_pm = np.einsum("...m,...mi,...mj->...ij", w, dev, dev) + np.eye(c) / 12.0
        pos = np.where(ok[..., None], pos, m_pm)
        cov = np.where(ok[..., None, None], cov, v_pm)
    return pos, cov, top + np.log(mass)


def refine(lj: np.ndarray, axes: GridAxes, mean: np.ndarray, var: np.ndarray) -> None:
    """Replace in place ``mean``, ``var`` (…, p) of parameters resolved below one cell; ``lj`` (…, M) log μ₀ + c."""
    lead = lj.shape[:-1]
    k = len(lead)
    L = lj.reshape(*lead, *axes.shape)
    w = np.exp(lj - lj.max(axis=-1, keepdims=True))
    w /= w.sum(axis=-1, keepdims=True)
    candidates = [d for d, n in enumerate(axes.shape) if n >= 3]
    collapsed = np.zeros((*lead, len(axes.shape)), bool)
    for d in candidates:
        n = axes.shape[d]
        j = np.broadcast_to(np.arange(n).reshape((1,) * d + (n,) + (1,) * (len(axes.shape) - d - 1)),
                            axes.shape).ravel()
        m_j = (w * j).sum(axis=-1)
        collapsed[..., d] = (w * (j - m_j[..., None]) ** 2).sum(axis=-1) < 1.0  # less than one cell
    # Rows differ in which parameters collapsed: one pass per combination present.
    for combo in {tuple(np.flatnonzero(row)) for row in collapsed.reshape(-1, collapsed.shape[-1])}:
        if not combo:
            continue
        rows = np.all(collapsed[..., list(combo)], axis=-1) & (collapsed.sum(axis=-1) == len(combo))
        pos, cov, log_mass = _plane_laplace(L, tuple(k + d for d in combo))
        others = tuple(range(k, log_mass.ndim))
        wl = np.exp(log_mass - log_mass.max(axis=others, keepdims=True))
        wl /= wl.sum(axis=others, keepdims=True)
        for i, d in enumerate(combo):
            # A sub-grid with (nearly) no curvature is no more spread than the whole grid.
            u = axes.u0[d] + axes.step[d] * np.clip(pos[..., i], 0.0, axes.shape[d] - 1.0)
            var_u = axes.step[d] ** 2 * np.clip(cov[..., i, i], 0.0, float(axes.shape[d]) ** 2)
            if axes.log[d]:
                m1 = (wl * np.exp(u + 0.5 * var_u)).sum(axis=others)
                m2 = (wl * np.exp(2.0 * u + 2.0 * var_u)).sum(axis=others)
            else:
                m1 = (wl * u).sum(axis=others)
                m2 = (wl * (var_u + u * u)).sum(axis=others)
            mean[..., d] = np.where(rows, m1, mean[..., d])
            var[..., d] = np.where(rows, np.maximum(m2 - m1 * m1, 0.0), var[..., d])
