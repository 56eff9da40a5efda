"""Residual diagnostics of fitted noise models: statistics (:mod:`.residuals`), whitening and score tests
(:mod:`.whitening`), detectors of missing effects (:mod:`.detectors`, :mod:`.av_signatures`, :mod:`.lines`), NIS
bounds (:mod:`.consistency`) and the streaming monitor (:mod:`.monitor`)."""
