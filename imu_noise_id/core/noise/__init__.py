"""The stochastic error components of an inertial sensor (:mod:`.components` and siblings), their units
(:mod:`.units`) and the model-spec vocabulary (:mod:`.modelspec`)."""
