"""Batch estimation of stochastic error models (paper 000 and beyond): the constrained EM (:mod:`.em`), the
exact-likelihood finish and intervals (:mod:`.mle`, :mod:`.uncertainty`, :mod:`.profile`), Whittle and Allan starts
(:mod:`.whittle`, :mod:`.starts`), one structure's fit (:mod:`.model`), model selection (:mod:`.selection`), the GMWM
(:mod:`.gmwm`) and the numbers users paste (:mod:`.kalibr`, :mod:`.instability`, :mod:`.overbound`)."""
