"""``rodfem plot``: the figures of runs or of one sweep, drawn on rank 0, with a note for each
directory that is not complete."""

from __future__ import annotations

import argparse
import sys

from rodfem.commands.common import EXIT_INPUT, EXIT_IO, say

# What ``rodfem plot`` says of a run directory that is not complete: the figures show what is
# there, up to the run's last checkpoint.
INCOMPLETE = {
    "gone": "is incomplete: the process is gone (killed before it finished); the figures show its "
            "steps up to the last checkpoint, and 'rodfem resume {path}' continues it",
    "running": "is still being written by a run; the figures show its last checkpoint",
    "interrupted": "holds an interrupted run ('rodfem resume {path}' continues it)",
    "failed": "holds a run that failed; the figures show the steps before the failure",
}


SWEEP_INCOMPLETE = {
    "gone": "is an incomplete sweep: the process is gone (killed before it finished); the "
            "figures show the scenes it finished, and 'rodfem resume {path}' runs the rest",
    "running": "is a sweep still running; the figures show the scenes finished so far",
    "interrupted": "is an interrupted sweep ('rodfem resume {path}' runs the rest)",
    "failed": "is a sweep stopped by a failed write ('rodfem resume {path}' runs the rest)",
}

# The study directories rodfem plot is not drawn from: their command's figure (its name without
# the format's suffix), the directory in them that rodfem plot draws, and what that holds.
STUDY_FIGURES = {"sensitivity": ("sensitivity", "runs", "its runs"),
                 "fit": ("fit", "fitted", "its fitted run")}


def _plot_options(args: argparse.Namespace):
    """The options of ``rodfem plot`` read (their fit with the runs is checked as they load)."""
    from rodfem.post.options import KINDS, Options, parse_labels, parse_only, parse_window

    return Options(only=parse_only(args.only) if args.only is not None else frozenset(KINDS),
                   animation=args.animation,
                   window=parse_window(args.window) if args.window is not None else None,
                   labels=parse_labels(args.labels) if args.labels is not None else None,
                   colour_by=args.colour_by, format=args.format)


def _drawing(args: argparse.Namespace):
    """Check the options against what the directories are (runs, or one sweep) and return what
    draws the figures: the options' mistakes are found before any note or figure."""
    from rodfem.output import figures
    from rodfem.output.directories import read_marker
    from rodfem.post import PlotError
    from rodfem.post import plot as draw

    if args.out is not None:  # a user's mistake, not a failed write: found before any figure
        blocking = next((p for p in (args.out, *args.out.parents) if p.exists()
                         and not p.is_dir()), None)
        if blocking is not None:
            raise PlotError(f"--out {args.out}: {blocking} is a file, not a directory; give a "
                            "directory for the figures")
    for d in args.dirs:
        command = (read_marker(d) or {}).get("command")
        if command in STUDY_FIGURES:
            stem, inner, what = STUDY_FIGURES[command]
            figure = figures.written(d, stem)
            drawn = f"drawn in {figure}" if figure is not None else \
                f"with no {stem}.{', .'.join(figures.FORMATS)} drawn"
            raise PlotError(f"{d} is a {command} study, {drawn}; 'rodfem plot "
                            f"{d / inner}' draws the figures of {what}")
    sweeps = [d for d in args.dirs if (read_marker(d) or {}).get("command") == "sweep"]
    if sweeps and len(args.dirs) > 1:
        raise PlotError(f"{sweeps[0]} is a sweep: plot it alone (its figures draw every "
                        "scene's measures)")
    if not sweeps:
        for option, value in (("--measures", args.measures), ("--overlay", args.overlay or None)):
            if value is not None:
                raise PlotError(f"{option} applies to a sweep directory; {args.dirs[0]} is a "
                                "run's")
        options = _plot_options(args)
        return lambda: draw(args.dirs, args.out, options, force=args.force)
    return _sweep_drawing(args, sweeps[0])


def _sweep_drawing(args: argparse.Namespace, sweep):
    """What draws a sweep's figures: the measures chosen (``--measures``, or ``--only`` as
    before), the scenes overlaid (``--overlay``, in the ``--window``)."""
    from rodfem.post import PlotError
    from rodfem.post.options import parse_window
    from rodfem.post.sweep import plot_sweep

    window = None if args.window is None else parse_window(args.window)
    for option, value in (("--window", None if args.overlay else args.window),
                          ("--labels", args.labels), ("--colour-by", args.colour_by)):
        if value is not None:
            raise PlotError(f"{option} applies to runs (and --window to a sweep's --overlay); "
                            f"{sweep} is a sweep")
    if args.measures is not None and args.only is not None:
        raise PlotError("--only and --measures both choose a sweep's measures: give one")
    option, text = ("--only", args.only) if args.only is not None else ("--measures",
                                                                       args.measures)
    chosen = None if text is None else [m.strip() for m in text.split(",")]
    if chosen is not None and not all(chosen):
        raise PlotError(f"{option} takes a comma-separated list without empty items, "
                        f"not {text!r}")
    return lambda: plot_sweep(sweep, args.out, force=args.force, measures=chosen,
                              overlay=args.overlay, window=window, option=option,
                              format=args.format,
                              note=lambda line: say(f"rodfem: note: {line}"))


def plot(args: argparse.Namespace) -> int:
    """Draw the figures on rank 0 (the others wait), then list the files written."""
    from mpi4py import MPI

    from rodfem.output.directories import read_marker, state

    comm = MPI.COMM_WORLD
    written, error, code = [], None, 0
    if comm.rank == 0:
        from rodfem.post import PlotError

        try:
            drawing = _drawing(args)
            for path in args.dirs:
                sweep = path.is_dir() and (read_marker(path) or {}).get("command") == "sweep"
                notes = SWEEP_INCOMPLETE if sweep else INCOMPLETE
                note = notes.get(state(path) if path.is_dir() else None)
                if note and not sweep and not (path / "history.h5").exists():
                    raise PlotError(f"{path} holds a run that stopped before its first step "
                                    "(only its scene.toml): nothing to draw")
                if note:
                    say(f"rodfem: note: {path} {note.format(path=path)}")
            written = drawing()
        except PlotError as err:
            error, code = " ".join(str(err).split()), EXIT_INPUT  # one line
        except OSError as err:
            from rodfem.output.atomic import io_line

            error, code = io_line(err), EXIT_IO
    written, error, code = comm.bcast((written, error, code), root=0)
    if error is not None:
        say(f"rodfem: error: {error}")
        return code
    for path in written:
        say(str(path), sys.stdout)
    return 0
