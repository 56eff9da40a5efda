"""Residual diagnostics of fitted noise models: statistics, detectors of missing effects, streaming monitor.

* :mod:`.residuals` — Ljung–Box, periodogram line over local floor, Allan-variance misfit (the loop's errors);
* :mod:`.whitening` — the fitted model's steady-state innovation filter and score tests of regressors;
* :mod:`.detectors` — one detector per missing effect (GM, RW, RR, QN, SIN, TEMP, STEP, OUTLIERS);
* :mod:`.consistency` — χ² acceptance bounds of the NIS (every filter-consistency check uses them);
* :mod:`.monitor` — windowed Ljung–Box / NIS on an online filter's innovations (for the node).
"""
