"""The constrained EM (:mod:`.em`), the exact-likelihood finish and intervals (:mod:`.mle`, :mod:`.uncertainty`,
:mod:`.profile`), the fixed-size likelihoods of long records (:mod:`.whittle`, :mod:`.block_sums`, :mod:`.composite`),
starts (:mod:`.starts`), one structure's fit (:mod:`.model`) and model selection (:mod:`.selection`)."""
