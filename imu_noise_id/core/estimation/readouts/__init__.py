"""The numbers users paste, read off fitted models: Kalibr's N and K (:mod:`.kalibr`), the bias instability
(:mod:`.instability`), the WN+RW overbound (:mod:`.overbound`), the EM–GMWM agreement (:mod:`.agreement`)."""
