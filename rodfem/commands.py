"""What each ``rodfem`` subcommand does with its parsed arguments (:mod:`rodfem.cli` parses
them): load and check the input, run, and report in one line per outcome, with the exit codes
below.

Exit codes: 0 complete, 2 bad input (nothing written), 3 the method did not converge at a step
(results so far kept), 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.scene import BUILTIN, load

EXIT_INPUT, EXIT_DIVERGED, EXIT_INTERRUPTED = 2, 3, 130


def say(message: str, stream=None) -> None:
    """Print one line, once (on rank 0), to stderr unless a stream is given."""
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(message, file=stream or sys.stderr, flush=True)


def _advice(scene, error) -> str:
    """The error, and for Picard the paper's condition and the methods that need none."""
    if error.method != "picard":
        return f"{error}."
    from mpi4py import MPI

    from rodfem.model import contact
    from rodfem.solver.methods.direct import compliance

    dt, eps, zeta, a = (scene[k] for k in ("time.dt", "obstacle.epsilon", "model.zeta", "model.a"))
    ratio = f"{dt / (eps * zeta):.3g}" if eps * zeta > 0 else "inf (ζ = 0)"
    w = compliance(scene, MPI.COMM_WORLD)
    law = contact.of_scene(scene)
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

    from rodfem.output.directories import OutputError, prepare_directory
    from rodfem.run import simulate

    try:
        scene_file = Path(args.scene) if args.scene not in BUILTIN else None
        prepare_directory(out, args.force, MPI.COMM_WORLD, keep=scene_file)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    result = simulate(scene, out, MPI.COMM_WORLD, progress=not args.quiet,
                      force_progress=args.progress)
    s = result.summary
    if result.status == "failed":
        say(f"rodfem: {_advice(scene, result.error)} "
             f"Steps 0..{s['steps']} are in {out} (status: failed).")
        return EXIT_DIVERGED
    if result.status == "interrupted":
        say(f"rodfem: interrupted; steps 0..{s['steps']} are in {out}.")
        return EXIT_INTERRUPTED
    if not args.quiet:
        say(
            f"{scene.source}: {s['steps']} steps in {s['loop_seconds']:.2f} s "
            f"({s['us_per_step']:.1f} µs/step, {s['method']}: {s['iterations_mean']:.2f} "
            f"{PER_STEP[s['method']]})"
            f" -> {out}",
            sys.stdout,
        )
    return 0


def plot(args: argparse.Namespace) -> int:
    """Draw the figures on rank 0 (the others wait), then list the files written."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    written, error = [], None
    if comm.rank == 0:
        from rodfem.post import PlotError
        from rodfem.post import plot as draw

        try:
            written = draw(args.dirs, args.out)
        except PlotError as err:
            error = " ".join(str(err).split())  # one line
    written, error = comm.bcast((written, error), root=0)
    if error is not None:
        say(f"rodfem: error: {error}")
        return EXIT_INPUT
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
        index = reproduce(args.out, args.force, MPI.COMM_WORLD, overrides=args.overrides,
                          report=say)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
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
        say(f"rodfem: interrupted; no results written to {args.out}.")
        return EXIT_INTERRUPTED
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
        say(f"rodfem: interrupted; no results written to {args.out}.")
        return EXIT_INTERRUPTED
    written = draw(args.out) if comm.rank == 0 else []
    finish(args.out, "complete", comm)
    for line in task.summary_lines(data, args.out):
        say(line, sys.stdout)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0
