"""What each ``rodfem`` subcommand does with its parsed arguments (:mod:`rodfem.cli` parses
them): load and check the input, run, and report in one line per outcome, with the exit codes
below.

Exit codes: 0 complete; 2 bad input (nothing written); 3 a step could not be taken: the method
did not converge, or the values overflowed (the steps before it kept); 4 a file could not be
written, e.g. a full disk (the files stay whole, up to the last checkpoint); 128 + the signal's
number when stopped by a signal: 130 Ctrl-C (SIGINT), 143 SIGTERM, 129 SIGHUP, 138 SIGUSR1.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.scene import BUILTIN, SceneError, load

EXIT_INPUT, EXIT_DIVERGED, EXIT_IO = 2, 3, 4


def say(message: str, stream=None) -> None:
    """Print one line, once (on rank 0), to stderr unless a stream is given."""
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(message, file=stream or sys.stderr, flush=True)


def _advice(scene, error) -> str:
    """The error, and for Picard's iteration not converging the paper's condition and the
    methods that need none (an overflow is not the iteration's doing)."""
    from rodfem.solver.errors import PicardNotConverged

    if not isinstance(error, PicardNotConverged):
        return f"{error}."
    from mpi4py import MPI

    from rodfem.solver.methods.direct import compliance

    dt, eps, zeta, a = (scene[k] for k in ("time.dt", "obstacle.epsilon", "model.zeta", "model.a"))
    ratio = f"{dt / (eps * zeta):.3g}" if eps * zeta > 0 else "inf (ζ = 0)"
    w, law = compliance(scene, MPI.COMM_WORLD, with_law=True)
    rate = law.contraction(w, error.u_1)
    return (
        f"{error} (tol {scene['solver.tol']:g}). In contact the iteration contracts by about "
        f"{law.contraction_formula} = {rate:.3g} (needs < 1; w = {w:.3g}, the rod's compliance "
        f"at x = 1 over a step); the paper's sufficient condition is Δt < εζ and a < 1, here "
        f'Δt/(εζ) = {ratio} and a = {a:g}. solver.method = "direct" solves every step exactly.'
    )


PER_STEP = {"picard": "Picard iterations/step", "newton": "Newton iterations/step",
            "direct": "solves/step"}


def run(args: argparse.Namespace) -> int:
    scene = load(args.scene, args.overrides)  # validates everything before anything is written
    out = args.out if args.out is not None else Path("results") / Path(args.scene).stem

    from mpi4py import MPI

    from rodfem.output import interrupts
    from rodfem.output.directories import OutputError, prepare_directory
    from rodfem.output.files import write_text
    from rodfem.output.sizes import SizeError, check_room

    try:
        check_room(scene, out, MPI.COMM_WORLD, allow=args.large)
        scene_file = Path(args.scene) if args.scene not in BUILTIN else None
        # A directory marked is one with its scene.toml, which resume reads: a signal between
        # the two is taken after both.
        with interrupts.deferred():
            prepare_directory(out, args.force, MPI.COMM_WORLD, keep=scene_file)
            write_text(out / "scene.toml", scene.to_toml(), MPI.COMM_WORLD)
    except (OutputError, SizeError) as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    from rodfem.run import simulate

    result = simulate(scene, out, MPI.COMM_WORLD, progress=not args.quiet,
                      force_progress=args.progress)
    return _report(scene, result, out, args.quiet)


def _report(scene, result, out: Path, quiet: bool) -> int:
    """The one line that says how a run ended, and its exit code."""
    s = result.summary
    again = f"'rodfem resume {out}' continues it"
    if result.io_error is not None:
        say(f"rodfem: error: {result.io_error}. The run's files are whole up to its last "
            f"checkpoint in {out}; once they can be written again, {again}.")
        return EXIT_IO
    if result.status == "failed":
        say(f"rodfem: {_advice(scene, result.error)} "
            f"Steps 0..{s['steps']} are in {out} (status: failed).")
        return EXIT_DIVERGED
    if result.status == "interrupted":
        import signal

        name = signal.Signals(result.signal).name if result.signal else "a signal"
        say(f"rodfem: interrupted by {name}; steps 0..{s['steps']} are in {out}, and {again}.")
        return 128 + (result.signal or signal.SIGINT)
    if not quiet:
        say(
            f"{scene.source}: {s['steps']} steps in {s['loop_seconds']:.2f} s "
            f"({s['us_per_step']:.1f} µs/step, {s['method']}: {s['iterations_mean']:.2f} "
            f"{PER_STEP[s['method']]})"
            f" -> {out}",
            sys.stdout,
        )
    return 0


def sweep(args: argparse.Namespace) -> int:
    """Run the sweep file args.file into args.out; report its table in one line."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError
    from rodfem.studies import design
    from rodfem.studies.sweep import run_sweep

    spec = design.load(args.file)  # SceneError: exit 2, nothing written
    out = args.out if args.out is not None else Path("results") / Path(args.file).stem
    try:
        result = run_sweep(spec, out, MPI.COMM_WORLD, histories=args.histories, force=args.force,
                           progress=args.progress or sys.stderr.isatty(),
                           text=Path(args.file).read_text(encoding="utf-8"))
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


def resume(args: argparse.Namespace) -> int:
    """Continue the run in args.dir from its checkpoint (or extend a finished one), or the
    sweep in args.dir."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError, mark_running, release, reopen
    from rodfem.output.resume import ResumeError, plan

    comm, out = MPI.COMM_WORLD, args.dir
    try:
        marker = reopen(out, comm)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if marker.get("command") == "sweep":
        return _resume_sweep(args, out, marker)
    try:
        scene, checkpoint = plan(out, args.overrides, marker, comm, large=args.large)
        mark_running(out, comm)
    except ResumeError as err:  # a complete run (exit 0), bad input (2), a full disk (4)
        release(out, comm)  # untouched
        say(err.line(), sys.stdout if err.code == 0 else None)
        return err.code
    except OutputError as err:
        release(out, comm)  # untouched
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    from rodfem.run import simulate

    if checkpoint is None and not args.quiet:
        say(f"rodfem: {out} has no checkpoint yet; running it again from step 0")
    result = simulate(scene, out, comm, progress=not args.quiet, force_progress=args.progress,
                      resume=checkpoint)
    return _report(scene, result, out, args.quiet)


def _resume_sweep(args: argparse.Namespace, out: Path, marker: dict) -> int:
    from mpi4py import MPI

    from rodfem.output.directories import release
    from rodfem.studies.sweep import resume as resume_sweep

    comm = MPI.COMM_WORLD
    if args.overrides:
        release(out, comm)
        say(f"rodfem: error: --set: a sweep resumes as it was written; {out} is a sweep "
            "(change its sweep file and run it again instead)")
        return EXIT_INPUT
    if marker.get("status") == "complete":
        release(out, comm)
        say(f"rodfem: {out} is a complete sweep; nothing to resume", sys.stdout)
        return 0
    try:
        result = resume_sweep(out, comm, progress=args.progress or sys.stderr.isatty())
    except SceneError as err:
        release(out, comm)
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    return _sweep_report(result, out, args.quiet)


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


def _plot_options(args: argparse.Namespace):
    """The options of ``rodfem plot`` read (their fit with the runs is checked as they load)."""
    from rodfem.post.options import KINDS, Options, parse_labels, parse_only, parse_window

    return Options(only=parse_only(args.only) if args.only is not None else frozenset(KINDS),
                   animation=args.animation,
                   window=parse_window(args.window) if args.window is not None else None,
                   labels=parse_labels(args.labels) if args.labels is not None else None,
                   colour_by=args.colour_by)


def _drawing(args: argparse.Namespace):
    """Check the options against what the directories are (runs, or one sweep) and return what
    draws the figures: the options' mistakes are found before any note or figure."""
    from rodfem.output.directories import read_marker
    from rodfem.post import PlotError
    from rodfem.post import plot as draw

    sweeps = [d for d in args.dirs if (read_marker(d) or {}).get("command") == "sweep"]
    if sweeps and len(args.dirs) > 1:
        raise PlotError(f"{sweeps[0]} is a sweep: plot it alone (its figures draw every "
                        "scene's measures)")
    if not sweeps:
        options = _plot_options(args)
        return lambda: draw(args.dirs, args.out, options, force=args.force)
    from rodfem.post.sweep import plot_sweep

    for option, value in (("--window", args.window), ("--labels", args.labels),
                          ("--colour-by", args.colour_by)):
        if value is not None:
            raise PlotError(f"{option} applies to runs; {sweeps[0]} is a sweep")
    only = None if args.only is None else [m.strip() for m in args.only.split(",")]
    return lambda: plot_sweep(sweeps[0], args.out, force=args.force, only=only)


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


def paper(args: argparse.Namespace) -> int:
    """Reproduce Section 6 into args.out; print where its index is."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError
    from rodfem.studies.paper import reproduce

    for name in BUILTIN:  # every override is checked before anything runs
        load(name, args.overrides)
    try:
        index, failed, stopped = reproduce(args.out, args.force, MPI.COMM_WORLD,
                                           overrides=args.overrides, report=say)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if stopped is not None:
        out = args.out / stopped.summary["scene"]
        code = _report(None, stopped, out, quiet=True)  # interrupted, or a write failed
        say("rodfem: the reproduction stopped there, before index.md; 'rodfem paper --force' "
            "makes it again.")
        return code
    if failed:
        say(f"rodfem: the run of {', '.join(failed)} failed (see {index}); the other "
            "experiments are reproduced.")
        say(str(index), sys.stdout)
        return EXIT_DIVERGED
    say(str(index), sys.stdout)
    return 0


def stability(args: argparse.Namespace) -> int:
    """The stability map into args.out, then its figures (rank 0)."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError, finish
    from rodfem.studies import stability as st

    comm = MPI.COMM_WORLD
    try:
        grid = st.Grid(dt=st.parse_list(args.dt, "--dt", st.DEFAULT_DT),
                       epsilon=st.parse_list(args.epsilon, "--epsilon", st.DEFAULT_EPSILON),
                       zeta=st.parse_list(args.zeta, "--zeta", st.DEFAULT_ZETA),
                       a=st.parse_list(args.a, "--a", st.DEFAULT_A),
                       methods=st.parse_methods(args.methods),
                       end=st.parse_number(args.end, "--end", st.DEFAULT_END))
        progress = args.progress or sys.stderr.isatty()
        records, seconds = st.run_map(args.out, args.scene, args.overrides, grid, args.force,
                                   progress, comm)
    except (st.GridError, OutputError) as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if records is None:
        finish(args.out, "interrupted", comm)
        return _stopped(args.out)
    written = []
    if comm.rank == 0:
        from rodfem.post.stability import plot_stability

        written = plot_stability(args.out)
    finish(args.out, "complete", comm)
    for line in st.report_lines(records, grid, seconds, args.out, comm.size):
        say(line, sys.stdout)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0


def _stopped(out: Path) -> int:
    """A study stopped by a signal: one line, and 128 + the signal."""
    import signal

    from rodfem.output import interrupts

    code = interrupts.exit_code()
    say(f"rodfem: interrupted by {signal.Signals(code - 128).name}; no results written to {out}.")
    return code


def verify(args: argparse.Namespace) -> int:
    """``rodfem verify`` or ``rodfem work-precision`` into args.out, then the figures (rank 0)."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError, finish

    comm = MPI.COMM_WORLD
    if args.command == "verify":
        from rodfem.post.verify import plot_orders as draw
        from rodfem.studies import verify as task

        plan = task.QUICK if args.quick else task.DEFAULT
        try:
            scenes = task.parse_scenes(args.scenes)
        except task.VerifyError as err:
            say(f"rodfem: error: {err}")
            return EXIT_INPUT

        def start(out, plan, force, progress, comm):
            return task.run_verify(out, plan, scenes, force, progress, comm)
    else:
        from rodfem.post.verify import plot_work_precision as draw
        from rodfem.studies import workprecision as task

        plan = task.default_plan(args.quick)
        start = task.run_work_precision
    try:
        data = start(args.out, plan, args.force, args.progress or sys.stderr.isatty(), comm)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if data is None:
        finish(args.out, "interrupted", comm)
        return _stopped(args.out)
    written = draw(args.out) if comm.rank == 0 else []
    finish(args.out, "complete", comm)
    for line in task.summary_lines(data, args.out):
        say(line, sys.stdout)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0
