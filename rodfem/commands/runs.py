"""``rodfem run`` and ``rodfem resume``: a scene run into its directory, a stopped run
continued, and the one line that says how it ended (a sweep's resume is
:mod:`rodfem.commands.sweeps`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.commands.common import EXIT_DIVERGED, EXIT_INPUT, EXIT_IO, say
from rodfem.scene import BUILTIN, load


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


# The directories `rodfem resume` continues other than a run's: their command's resume function.
STUDIES = {"sweep": ("rodfem.commands.sweeps", "resume_sweep"),
           "fit": ("rodfem.commands.fit", "resume_fit"),
           "sensitivity": ("rodfem.commands.sensitivity", "resume_sensitivity")}
FIGURED = ("fit", "sensitivity")  # the resumed studies that draw a figure (--format)
PER_STEP = {"picard": "Picard iterations/step", "newton": "Newton iterations/step",
            "direct": "solves/step"}


def run(args: argparse.Namespace) -> int:
    scene = load(args.scene, args.overrides)  # validates everything before anything is written
    out = args.out if args.out is not None else Path("results") / Path(args.scene).stem

    from rodfem.output import handover, interrupts
    from rodfem.output.directories import OutputError, prepare_directory
    from rodfem.output.files import write_text
    from rodfem.output.sizes import SizeError, check_room
    from rodfem.parallel import world
    from rodfem.solver.compiled import KernelUnavailable, ready

    comm = world()  # MPI's, or where no launcher started the process one without MPI

    try:  # the compiled loop built, or checked, before anything is written
        ready(scene, comm)
    except KernelUnavailable as err:
        say(err.line())
        return EXIT_DIVERGED
    try:
        check_room(scene, out, comm, allow=args.large)
        scene_file = Path(args.scene) if args.scene not in BUILTIN else None
        # A directory marked is one with its scene.toml, which resume reads: a signal between
        # the two is taken after both.
        with interrupts.deferred():
            prepare_directory(out, args.force, comm, keep=scene_file,
                              files=run_files(scene))
            write_text(out / "scene.toml", scene.to_toml(), comm)
    except (OutputError, SizeError) as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    handover.pause_for_tests(comm)
    if scene.targets:
        return run_to_target(scene, out, args.quiet)
    from rodfem.run import simulate

    result = simulate(scene, out, comm, progress=not args.quiet,
                      force_progress=args.progress)
    return report_run(scene, result, out, args.quiet)


def run_to_target(scene, out: Path, quiet: bool) -> int:
    """A scene with an accuracy target (:mod:`rodfem.studies.accuracy`): its ladder of runs,
    each said in a line (unless ``quiet``), then the reported run into ``out``, its line, and
    the estimates (a warning for a target not met, said even when quiet)."""
    from mpi4py import MPI

    from rodfem.output.directories import finish
    from rodfem.studies.accuracy.ladder import LadderFailed
    from rodfem.studies.accuracy.run import simulate_to_target

    talk = None if quiet else (lambda line: say(f"rodfem: {line}"))
    try:
        chosen, result, record = simulate_to_target(scene, out, MPI.COMM_WORLD, talk,
                                                    progress=not quiet)
    except LadderFailed as err:  # nothing written but the scene: a resume starts it again
        failed = err.result
        finish(out, "interrupted" if failed.status == "interrupted" else "failed",
               MPI.COMM_WORLD)
        step = ("time.tolerance", err.scene["time.tolerance"]) if err.scene.adaptive \
            else ("time.dt", err.scene["time.dt"])
        where = f"{err.scene['mesh.cells']} cells, {step[0]} = {step[1]:g}"
        if failed.status == "interrupted":
            import signal

            name = signal.Signals(failed.signal).name if failed.signal else "a signal"
            say(f"rodfem: interrupted by {name} while choosing the mesh and steps (a run on "
                f"{where}); 'rodfem resume {out}' starts the choice again")
            return 128 + (failed.signal or signal.SIGINT)
        say(f"rodfem: a run made to choose the mesh and steps for the accuracy target ({where}) "
            f"failed: {_advice(err.scene, failed.error)} Nothing but the scene is in {out}.")
        return EXIT_DIVERGED
    code = report_run(chosen, result, out, quiet)
    if code == 0:
        said_accuracy(record, quiet)
    return code


def said_accuracy(record: dict, quiet: bool) -> None:
    """The estimates of a run chosen for its accuracy target: a warning for a target not met
    (said even when quiet), else the line of the estimates."""
    from rodfem.studies.accuracy.ladder import not_met_line

    missed = not_met_line(record)
    if missed is not None:
        say(f"rodfem: warning: {missed}")
    elif not quiet:
        say(f"rodfem: {accuracy_line(record)}", sys.stdout)


def accuracy_line(record: dict) -> str:
    """The estimates of a run whose targets are met, in one line."""
    accuracy = record["accuracy"]
    step = next(f"{key} = {accuracy[key]:g}" for key in ("tolerance", "dt") if key in accuracy)
    parts = [f"{name} = {e['value']:.6g} ± {e['error'] or 0.0:.2g} (target {e['target']:g})"
             for name, e in accuracy["measures"].items()]
    return (f"accuracy met: {'; '.join(parts)}; {accuracy['cells']} cells, time.{step}, "
            f"{accuracy['runs']} runs")


def run_files(scene) -> tuple[str, ...]:
    """The files a run of ``scene`` writes into its directory."""
    from rodfem.output.directories import ACCURACY_FILES, RUN_FILES

    return (*RUN_FILES, *ACCURACY_FILES) if scene.targets else RUN_FILES


def report_run(scene, result, out: Path, quiet: bool) -> int:
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
    from rodfem.model.timescales import coarse_run

    coarse = coarse_run(scene, {**s, "status": result.status})
    if coarse is not None:  # said whether quiet or not: the results may be off
        say(f"rodfem: warning: {coarse.line}")
    if not quiet:
        adaptive = s.get("adaptive")
        steps = (f"{s['steps']} adaptive steps ({adaptive['rejected']} rejected, "
                 f"{adaptive['events']} contact events)" if adaptive else f"{s['steps']} steps")
        say(
            f"{scene.source}: {steps} in {s['loop_seconds']:.2f} s "
            f"({s['us_per_step']:.1f} µs/step, {s['method']}: {s['iterations_mean']:.2f} "
            f"{PER_STEP[s['method']]})"
            f" -> {out}",
            sys.stdout,
        )
    return 0


def resume(args: argparse.Namespace) -> int:
    """Continue the run in args.dir from its checkpoint (or extend a finished one), or the
    sweep in args.dir."""
    from rodfem.output.directories import OutputError, mark_running, release, reopen
    from rodfem.output.resume import ResumeError, plan
    from rodfem.parallel import world

    comm, out = world(), args.dir
    try:
        marker = reopen(out, comm)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    from rodfem.studies.damage import damage

    why = comm.bcast(damage(out, marker) if comm.rank == 0 else None, root=0)
    if why is not None:  # checked before anything is done: nothing changed
        release(out, comm)
        say(f"rodfem: error: {why}")
        return EXIT_INPUT
    if args.format is not None and marker.get("command") not in FIGURED:
        release(out, comm)  # untouched
        say(f"rodfem: error: --format: a resumed {marker.get('command') or 'run'} draws no "
            f"figure (a fit or a sensitivity study does); 'rodfem plot {out} --format "
            f"{args.format}' draws its figures")
        return EXIT_INPUT
    if marker.get("command") in STUDIES:
        import importlib

        module, function = STUDIES[marker["command"]]
        return getattr(importlib.import_module(module), function)(args, out, marker)
    try:
        scene, checkpoint = plan(out, args.overrides, marker, comm, large=args.large,
                                 any_loop=getattr(args, "any_loop", False))
        mark_running(out, comm)
    except ResumeError as err:  # complete (exit 0), bad input (2), no loop (3), a full disk (4)
        release(out, comm)  # untouched
        say(err.line(), sys.stdout if err.code == 0 else None)
        return err.code
    except OutputError as err:
        release(out, comm)  # untouched
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    from rodfem.run import simulate
    from rodfem.studies.accuracy.run import recorded

    if scene.targets:  # stopped while choosing its mesh and steps: chosen again
        return run_to_target(scene, out, args.quiet)
    if checkpoint is None and not args.quiet:
        say(f"rodfem: {out} has no checkpoint yet; running it again from step 0")
    # a run chosen for an accuracy target keeps its estimates, not one changed by --set (a
    # later end): its record names the scene it is of
    record = recorded(out, scene)
    result = simulate(scene, out, comm, progress=not args.quiet, force_progress=args.progress,
                      resume=checkpoint, annotate=record)
    code = report_run(scene, result, out, args.quiet)
    if code == 0 and record is not None:
        said_accuracy(record, args.quiet)
    return code
