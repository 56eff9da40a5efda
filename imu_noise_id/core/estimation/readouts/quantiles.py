"""The normal and χ² quantiles of the 95 % intervals and bounds, written once (scipy's ``norm.ppf(0.975)``,
``chi2.ppf(0.95, 1)`` and ``norm.ppf(0.95)`` to the last digit; no scipy call at import)."""

#: Two-sided 95 % normal quantile: Wald intervals are estimate ± Z95·se, profile intervals end where the signed root
#: of the likelihood ratio reaches ±Z95.
Z95 = 1.959963984540054

#: χ²₁ 95 % quantile (Z95²): a profile interval ends where twice the log-likelihood, or the objective, moves by this.
CHI2_95 = 3.841458820694124

#: One-sided 95 % normal quantile (scipy's ``norm.ppf(0.95)``): an upper bound K ≤ U whose interval [0, U] is a 95 %
#: interval ends at estimate·exp(Z95_ONE_SIDED·sd) on the log scale, not at the two-sided 97.5 % point.
Z95_ONE_SIDED = 1.6448536269514722
