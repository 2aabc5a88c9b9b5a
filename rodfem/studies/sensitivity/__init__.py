"""``rodfem sensitivity`` and ``rodfem.sensitivity``: which parameters a scene's measures depend
on, and how much (Sobol or Morris indices over the parameters' ranges).

:mod:`~.indices` (the samples and the indices, thin over SALib), :mod:`~.run` (the campaign: its
runs a sweep, then the analysis; resumed) and :mod:`~.files` (its directory's files,
:class:`~.files.SensitivityResult`, ``rodfem.load_sensitivity``)."""
