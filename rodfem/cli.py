"""The ``rodfem`` command.

    rodfem run SCENE [--out DIR] [--set section.key=value ...] [--force]
    rodfem plot DIR [DIR ...] [--out FIGDIR]

Exit codes: 0 complete, 2 bad input (nothing written), 3 the method did not converge at a step
(results so far kept), 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.scene import BUILTIN, SceneError, load

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
    run.add_argument("scene", help=f"a built-in scene ({', '.join(BUILTIN)}) or a TOML file")
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
    dt, eps, zeta, a = (scene[k] for k in ("time.dt", "obstacle.epsilon", "model.zeta", "model.a"))
    ratio = f"{dt / (eps * zeta):.3g}" if eps * zeta > 0 else "inf (ζ = 0)"
    return (
        f"{error} (tol {scene['solver.tol']:g}). The paper's sufficient condition for "
        f"convergence is Δt < εζ and a < 1; here Δt/(εζ) = {ratio} (needs < 1) and a = {a:g}. "
        f'solver.method = "direct" solves every step exactly.'
    )


PER_STEP = {"picard": "Picard iterations/step", "newton": "Newton iterations/step",
            "direct": "solves/step"}


def run(args: argparse.Namespace) -> int:
    scene = load(args.scene, args.overrides)  # validates everything before anything is written
    out = args.out if args.out is not None else Path("results") / Path(args.scene).stem

    from mpi4py import MPI

    from rodfem.output import OutputError, prepare_directory
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

    from rodfem.output import OutputError
    from rodfem.paper import reproduce
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


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "plot":
            return plot(args)
        if args.command == "paper":
            return paper(args)
        return run(args)
    except SceneError as err:
        _say(f"rodfem: error: {err}")
        return EXIT_INPUT


if __name__ == "__main__":
    sys.exit(main())
