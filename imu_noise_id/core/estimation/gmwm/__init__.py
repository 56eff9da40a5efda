"""The generalized method of wavelet moments: one fit (:mod:`.fit`, :mod:`.engine`), its selection (:mod:`.select`),
the ramp (:mod:`.ramp`) and the fit pooled over recordings (:mod:`.pool`)."""
