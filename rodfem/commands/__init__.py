"""What each ``rodfem`` subcommand does with its parsed arguments (:mod:`rodfem.cli` parses
them): load and check the input, run, and report in one line per outcome, with the exit codes of
:mod:`rodfem.commands.common`. By family: :mod:`~rodfem.commands.runs` (run, resume),
:mod:`~rodfem.commands.sweeps` (sweep), :mod:`~rodfem.commands.figures` (plot) and
:mod:`~rodfem.commands.studies` (paper, stability, verify, work-precision, steady);
:mod:`~rodfem.commands.prepare` (prepare); :mod:`~rodfem.commands.periodic` (periodic). Each
subcommand's arguments are :mod:`~rodfem.commands.parsers`' (the options several share,
:mod:`~rodfem.commands.arguments`').
"""

from rodfem.commands.common import EXIT_DIVERGED, EXIT_INPUT, EXIT_IO, say
from rodfem.commands.figures import plot
from rodfem.commands.fit import fit
from rodfem.commands.periodic import periodic
from rodfem.commands.prepare import prepare
from rodfem.commands.runs import resume, run
from rodfem.commands.sensitivity import sensitivity
from rodfem.commands.studies import paper, stability, steady, verify
from rodfem.commands.sweeps import sweep

__all__ = ["EXIT_DIVERGED", "EXIT_INPUT", "EXIT_IO", "fit", "paper", "periodic", "plot", "prepare",
           "resume", "run", "say", "sensitivity", "stability", "steady", "sweep", "verify"]
