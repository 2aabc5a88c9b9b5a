"""Runs that choose their own mesh and steps to hold their declared measures to a relative error
(``[accuracy]``): :mod:`.estimates` (the error of a measure from runs refined in one direction),
:mod:`.ladder` (the runs, and what is refined next)."""
