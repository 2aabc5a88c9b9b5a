"""``rodfem fit``, and ``rodfem resume`` of a fit directory: the fit run or continued, and the
line that says how it ended."""

from __future__ import annotations

import argparse
import signal
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


def fit(args: argparse.Namespace) -> int:
    """Fit the fit file args.file into args.out; report the fitted values in one line."""
    from mpi4py import MPI

    from rodfem.studies.fit.run import problem_of, run_fit, study_of

    study, data_path = study_of(args.file)  # SceneError: exit 2, nothing written
    problem = problem_of(study, data_path)
    start = problem.sweep([[problem.start[key] for key in study.keys]])
    # each evaluation a run, each Jacobian one per parameter
    said_cost(start.scene, 1, args.yes, args.quiet,
              runs=problem.max_evaluations * (len(study.keys) + 1))
    out = args.out if args.out is not None else Path("results") / Path(args.file).stem
    return _ended(lambda: run_fit(args.file, out, MPI.COMM_WORLD, force=args.force,
                                  progress=args.progress, format=args.format), out, args.quiet)


def _ended(call, out: Path, quiet: bool) -> int:
    """Run ``call`` (a fit, or its resume) and say how it ended; its exit code."""
    from rodfem.output import interrupts
    from rodfem.output.atomic import io_line
    from rodfem.output.directories import OutputError
    from rodfem.studies.common import plural
    from rodfem.studies.fit.files import FitError
    from rodfem.studies.fit.optimiser import WriteError

    again = f"'rodfem resume {out}' continues it"
    try:
        result = call()
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    except FitError as err:
        say(f"rodfem: error: {err}. The points run before are journalled in {out}.")
        return EXIT_DIVERGED
    except WriteError as err:
        say(f"rodfem: error: {err}. The points run before are journalled in {out}; once its "
            f"files can be written again, {again}.")
        return EXIT_IO
    except interrupts.Interrupted as err:
        say(f"rodfem: interrupted by {signal.Signals(err.signum).name}; the points run so far "
            f"are journalled in {out}, and {again}.")
        return err.exit_code
    except OSError as err:  # fit.json, fit.png or the fitted run's files
        say(f"rodfem: error: {io_line(err)}; once it can be written, {again}.")
        return EXIT_IO
    numbers = result.numbers
    if numbers["warning"]:
        say(f"rodfem: warning: {numbers['warning']}")
    if numbers.get("coarse_warning"):  # a fit.json of an earlier rodfem has none
        say(f"rodfem: warning: {numbers['coarse_warning']}")
    if numbers["status"] != "converged":
        say(f"rodfem: warning: the fit stopped before converging ({numbers['message']}); "
            "allow more with max_evaluations")
    if not quiet:
        shown = ", ".join(f"{key} = {value:.6g}" + (f" ± {err:.2g}" if err is not None else "")
                          for key, (value, err) in result.parameters.items())
        say(f"{shown}; |r| = {numbers['residual_norm']:.4g} after "
            f"{plural(numbers['runs'], 'run')} ({plural(numbers['iterations'], 'iteration')})"
            f" -> {out / 'fit.json'}", sys.stdout)
    return 0


def resume_fit(args: argparse.Namespace, out: Path, marker: dict) -> int:
    """``rodfem resume`` of the fit directory ``out`` (held by this command, its ``marker``
    read): the fit replayed, its journalled points taken, the others run."""
    from mpi4py import MPI

    from rodfem.studies.fit.files import numbers_of, read_meta
    from rodfem.studies.fit.run import resume

    def complete() -> None:
        read_meta(out)
        numbers_of(out)

    return resume_as_written(args, out, marker, "fit", complete, lambda: _ended(
        lambda: resume(out, MPI.COMM_WORLD, progress=args.progress, format=args.format), out,
        args.quiet))
