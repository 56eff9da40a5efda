"""Batch estimation of stochastic error models: the EM with its intervals and selection (:mod:`.em`), the GMWM
(:mod:`.gmwm`) and the numbers read off a fitted model (:mod:`.readouts`)."""
