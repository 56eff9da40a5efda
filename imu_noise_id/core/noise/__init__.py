"""The stochastic error components of an inertial sensor, their units and the model-spec vocabulary.

* :mod:`.components` — WN, QN, RW, GM, RR: simulation, state-space block, theoretical AV and PSD;
* :mod:`.units` — continuous-time ↔ per-sample conversions (the one place they live);
* :mod:`.modelspec` — ``WN+GM+RW`` strings with or without values.
"""
