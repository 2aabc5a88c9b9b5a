"""The ``rodfem`` command.

    rodfem run SCENE [--out DIR] [--set section.key=value ...] [--force]
    rodfem plot DIR [DIR ...] [--out FIGDIR]
    rodfem stability [--out DIR] [--scene S] [--methods M,...] [--dt LIST] [--epsilon LIST]
                     [--zeta LIST] [--a LIST] [--end T] [--force] [--progress]
    rodfem verify [--out DIR] [--scenes S,...] [--force] [--quick] [--progress]
    rodfem work-precision [--out DIR] [--force] [--quick] [--progress]

Exit codes: 0 complete, 2 bad input (nothing written), 3 the method did not converge at a step
(results so far kept), 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.scene import BUILTIN, EXTRA, SceneError, load

EXIT_INPUT, EXIT_DIVERGED, EXIT_INTERRUPTED = 2, 3, 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rodfem",
        description="Dynamic contact of a thermoviscoelastic rod with an obstacle (Copetti).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser(
        "run",
        help="simulate a scene",
        description="Simulate a scene and write history.csv, fields.xdmf, scene.toml and "
        "summary.json into the output directory.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    run.add_argument("scene",
                     help=f"a built-in scene ({', '.join(BUILTIN + EXTRA)}) or a TOML file")
    run.add_argument("--out", type=Path, help="output directory (default: results/<scene name>)")
    run.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="override a scene value, e.g. --set model.zeta=1 (repeatable)",
    )
    run.add_argument("--force", action="store_true", help="replace an existing run directory")
    run.add_argument("--quiet", action="store_true", help="no progress bar and no final line")
    run.add_argument("--progress", action="store_true",
                     help="draw the progress bar even when output is not a terminal (mpirun)")
    plot = sub.add_parser(
        "plot",
        help="draw the figures of runs",
        description="Draw contact.png, energy.png, spacetime_{u,theta,sigma}.png and rod.gif of "
        "a run directory into DIR/figures. With several directories, contact.png and energy.png "
        "overlay the runs and the per-run figures are named after each run's directory, "
        "e.g. rod_paper2.gif, all in the first directory's figures/ (or FIGDIR).",
    )
    plot.add_argument("dirs", nargs="+", type=Path, metavar="DIR",
                      help="a run directory written by 'rodfem run'")
    plot.add_argument("--out", type=Path, metavar="FIGDIR",
                      help="figure directory (default: the first DIR's figures/)")
    paper = sub.add_parser(
        "paper",
        help="reproduce the paper's Section 6",
        description="Run the paper's five experiments, draw their figures and Figure 5, and write "
        "index.md, which sets each figure beside what the paper says about it.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    paper.add_argument("--out", type=Path, default=Path("results/paper"), help="output directory")
    paper.add_argument("--force", action="store_true", help="replace an earlier reproduction")
    paper.add_argument("--set", dest="overrides", action="append", default=[],
                       metavar="SECTION.KEY=VALUE",
                       help="override a value in every experiment, e.g. --set time.end=2")
    stability = sub.add_parser(
        "stability",
        help="map where each method converges over (Δt, ε, ζ, a)",
        description="Sweep Δt, ε, ζ and a over a log grid, run the scene at every point with each "
        "method, and write stability.csv (one row per point and method), stability.json (the grid, "
        "the machine, and Picard's measured boundary against the paper's Δt < εζ and the "
        "compliance's w/ε < 1) and figures/stability_<method>.png. Lists are comma-separated. "
        "Points are shared round-robin among MPI ranks.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    stability.add_argument("--out", type=Path, default=Path("results/stability"),
                           help="output directory")
    stability.add_argument("--scene", default="paper1",
                           help=f"the base scene: built-in ({', '.join(BUILTIN)}) or a TOML file")
    stability.add_argument("--set", dest="overrides", action="append", default=[],
                           metavar="SECTION.KEY=VALUE",
                           help="override a base scene value, e.g. solver.max_iterations=500")
    stability.add_argument("--methods", default="direct,newton,picard", help="methods to run")
    from rodfem.studies.stability import DEFAULT_A, DEFAULT_DT, DEFAULT_EPSILON, DEFAULT_ZETA

    listed = lambda values: ",".join(f"{v:g}" for v in values)  # noqa: E731
    stability.add_argument("--dt", default=listed(DEFAULT_DT),
                           help="time steps, each a divisor of --end")
    stability.add_argument("--epsilon", default=listed(DEFAULT_EPSILON),
                           help="obstacle compliances ε (stiffness 1/ε)")
    stability.add_argument("--zeta", default=listed(DEFAULT_ZETA), help="viscosities ζ")
    stability.add_argument("--a", default=listed(DEFAULT_A), help="thermal couplings a")
    stability.add_argument("--end", default="1", help="end time of every run")
    stability.add_argument("--force", action="store_true",
                           help="replace an earlier stability map in --out")
    stability.add_argument("--progress", action="store_true",
                           help="a line per point even when output is not a terminal (mpirun)")
    verify = sub.add_parser(
        "verify",
        help="observed orders of convergence in h and Δt",
        description="Run ladders of refinements in h and in Δt of paper1, paper5 and a scene "
        "without contact (and the manufactured solution), for every method and time scheme, "
        "against finer reference runs, and write orders.csv, orders.md, orders.json, errors.csv "
        "and figures/orders_<scene>.png (log-log, with slopes 1 and 2). Ladders are dealt "
        "among MPI ranks, the costliest first.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    work = sub.add_parser(
        "work-precision",
        help="accuracy against wall time, per method and time scheme",
        description="For each (method, time scheme) run a ladder of (cells, Δt) refinements of "
        "paper1 and paper5, measure the error of u(1, ·) against a fine reference and the wall "
        "time, and write workprecision.csv, workprecision.json (with the time at which each "
        "choice reaches an error of 1e-3 on paper5) and figures/workprecision_<scene>.png.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    for command, default in ((verify, "results/verify"), (work, "results/work-precision")):
        command.add_argument("--out", type=Path, default=Path(default), help="output directory")
        command.add_argument("--force", action="store_true",
                             help="replace an earlier result of this command in --out")
        command.add_argument("--quick", action="store_true",
                             help="small ladders, the direct method only (seconds)")
        command.add_argument("--progress", action="store_true",
                             help="a line per ladder even when output is not a terminal")
    verify.add_argument("--scenes", help="scenes to verify (default: paper1, paper5, no-contact "
                        "and, where rodfem.model.manufactured exists, manufactured)")
    return parser


def _say(message: str, stream=None) -> None:
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

    from rodfem.output.files import OutputError, prepare_directory
    from rodfem.run import simulate

    try:
        scene_file = Path(args.scene) if args.scene not in BUILTIN else None
        prepare_directory(out, args.force, MPI.COMM_WORLD, keep=scene_file)
    except OutputError as err:
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT
    result = simulate(scene, out, MPI.COMM_WORLD, progress=not args.quiet,
                      force_progress=args.progress)
    s = result.summary
    if result.status == "failed":
        _say(f"rodfem: {_advice(scene, result.error)} "
             f"Steps 0..{s['steps']} are in {out} (status: failed).")
        return EXIT_DIVERGED
    if result.status == "interrupted":
        _say(f"rodfem: interrupted; steps 0..{s['steps']} are in {out}.")
        return EXIT_INTERRUPTED
    if not args.quiet:
        _say(
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
        _say(f"rodfem: error: {error}")
        return EXIT_INPUT
    for path in written:
        _say(str(path), sys.stdout)
    return 0


def paper(args: argparse.Namespace) -> int:
    """Reproduce Section 6 into args.out; print where its index is."""
    from mpi4py import MPI

    from rodfem.output.files import OutputError
    from rodfem.studies.paper import reproduce
    from rodfem.scene import load

    for name in BUILTIN:  # every override is checked before anything runs
        load(name, args.overrides)
    try:
        index = reproduce(args.out, args.force, MPI.COMM_WORLD, overrides=args.overrides,
                          report=_say)
    except OutputError as err:
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT
    _say(str(index), sys.stdout)
    return 0


def stability(args: argparse.Namespace) -> int:
    """The stability map into args.out, then its figures (rank 0)."""
    from mpi4py import MPI

    from rodfem.studies import stability as st
    from rodfem.output.files import OutputError

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
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if records is None:
        _say(f"rodfem: interrupted; nothing written to {args.out}.")
        return EXIT_INTERRUPTED
    written = []
    if comm.rank == 0:
        from rodfem.post.stability import plot_stability

        written = plot_stability(args.out)
    for line in st.report_lines(records, grid, seconds, args.out, comm.size):
        _say(line, sys.stdout)
    for path in written:
        _say(str(path), sys.stdout)
    comm.barrier()
    return 0


def verify(args: argparse.Namespace) -> int:
    """``rodfem verify`` or ``rodfem work-precision`` into args.out, then the figures (rank 0)."""
    from mpi4py import MPI

    from rodfem.output.files import OutputError

    comm = MPI.COMM_WORLD
    if args.command == "verify":
        from rodfem.studies import verify as task
        from rodfem.post.verify import plot_orders as draw

        plan = task.QUICK if args.quick else task.DEFAULT
        try:
            scenes = task.parse_scenes(args.scenes)
        except task.VerifyError as err:
            _say(f"rodfem: error: {err}")
            return EXIT_INPUT

        def start(out, plan, force, progress, comm):
            return task.run_verify(out, plan, scenes, force, progress, comm)
    else:
        from rodfem.studies import workprecision as task
        from rodfem.post.verify import plot_work_precision as draw

        plan = task.default_plan(args.quick)
        start = task.run_work_precision
    try:
        data = start(args.out, plan, args.force, args.progress or sys.stderr.isatty(), comm)
    except OutputError as err:
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if data is None:
        _say(f"rodfem: interrupted; nothing written to {args.out}.")
        return EXIT_INTERRUPTED
    written = draw(args.out) if comm.rank == 0 else []
    for line in task.summary_lines(data, args.out):
        _say(line, sys.stdout)
    for path in written:
        _say(str(path), sys.stdout)
    comm.barrier()
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "plot":
            return plot(args)
        if args.command == "paper":
            return paper(args)
        if args.command == "stability":
            return stability(args)
        if args.command in ("verify", "work-precision"):
            return verify(args)
        return run(args)
    except SceneError as err:
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT


if __name__ == "__main__":
    sys.exit(main())
