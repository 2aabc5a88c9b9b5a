"""``rodfem sensitivity``, and ``rodfem resume`` of a sensitivity directory: the campaign run or
continued, and the lines that say how it ended."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.commands.common import (
    EXIT_DIVERGED,
    EXIT_INPUT,
    EXIT_IO,
    resume_as_written,
    said_cost,
    say,
)


def sensitivity(args: argparse.Namespace) -> int:
    """Run the sensitivity file args.file into args.out; report its indices in one line."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError
    from rodfem.studies.sensitivity.run import prepare, run_campaign

    found = prepare(args.file)  # SceneError: exit 2, nothing written
    said_cost(found.sweep.scene, len(found.sweep), args.yes, args.quiet)
    out = args.out if args.out is not None else Path("results") / Path(args.file).stem
    try:
        result = run_campaign(found, out, MPI.COMM_WORLD, force=args.force, format=args.format,
                              progress=args.progress or sys.stderr.isatty())
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    return _report(result, out, args.quiet)


def _report(result, out: Path, quiet: bool) -> int:
    """The lines that say how a campaign ended, and its exit code."""
    from rodfem.studies.sensitivity.files import CSV
    from rodfem.studies.sensitivity.run import summary_line

    for line in result.warnings if not result.failed else ():  # the error line says it
        say(f"rodfem: warning: {line}")
    again = f"'rodfem resume {out}' runs the rest and analyses them"
    if result.error is not None:
        say(f"rodfem: error: {result.error}. The runs finished before are kept in {out}; once "
            f"its files can be written again, {again}.")
        return EXIT_IO
    if result.status != "complete":
        import signal

        from rodfem.output import interrupts

        if interrupts.signal_received() is None:
            say(f"rodfem: error: the runs in {out / 'runs'} are not complete; {again}")
            return EXIT_DIVERGED
        code = interrupts.exit_code()
        say(f"rodfem: interrupted by {signal.Signals(code - 128).name}; the runs so far are in "
            f"{out / 'runs'}, and {again}.")
        return code
    if result.failed:
        say(f"rodfem: error: {result.failed} of the {result.numbers['runs']} runs failed "
            f"(their rows in {out / 'runs' / 'results.csv'} say why); no indices in {out / CSV}")
        return EXIT_DIVERGED
    if not quiet:
        say(f"{summary_line(result)} -> {out / CSV}", sys.stdout)
    return 0


def resume_sensitivity(args: argparse.Namespace, out: Path, marker: dict) -> int:
    """``rodfem resume`` of the sensitivity directory ``out`` (held by this command, its
    ``marker`` read): the runs its sweep does not hold, then the analysis."""
    from mpi4py import MPI

    from rodfem.studies.sensitivity.run import resume

    return resume_as_written(args, out, marker, "sensitivity study", lambda: None, lambda: _report(
        resume(out, MPI.COMM_WORLD, progress=args.progress or sys.stderr.isatty(),
               format=args.format), out, args.quiet))
