"""The studies over many runs: ``rodfem paper``, ``rodfem stability``, ``rodfem verify`` and
``rodfem work-precision``, each into its directory, then its figures and summary lines; and
``rodfem steady``, a scene's steady states and their branches."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.commands.common import EXIT_DIVERGED, EXIT_INPUT, say
from rodfem.commands.runs import report_run
from rodfem.scene import BUILTIN, load


def paper(args: argparse.Namespace) -> int:
    """Reproduce Section 6 into args.out; print where its index is."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError
    from rodfem.studies.verification.paper import reproduce

    for name in BUILTIN:  # every override is checked before anything runs
        load(name, args.overrides)
    try:
        index, failed, stopped = reproduce(args.out, args.force, MPI.COMM_WORLD,
                                           overrides=args.overrides, report=say,
                                           format=args.format)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    if stopped is not None:
        out = args.out / stopped.summary["scene"]
        code = report_run(None, stopped, out, quiet=True)  # interrupted, or a write failed
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
    from rodfem.studies.verification import stability as st

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

        written = plot_stability(args.out, format=args.format or "png")
    finish(args.out, "complete", comm)
    for line in st.report_lines(records, grid, seconds, args.out, comm.size):
        say(line, sys.stdout)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0


def steady(args: argparse.Namespace) -> int:
    """Every steady state of a scene and its stability (and their branches) into its
    directory; the states as a table."""
    from mpi4py import MPI

    from rodfem.solver.spectrum import Spectra
    from rodfem.studies.steady import states as st
    from rodfem.studies.steady.continuation import ContinuationError

    comm = MPI.COMM_WORLD
    scene = load(args.scene, args.overrides)
    try:
        key, lo, hi, n = st.parse_continuation(args.continuation, scene) if args.continuation \
            else (None, None, None, None)
        st.check_mesh(scene, 4 if args.extrapolate else 1)
        follow = _follow(args, key, n)
    except st.SteadyError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    out = args.out if args.out is not None else \
        Path("results") / f"{Path(args.scene).stem}-steady"
    spectra = Spectra(comm)
    rows = st.analyse(scene, spectra)
    if args.extrapolate:
        st.continuum(scene, rows, spectra)
    try:
        return _steady_files(args, scene, comm, spectra, rows, key, lo, hi, n, follow, out)
    except ContinuationError as err:
        say(f"rodfem: error: {err}; nothing written")
        return EXIT_DIVERGED


def _steady_files(args, scene, comm, spectra, rows, key, lo, hi, n, follow, out) -> int:
    """The branches, points and curves of ``rodfem steady``, its files and lines."""
    import numpy as np

    from rodfem.output.directories import OutputError, finish
    from rodfem.studies.steady import states as st

    branch_rows = point_rows = None
    if key is not None and n is not None:
        values = np.linspace(lo, hi, n)
        branch_rows = st.continuation(st.scenes_over(args.scene, args.overrides, key, values),
                                      values, spectra, key)
    elif key is not None:
        from rodfem.studies.steady import diagram

        st.scenes_over(args.scene, args.overrides, key, [lo, hi])  # both ends valid
        found = diagram.compute(scene, key, min(lo, hi), max(lo, hi), spectra,
                                args.extrapolate)
        branch_rows, point_rows = found.branch_rows, found.point_rows
    curve_rows = grid = None
    if follow is not None:
        from rodfem.studies.steady import curves

        key2, c, d, count = follow
        st.scenes_over(args.scene, args.overrides, key2, [c, d])  # both ends valid
        curve_rows = curves.follow(scene, key, min(lo, hi), max(lo, hi), key2,
                                   np.linspace(c, d, count), args.follow, spectra, point_rows)
        grid = curves.counts(scene, key, min(lo, hi), max(lo, hi), key2, c, d)
    try:
        st.write(out, args.force, comm, rows, branch_rows, point_rows, curve_rows, grid)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    written = []
    if comm.rank == 0 and key is not None:
        from rodfem.output.figures import chosen
        from rodfem.post.steady import plot_branches

        written = plot_branches(out, key, scene["obstacle.gap"], chosen(args.format, scene))
        if curve_rows is not None:
            from rodfem.post.bifurcation import plot_curves

            written += plot_curves(out, chosen(args.format, scene))
    finish(out, "complete", comm)
    for line in st.table_lines(rows):
        say(line, sys.stdout)
    for line in st.warning_lines(rows):
        say(line)
    if key is not None:
        for line in st.branch_lines(branch_rows, key):
            say(line, sys.stdout)
        if point_rows is not None:
            from rodfem.studies.steady.diagram import point_lines

            for line in point_lines(point_rows, key):
                say(line, sys.stdout)
        for line in st.warning_lines(branch_rows):
            say(line)
    if not args.extrapolate:
        say(f"(rates on the mesh of {scene['mesh.cells']} cells, off the rod's by O(h²): "
            "--extrapolate gives the continuum's, with error estimates)", sys.stdout)
    if curve_rows is not None:
        say(f"{len({(r['kind'], r['curve']) for r in curve_rows})} curve(s) of {args.follow} "
            f"points over {follow[0]}, {len(curve_rows)} points", sys.stdout)
    files = [st.STATES, *([st.BRANCHES] if key else []),
             *(["points.csv"] if point_rows is not None else []),
             *(["curves.csv", "counts.csv"] if curve_rows is not None else [])]
    for path in (*(out / f for f in files), *written):
        say(str(path), sys.stdout)
    comm.barrier()
    return 0


def _follow(args, key, n):
    """--follow KIND --along KEY2=c:d[:n] → (KEY2, c, d, n), or None without them (SteadyError:
    one without the other, or without --continue KEY=a:b)."""
    from rodfem.studies.steady import curves
    from rodfem.studies.steady import states as st

    if args.follow is None and args.along is None:
        return None
    if args.follow is None or args.along is None:
        raise st.SteadyError("--follow and --along go together: --follow fold|grazing|hopf "
                             "--along KEY2=c:d")
    if key is None or n is not None:
        raise st.SteadyError("--follow needs --continue KEY=a:b (the branches followed, not "
                             "sampled at n values)")
    return curves.parse_along(args.along, key, st.SteadyError)


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
        from rodfem.studies.verification import ladders as user_ladders
        from rodfem.studies.verification import refine as task
        from rodfem.studies.verification import verify

        plan = verify.QUICK if args.quick else verify.DEFAULT
        ladders = user_ladders.QUICK if args.quick else user_ladders.DEFAULT
        try:
            scenes, users = user_ladders.parse_scenes(args.scenes, args.overrides, ladders,
                                                      args.select)
        except verify.VerifyError as err:
            say(f"rodfem: error: {err}")
            return EXIT_INPUT

        def start(out, plan, force, progress, comm):
            return task.run_verify(out, plan, scenes, force, progress, comm, users, ladders)
    else:
        from rodfem.post.workprecision import plot_work_precision as draw
        from rodfem.studies.verification import workprecision as task

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
    written = draw(args.out, args.format or "png") if comm.rank == 0 else []
    finish(args.out, "complete", comm)
    for line in task.summary_lines(data, args.out):
        say(line, sys.stdout)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0
