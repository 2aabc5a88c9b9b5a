"""``rodfem fit`` and ``rodfem.fit``: a scene's parameters fitted to a measured history, with
their standard errors and correlations.

:mod:`~.data` (the data file and the fit's own keys), :mod:`~.optimiser` (least squares, its
batches of runs, the journal's replay, the statistics), :mod:`~.run` (a fit from its file to its
directory, and resumed) and :mod:`~.files` (a fit directory's files, :class:`~.files.FitResult`,
``rodfem.load_fit``)."""
