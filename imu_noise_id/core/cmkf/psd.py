"""What the covariance matching says about a noise PSD (S_v or S_g) per axis, from the 95 % interval Ŝ ± t·se:
**identified** (above 0; density √Ŝ), **not identifiable** (contains 0; the bound Ŝ + t·se), **negative** (upper
end ≤ 0), **unknown** (fewer than two blocks). Never the filter's working value."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .matching import t_quantile

VERDICTS = ("identified", "not_identifiable", "negative", "unknown")


@dataclass(frozen=True)
class PsdEstimate:
    """PSD per axis ([m²/s³] S_v, [rad²/s] S_g): ``value``, ``se``, ``dof``, ``ci95`` (3, 2), ``upper95``, verdicts."""

    value: np.ndarray
    se: np.ndarray
    dof: int
    ci95: np.ndarray
    upper95: np.ndarray
    verdict: tuple[str, ...]

    @property
    def identified(self) -> np.ndarray:
        """(3,) bool: the axes whose PSD is identified."""
        return np.array([v == "identified" for v in self.verdict])

    def density(self) -> np.ndarray:
        """(3,) noise density √Ŝ where identified, NaN elsewhere [u/√Hz]."""
        return np.where(self.identified, np.sqrt(np.maximum(self.value, 0.0)), np.nan)

    def density_ci95(self) -> np.ndarray:
        """(3, 2) 95 % interval of the density where identified, NaN elsewhere."""
        return np.where(self.identified[:, None], np.sqrt(np.maximum(self.ci95, 0.0)), np.nan)

    def density_upper95(self) -> np.ndarray:
        """(3,) upper end of the density's 95 % interval where the PSD is not identifiable, NaN elsewhere."""
        ok = np.array([v == "not_identifiable" for v in self.verdict])
        return np.where(ok, np.sqrt(np.maximum(self.upper95, 0.0)), np.nan)

    def describe(self, axes: tuple[str, ...], unit: str) -> list[str]:
        """One sentence per axis (density unit ``unit``, e.g. ``m/s^2/sqrt(Hz)``) for summaries and diagnostics."""
        out = []
        n, lo_hi, up = self.density(), self.density_ci95(), self.density_upper95()
        for i, axis in enumerate(axes):
            verdict = self.verdict[i]
            if verdict == "identified":
                out.append(f"{axis}: {n[i]:.3g} {unit} (95 % CI {lo_hi[i, 0]:.3g} … {lo_hi[i, 1]:.3g})")
            elif verdict == "not_identifiable":
                out.append(f"{axis}: not identifiable from this data (the noise is below what the odometry noise "
                           f"contributes): below {up[i]:.3g} {unit} (95 % interval)")
            elif verdict == "negative":
                out.append(f"{axis}: not identifiable: the least squares is negative beyond its uncertainty "
                           f"({self.value[i]:.3g} ± {self.se[i]:.2g}): the odometry noise assumed is too large for "
                           "these data (declared covariance too large, or smoothed odometry)")
            else:
                out.append(f"{axis}: not estimated yet (too few odometry epochs for an uncertainty)")
        return out


def psd_estimate(value: np.ndarray, se: np.ndarray, dof: int) -> PsdEstimate:
    """Per-axis verdicts and intervals from the least-squares values, their standard errors and ``dof``."""
    value = np.asarray(value, dtype=float)
    se = np.asarray(se, dtype=float)
    codes, lo, hi = classify(value, se, np.full(value.shape, int(dof)))
    known = codes != VERDICTS.index("unknown")
    ci = np.where(known[:, None], np.column_stack([np.maximum(lo, 0.0), hi]), np.nan)
    return PsdEstimate(value, se, int(dof), ci, np.where(known, hi, np.nan), tuple(VERDICTS[c] for c in codes))


def classify(value: np.ndarray, se: np.ndarray, dof: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Verdicts (indices into :data:`VERDICTS`) and the interval ends Ŝ ∓ t·se of arrays of estimates (broadcast)."""
    value, se = np.asarray(value, dtype=float), np.asarray(se, dtype=float)
    dof = np.broadcast_to(np.asarray(dof), value.shape)
    t = np.vectorize(t_quantile, otypes=[float])(dof.astype(int)) if dof.size else np.zeros(value.shape)
    with np.errstate(invalid="ignore"):
        lo, hi = value - t * se, value + t * se
        codes = np.where(lo > 0.0, 0, np.where(hi <= 0.0, 2, 1))
    codes = np.where(np.isfinite(value) & np.isfinite(se) & (dof >= 1), codes, 3)
    return codes, lo, hi


def density_series(value: np.ndarray, se: np.ndarray, dof: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """√Ŝ where identified, √ of the upper end where not identifiable, NaN elsewhere (a replay's time series)."""
    codes, _, hi = classify(value, se, dof)
    with np.errstate(invalid="ignore"):
        return (np.where(codes == 0, np.sqrt(np.maximum(value, 0.0)), np.nan),
                np.where(codes == 1, np.sqrt(np.maximum(hi, 0.0)), np.nan))
