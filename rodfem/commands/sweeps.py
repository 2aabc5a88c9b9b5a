"""``rodfem sweep``, and ``rodfem resume`` of a sweep directory: the sweep run or continued,
and the one line that says how it ended."""

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


def sweep(args: argparse.Namespace) -> int:
    """Run the sweep file args.file into args.out; report its table in one line."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError
    from rodfem.studies.sweep import design
    from rodfem.studies.sweep.run import run_sweep

    spec = design.load(args.file)  # SceneError: exit 2, nothing written
    said_cost(spec.scene, len(spec), args.yes, args.quiet)
    out = args.out if args.out is not None else Path("results") / Path(args.file).stem
    try:
        result = run_sweep(spec, out, MPI.COMM_WORLD, histories=args.histories, force=args.force,
                           progress=args.progress or sys.stderr.isatty(),
                           text=Path(args.file).read_text(encoding="utf-8"), keep=args.file)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    return _sweep_report(result, out, args.quiet)


def _sweep_report(result, out: Path, quiet: bool) -> int:
    """The line that says how a sweep ended, and its exit code."""
    import json

    from mpi4py import MPI

    summary = {}
    if MPI.COMM_WORLD.rank == 0:
        try:
            summary = json.loads((out / "summary.json").read_text())
        except (OSError, ValueError):
            pass
    summary = MPI.COMM_WORLD.bcast(summary, root=0)
    failed, total = summary.get("scenes_failed", 0), summary.get("scenes", len(result))
    for line in result.coarse_steps:  # once for each kind, not for each scene
        say(f"rodfem: warning: {line}")
    if result.accuracy_missed:
        say(f"rodfem: warning: {result.accuracy_missed}")
    if result.error is not None:
        say(f"rodfem: error: {result.error}. The scenes finished before are kept in {out}; once "
            f"its files can be written again, 'rodfem resume {out}' runs the rest.")
        return EXIT_IO
    if result.status != "complete":
        import signal

        from rodfem.output import interrupts

        done = summary.get("scenes_complete", 0) + failed
        if interrupts.signal_received() is None:
            say(f"rodfem: error: {done} of {total} scenes are in {out / 'results.csv'}, but the "
                "sweep is not complete")
            return EXIT_DIVERGED
        code = interrupts.exit_code()
        say(f"rodfem: interrupted by {signal.Signals(code - 128).name}; {done} of {total} scenes "
            f"are in {out / 'results.csv'}, and 'rodfem resume {out}' runs the rest.")
        return code
    if not quiet:
        rate = summary.get("scenes_per_second") or 0.0
        ranks = summary.get("mpi_ranks", 1)
        note = f", {failed} failed (their rows say why)" if failed else ""
        say(f"{total} scenes{note}; {summary.get('ran_this_time', total)} run in "
            f"{summary.get('seconds', 0.0):.2f} s ({rate:.1f} scenes/s on {ranks} "
            f"rank{'s' if ranks > 1 else ''}) -> {out / 'results.csv'}", sys.stdout)
    return 0


def resume_sweep(args: argparse.Namespace, out: Path, marker: dict) -> int:
    """``rodfem resume`` of the sweep directory ``out`` (held by this command, its ``marker``
    read): the scenes its journal does not hold are run."""
    from mpi4py import MPI

    from rodfem.studies.sweep.run import check_complete
    from rodfem.studies.sweep.run import resume as continue_sweep

    return resume_as_written(args, out, marker, "sweep", lambda: check_complete(out), lambda: (
        _sweep_report(continue_sweep(out, MPI.COMM_WORLD,
                                     progress=args.progress or sys.stderr.isatty()),
                      out, args.quiet)))
