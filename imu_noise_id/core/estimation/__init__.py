"""Batch estimation of stochastic error models: the constrained EM with its exact-likelihood finish, intervals and
model selection (:mod:`.em`), the GMWM (:mod:`.gmwm`) and the numbers users read off a fitted model
(:mod:`.readouts`)."""
