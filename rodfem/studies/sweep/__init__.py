"""``rodfem sweep`` and ``rodfem.sweep``: many scenes of one sweep file run across the MPI ranks,
their measures in one table; the engine fits and sensitivity studies run on.

:mod:`~.design` (sweep files: which scenes, read and checked), :mod:`~.run` (running them,
resuming, ``rodfem.load_sweep``), :mod:`~.dealing` (scenes dealt to the ranks), :mod:`~.files`
(a sweep directory's files written and read, :class:`~.files.SweepResult`) and
:mod:`~.parameters` (study files: a base scene, shared values, parameters and their ranges)."""
