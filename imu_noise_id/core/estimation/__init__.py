"""Batch estimation of stochastic error models (paper 000 and beyond).

* :mod:`.em` — the constrained EM algorithm (E-step sums, M-step updates, Q function);
* :mod:`.mle` — quasi-Newton finish on the exact likelihood, observed information, likelihood intervals;
* :mod:`.whittle` — banded Whittle likelihood of the differenced signal (fast starting values);
* :mod:`.starts` — starting values from the Allan variance;
* :mod:`.fit` — one structure fitted to one axis, model selection and recording-length advice.
"""
