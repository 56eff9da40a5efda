"""Pure-sinusoid regressor columns: their steady-state filter response in closed form (docs/em.md, "SIN terms"). For
x_{t+1} = A x_t + g·y_t (x_0 = 0, A = Φ(I − K H), g = ΦK), y_t = Re(ζ_0 e^{jωt}), (e^{jω} I − A) v = g:

    H x_t = Re(Hv)·y_t − Im(Hv)·ŷ_t − H A^t Re(v ζ_0),        ŷ_t = (cos ω·y_t − y_{t+1}) / sin ω,

the free response (last term) while ρ(A)^t ≥ :data:`FREE_RESPONSE_FLOOR`; for columns declared in
:attr:`~.statespace.StateSpace.sinusoid_omega` that pass :func:`obeys`. At ω = 0 the recurrence
y_{t+1} + y_{t−1} = 2 cos ω·y_t holds for the affine columns y_t = c₀ + c₁t (a bias, a ramp): declared with ω = 0, their
response is c₀·s_t + c₁·Σ_{u<t} s_u, s the step response of the filter (:func:`affine_coefficients`; the engine's
``_affine_output``)."""

from __future__ import annotations

import math

import numpy as np

#: Relative tolerance of y_{t+1} + y_{t−1} = 2 cos ω·y_t at every sample for a column to be a sinusoid.
RECURRENCE_TOL = 1e-7
#: Frequencies this close to 0 or π (rad per sample) are not treated in closed form: ŷ divides by sin ω.
MIN_SIN = 1e-6
#: A filter pole closer than this to e^{jω} leaves the column to the plain filter (v would be ill-conditioned).
MIN_POLE_DISTANCE = 1e-7
#: The free response is kept until ρ(A)^t falls below this.
FREE_RESPONSE_FLOOR = 1e-22


def affine_coefficients(column: np.ndarray) -> tuple[float, float]:
    """(c₀, c₁) of the line y_t = c₀ + c₁·t [per sample] through the first and last samples of ``column``."""
    return float(column[0]), float(column[-1] - column[0]) / (column.size - 1)


def _is_affine(z: np.ndarray) -> bool:
    """Whether z is c₀ + c₁·t to :data:`RECURRENCE_TOL` of max |z| at every sample (and not all zero)."""
    scale = float(np.max(np.abs(z)))
    c0, c1 = affine_coefficients(z)
    line = np.arange(z.size, dtype=float)
    line *= c1
    line += c0
    return scale > 0.0 and float(np.max(np.abs(z - line))) <= RECURRENCE_TOL * scale


def sinusoid_omega(column: np.ndarray) -> float:
    """ω ∈ (0, π) [rad/sample] if ``column`` is a·cos ωt + b·sin ωt to :data:`RECURRENCE_TOL`; 0 if it is affine,
    c₀ + c₁·t to :data:`RECURRENCE_TOL` at every sample (the recurrence's solutions at ω = 0); else NaN."""
    z = np.asarray(column, dtype=float)
    if z.ndim != 1 or z.size < 8 or not np.all(np.isfinite(z)):
        return math.nan
    if _is_affine(z):
        return 0.0
    mid, second = z[1:-1], z[2:] - 2.0 * z[1:-1] + z[:-2]
    energy = float(mid @ mid)
    if energy == 0.0:
        return math.nan
    one_minus_cos = -float(mid @ second) / (2.0 * energy)
    if not 0.0 < one_minus_cos < 2.0:
        return math.nan
    omega = 2.0 * math.asin(math.sqrt(0.5 * one_minus_cos))
    residual = second + 2.0 * one_minus_cos * mid
    if float(np.max(np.abs(residual))) > RECURRENCE_TOL * float(np.max(np.abs(z))):
        return math.nan
    return omega if math.sin(omega) > MIN_SIN else math.nan


def obeys(column: np.ndarray, omega: float) -> bool:
    """Whether ``column`` obeys ω's recurrence at its second, middle and last-but-one samples (at ω = 0: lies on
    the line through its ends there)."""
    n = column.size
    centres = np.array([1, n // 2, n - 2])
    if n >= 8 and omega == 0.0:
        c0, c1 = affine_coefficients(column)
        scale = max(abs(float(column[0])), abs(float(column[-1])), float(np.max(np.abs(column[centres]))))
        return bool(scale > 0.0 and np.all(np.abs(column[centres] - (c0 + c1 * centres)) <= RECURRENCE_TOL * scale))
    if n < 8 or math.sin(omega) <= MIN_SIN:
        return False
    before, here, after = column[centres - 1], column[centres], column[centres + 1]
    residual = np.abs(after + before - 2.0 * math.cos(omega) * here)
    scale = float(np.max(np.abs(np.concatenate([before, here, after]))))
    return bool(np.all(residual <= RECURRENCE_TOL * scale))


def quadrature(y: np.ndarray, omega: float) -> np.ndarray:
    """ŷ_t = Im ζ_t of a sinusoid y_t = Re ζ_t at ω: (cos ω·y_t − y_{t+1}) / sin ω, y_N from the recurrence."""
    c, s = math.cos(omega), math.sin(omega)
    nxt = np.empty_like(y)
    nxt[:-1] = y[1:]
    nxt[-1] = 2.0 * c * y[-1] - y[-2]
    return (c * y - nxt) / s


def usable(poles: np.ndarray, omega: float) -> bool:
    """No filter pole (eigenvalue of A) within :data:`MIN_POLE_DISTANCE` of e^{jω}."""
    return bool(np.all(np.abs(np.exp(1j * omega) - poles) > MIN_POLE_DISTANCE))


def free_response_length(poles: np.ndarray, n: int) -> int:
    """Samples after which ρ(A)^t < :data:`FREE_RESPONSE_FLOOR` (at most n), ρ(A) the largest |pole|."""
    rho = float(np.max(np.abs(poles))) if poles.size else 0.0
    if rho >= 1.0:
        return n
    if rho <= 0.0:
        return min(n, 1)
    return min(n, math.ceil(math.log(FREE_RESPONSE_FLOOR) / math.log(rho)) + 1)


def steady_parts(a: np.ndarray, g: np.ndarray, h: np.ndarray, y: np.ndarray, omega: np.ndarray, *,
                 rows: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Re(Hv)·y − Im(Hv)·ŷ of the sinusoidal columns ``y[rows]`` into ``out[rows]``; returns Re(v ζ_0) (p,
    len(rows))."""
    p = a.shape[0]
    start = np.zeros((p, rows.size))
    for i, r in enumerate(rows):
        w = float(omega[r])
        v = np.linalg.solve(np.exp(1j * w) * np.eye(p) - a, g.astype(complex))
        hv = complex(h @ v)
        y_hat = quadrature(y[r], w)
        start[:, i] = v.real * y[r, 0] - v.imag * y_hat[0]
        np.multiply(y[r], hv.real, out=out[r])
        y_hat *= hv.imag
        out[r] -= y_hat
    return start


def step_response(modes: list[tuple[complex, complex]], n: int) -> np.ndarray:
    """s_t = Σ Re(κ (1 − μ^t)) for t = 0 … n − 1 over ``modes`` (μ, κ), each μ^t kept while |μ|^t ≥
    :data:`FREE_RESPONSE_FLOOR` (:func:`powers`): the step response of a filter in its modal form."""
    out = np.full(n, sum(kappa.real for _, kappa in modes))
    for mu, kappa in modes:
        length = free_response_length(np.array([mu]), n)
        if mu.imag == 0.0:
            out[:length] -= kappa.real * powers(mu.real, length)
        else:
            power = powers(mu, length)
            out[:length] -= kappa.real * power.real - kappa.imag * power.imag
    return out


def powers(mu: float | complex, length: int) -> np.ndarray:
    """μ^t for t = 0 … length − 1 as the outer product of μ^(w·i) and μ^j, w = ⌈√length⌉: one product per sample (a
    power is a few ulps; a recursion would add one rounding per step)."""
    width = math.isqrt(max(length - 1, 0)) + 1
    fine = np.power(mu, np.arange(width, dtype=float))
    coarse = np.power(mu, width * np.arange(-(-length // width), dtype=float))
    return np.multiply.outer(coarse, fine).ravel()[:length]
