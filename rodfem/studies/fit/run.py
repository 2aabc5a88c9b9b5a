"""The fit of a study file (``rodfem fit``, :func:`fit`): its inputs checked, its directory
written (:mod:`rodfem.studies.fit.files`), the optimiser run (:mod:`rodfem.studies.fit.optimiser`),
the run at the optimum, fit.json and fit.png; and a stopped fit resumed.
"""

from __future__ import annotations

import dataclasses
import signal
from pathlib import Path

import numpy as np
from mpi4py import MPI

from rodfem.output import interrupts, journal
from rodfem.output.atomic import io_line, replacing
from rodfem.output.files import write_json
from rodfem.scene import SceneError
from rodfem.studies.fit.files import FitError, FitResult
from rodfem.studies.fit.optimiser import (
    Evaluations,
    Problem,
    WriteError,
    at_bounds,
    coarse_line,
    jacobian,
    optimise,
    statistics,
)
from rodfem.studies.sweep.parameters import Study


def study_of(spec) -> tuple[Study, Path]:
    """The study of a fit file's path or TOML data, and its data file's path."""
    from rodfem.studies.fit.data import OWN
    from rodfem.studies.sweep import parameters

    if isinstance(spec, dict):
        study, directory = parameters.parse(spec, "<dict>", None, OWN), None
    elif isinstance(spec, (str, Path)):
        study, directory = parameters.load(spec, OWN), Path(spec).parent
    else:
        raise SceneError("fit: must be a fit file's path or its data as a dict, not "
                         f"{type(spec).__name__}")
    data = study.extra.get("data")
    if not isinstance(data, str) or not data:
        raise SceneError(f'{study.name}: data must name the CSV of the measured histories, e.g. '
                         'data = "measured.csv"')
    path = Path(data)
    return study, path if directory is None or path.is_absolute() else directory / path


def problem_of(study: Study, data_path: Path, base: tuple[dict, str] | None = None) -> Problem:
    """The fit of ``study`` to the data at ``data_path``, every input checked (SceneError)."""
    from rodfem.scene import read
    from rodfem.studies.fit.data import load_data, options

    start, count, tolerance = options(study)
    problem = Problem(study, None, start, count, tolerance, base or read(study.scene))
    scene = problem.sweep([[start[key] for key in study.keys]]).scene(0)
    return dataclasses.replace(problem, data=load_data(study, data_path, scene))


def run_fit(spec, out: str | Path | None = None, comm: MPI.Comm | None = None, *,
            force: bool = False, progress: bool = False, text: str | None = None,
            format: str | None = None) -> FitResult:
    """Fit a study (a fit file's path or its TOML data) into the directory ``out`` (as
    ``rodfem fit --out``), or in memory with ``out=None``. Under mpirun every rank calls it.
    ``format``: fit.png's, png, pdf or svg (default: the base scene's ``output.figure_format``).

    Raises:
        SceneError: a mistake in the fit file, its data or a scene (nothing run or written).
        rodfem.OutputError: ``out`` cannot be used.
        FitError: a run failed. WriteError: the journal could not be written.
        rodfem.output.interrupts.Interrupted: a signal stopped it (between two batches).
    """
    comm = comm or MPI.COMM_WORLD
    if format is not None:
        from rodfem.output.figures import checked

        format = checked(format)  # FormatError before anything runs
    study, data_path = study_of(spec)
    problem = problem_of(study, data_path)
    if out is None:
        with interrupts.deferred():
            return _solve(problem, Evaluations(problem, comm, progress=progress), comm, None)
    out = Path(out)
    from rodfem.output.directories import OutputError, prepare_directory
    from rodfem.output.files import write_text
    from rodfem.scene import validate
    from rodfem.studies.fit.files import FILES, meta

    data_bytes = data_path.read_bytes()
    written = meta(study, problem.base, data_bytes, format)  # SceneError before any write
    base = validate(*problem.base).to_toml()
    keep = Path(spec) if isinstance(spec, (str, Path)) else None
    if keep is not None and text is None:
        text = keep.read_text(encoding="utf-8")
    if out.exists() and out.resolve() in data_path.resolve().parents:
        raise OutputError(f"the data {data_path} is inside the output directory {out}")
    with interrupts.deferred():
        prepare_directory(out, force, comm, keep=keep, command="fit", files=FILES)
        if text is not None:
            write_text(out / "fit.toml", text, comm)
        write_json(out / "study.json", written, comm)
        write_text(out / "base.toml", base, comm)
        if comm.rank == 0:
            with replacing(out / "data.csv", "wb") as file:
                file.write(data_bytes)
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    return _into(out, problem, comm, written, 0, {}, progress, format)


def _into(out: Path, problem: Problem, comm: MPI.Comm, written: dict, session: int,
          known: dict, progress: bool, figure_format: str | None = None,
          flagged: frozenset[bytes] = frozenset()) -> FitResult:
    """The fit into ``out`` (held by this command), its marker's status written however it
    ends."""
    from rodfem.output.directories import finish
    from rodfem.studies.fit.files import tag

    log = journal.Journal(out, session, comm.rank, tag(written))
    status = "failed"
    try:
        with interrupts.deferred():
            try:
                result = _solve(problem, Evaluations(problem, comm, log, known, progress,
                                                     flagged), comm, out, figure_format)
            finally:
                log.close()
        status = "complete"
        return result
    except interrupts.Interrupted:
        status = "interrupted"
        raise
    finally:
        try:
            finish(out, status, comm)
        except OSError:
            pass  # the marker says running, and is read as killed


def _solve(problem: Problem, evaluations: Evaluations, comm: MPI.Comm,
           out: Path | None, figure_format: str | None = None) -> FitResult:
    """Fit, then the statistics at the optimum, the fitted run, fit.json and fit.png (or .pdf,
    .svg: ``figure_format``, else the scene's)."""
    found = optimise(problem, evaluations)
    u = found.x
    r = evaluations.batch([u])[0]
    stderr, correlation, why = statistics(problem, u, r, jacobian(evaluations, u))
    warnings = [w for w in (why, at_bounds(problem, u, found.active_mask)) if w]
    coarse_runs, coarse_warning = coarse_line(evaluations)
    interrupts.stop_if_received(comm)  # a signal in the phases after the optimiser stops them
    data = problem.data
    model = data.model(r)
    numbers = {
        "parameters": {key: {"value": value, "stderr": None if stderr is None else float(e)}
                       for key, value, e in zip(problem.study.keys, problem.values(u),
                                                stderr if stderr is not None else u,
                                                strict=True)},
        "correlation": None if correlation is None else correlation.tolist(),
        "residual_norm": float(np.linalg.norm(r)), "iterations": int(found.njev),
        "evaluations": int(found.nfev), "runs": len(evaluations.cache),
        "status": "converged" if found.status > 0 else "stopped", "message": found.message,
        "columns": list(data.columns), "points": len(data.t), "counts": data.counts(),
        "start": problem.start, "warning": "; ".join(warnings) or None,
        "coarse_runs": coarse_runs, "coarse_warning": coarse_warning,
        "model": {c: [None if np.isnan(x) else x for x in model[:, j].tolist()]
                  for j, c in enumerate(data.columns)}}
    fitted = _fitted(problem.scene(u), comm, out)
    interrupts.stop_if_received(comm)
    error = None
    if out is not None and comm.rank == 0:
        from rodfem.output.figures import chosen
        from rodfem.post.fit import fit_title, plot_fit

        values = {c: data.values[:, j] for j, c in enumerate(data.columns)}
        try:
            figure = out / f"fit.{chosen(figure_format, problem.scene(u))}"
            plot_fit(figure, data.t, values, fitted.history["t"],
                     {c: fitted.history[c] for c in data.columns},
                     fit_title(numbers["parameters"]))
        except OSError as err:
            error = io_line(err)
    error = comm.bcast(error, root=0)
    if error is not None:
        raise WriteError(error)
    interrupts.stop_if_received(comm)  # before fit.json: a fit with one is complete
    if out is not None and comm.rank == 0:
        try:
            write_json(out / "fit.json", numbers, MPI.COMM_SELF)
        except OSError as err:
            error = io_line(err)
    error = comm.bcast(error, root=0)
    if error is not None:
        raise WriteError(error)
    comm.barrier()
    return FitResult(numbers, data.t, {c: data.values[:, j] for j, c in enumerate(data.columns)},
                     {c: model[:, j] for j, c in enumerate(data.columns)}, fitted, out)


def _fitted(scene, comm: MPI.Comm, out: Path | None):
    """The run at the optimum: ``out/fitted`` (a run directory), or in memory."""
    from rodfem.output.columns import for_scene
    from rodfem.output.result import Result, load, named_history
    from rodfem.run import simulate

    where = None if out is None else out / "fitted"
    if where is not None:
        from rodfem.output.directories import prepare_directory
        from rodfem.output.files import write_text

        prepare_directory(where, True, comm)
        write_text(where / "scene.toml", scene.to_toml(), comm)
    run = simulate(scene, where, comm, progress=False)
    if run.status == "interrupted":
        raise interrupts.Interrupted(run.signal or signal.SIGINT)
    if run.io_error is not None:
        raise WriteError(run.io_error)
    if run.status != "complete":
        raise FitError(f"the run at the optimum failed: {run.io_error or run.error}")
    comm.barrier()
    if where is not None:
        return load(where)
    return Result(scene, run.summary, named_history(run.history, for_scene(scene)))


def resume(out: Path, comm: MPI.Comm, progress: bool = False,
           format: str | None = None) -> FitResult:
    """Continue the fit in ``out`` (held by this command with ``reopen``): replayed from its
    start, the journalled points taken, not run; its figure in ``format`` (png, pdf or svg;
    default: the one the fit was started with, else the base scene's ``output.figure_format``).

    Raises:
        SceneError: its study.json, data.csv or journal is not this fit's (one line).
    """
    from rodfem.output.directories import mark_running
    from rodfem.output.figures import checked
    from rodfem.studies.fit.data import OWN
    from rodfem.studies.fit.files import read_meta, tag
    from rodfem.studies.sweep import parameters

    written = read_meta(out)
    study = parameters.parse(written["study"], written["name"], out, OWN)
    problem = problem_of(study, out / "data.csv", (written["base"], written["source"]))
    known, flagged, error = {}, frozenset(), None
    if comm.rank == 0:
        try:
            records = journal.read(out, tag(written)).values()
            known = {bytes.fromhex(r.line.split()[0]): r.history()[0] for r in records}
            flagged = frozenset(bytes.fromhex(r.line.split()[0]) for r in records
                                if r.line.endswith(" coarse"))
        except journal.JournalError as err:
            error = (f"{err.path} holds points of another fit than the directory's study.json; "
                     "run the fit again with --force")
        except (ValueError, IndexError, TypeError) as err:
            error = f"{out}: its journal is not this fit's ({err}); run the fit again with --force"
    error, known, flagged = comm.bcast((error, known, flagged), root=0)
    if error is not None:
        raise SceneError(error)
    session = comm.bcast(journal.sessions(out) if comm.rank == 0 else None, root=0)
    mark_running(out, comm)
    # the format asked for now, else the one the fit was started with (study.json)
    figure_format = checked(format) if format is not None else written.get("figure")
    return _into(out, problem, comm, written, session, known, progress, figure_format, flagged)


def fit(study, out: str | Path | None = None, comm=None, *, force: bool = False,
        progress: bool = False) -> FitResult:
    """Fit a scene's parameters to measured histories: ``study`` a fit file's path or its TOML
    data (a dict), into the directory ``out`` (as ``rodfem fit --out``) or in memory. Under
    mpirun every rank calls it and gets the same result. A signal received during the call
    stops it, not the next.

    Raises:
        SceneError: a mistake in the fit file, its data or a scene (nothing run or written).
        rodfem.OutputError: ``out`` cannot be used.
        FitError: a run failed (the message names its point).
        rodfem.output.interrupts.Interrupted: a stop signal (Ctrl-C, SIGTERM, SIGUSR1) came:
            the fit stopped between two batches of runs, with no result; a fit into ``out``
            continues with ``rodfem resume``.
    """
    with interrupts.call():
        return run_fit(study, out, comm, force=force, progress=progress)
