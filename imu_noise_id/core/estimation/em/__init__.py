"""The constrained EM (:mod:`.em`), its exact-likelihood finish (:mod:`.mle`), intervals (:mod:`.uncertainty`,
:mod:`.profile`), fixed-size likelihoods (:mod:`.composite`), starts, fit and model selection."""
