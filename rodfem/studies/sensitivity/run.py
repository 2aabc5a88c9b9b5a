"""``rodfem sensitivity``: which parameters the measures of a scene depend on, and how much.

A sensitivity file is a study file (:mod:`rodfem.studies.sweep.parameters`: a base scene, ``[set]``,
``[parameters]`` ranges, ``[measures]``) with the keys of :mod:`rodfem.studies.sensitivity.indices`
(``method``, ``samples``, ``seed``, ``outputs``, ...). Its points are drawn by SALib, its runs
are a sweep (:mod:`rodfem.studies.sweep.run`) in ``DIR/runs``, a sweep directory like any other: the
MPI ranks share its scenes, a journal keeps them, ``rodfem resume DIR`` continues it, and its
table is the same for any number of ranks and however often it was stopped. The analysis reads
that table: the indices are the same bit for bit too.

The directory: ``sensitivity.toml`` (the file as given), ``sensitivity.json`` (the study, its
base scene and sampling resolved, what resume reads, with its digest), ``samples.csv`` (the
parameters' values of each run, by run index), ``runs/`` (the sweep), ``sensitivity.csv`` (a row
per measure and parameter: Sobol ``S1, S1_conf, ST, ST_conf``, or Morris ``mu_star,
mu_star_conf, sigma``) and ``sensitivity.png`` (their bars).
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from rodfem.output import interrupts
from rodfem.output.measures import NAMES as BUILTIN
from rodfem.output.measures import TIMINGS
from rodfem.scene import SceneError
from rodfem.studies.common import plural
from rodfem.studies.sensitivity import indices
from rodfem.studies.sensitivity.files import (
    CSV,
    FIGURE,
    FILES,
    SensitivityResult,
    coarse_warning,
    load_sensitivity,
    meta,
    read_meta,
    samples_text,
)
from rodfem.studies.sweep import parameters
from rodfem.studies.sweep.design import Sweep
from rodfem.studies.sweep.files import SweepResult
from rodfem.studies.sweep.parameters import Study

__all__ = ["SensitivityResult", "load_sensitivity", "sensitivity"]


@dataclasses.dataclass(frozen=True)
class Campaign:
    """A checked sensitivity study: its points (:class:`~rodfem.studies.sensitivity.indices.Plan`),
    their sweep, and the measures analysed."""

    study: Study
    plan: indices.Plan
    sweep: Sweep
    outputs: tuple[str, ...]
    text: str | None = None
    keep: Path | None = None
    figure_format: str | None = None  # the figure's format (None: the base scene's, or png)


def outputs(value: Any, name: str, declared: tuple[str, ...]) -> tuple[str, ...]:
    """The measures a study analyses: ``outputs``, or every declared measure."""
    allowed = (*[m for m in BUILTIN if m not in TIMINGS], *declared)
    listed = f"allowed: {', '.join(allowed)}"
    if value is None:
        if not declared:
            raise SceneError(f"{name}: outputs must name the measures to analyse, e.g. outputs "
                             f'= ["u_1_final"], or declare some in [measures]; {listed}')
        return declared
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise SceneError(f'{name}: outputs must be a list of measures\' names, e.g. ["u_1_final"]'
                         f"; {listed}")
    for measure in value:
        if measure not in allowed:
            raise SceneError(f"{name}: outputs: unknown measure {measure!r}; {listed}")
    if len(set(value)) != len(value):
        raise SceneError(f"{name}: outputs names a measure twice")
    return tuple(value)


def campaign(study: Study, text: str | None = None, keep: Path | None = None,
             base: tuple[dict, str] | None = None) -> Campaign:
    """The points, sweep and measures of a checked study (SceneError, one line, for a mistake
    in its own keys); ``base``: its base scene's data and source, as a directory keeps them."""
    from rodfem.studies.sweep import design

    chosen = indices.settings(study.extra, study.name, len(study.parameters))
    plan = indices.plan(study.parameters, **chosen)
    sweep = design.parse(study.sweep_data(plan.values), study.name, base=base)
    return Campaign(study, plan, sweep, outputs(study.extra.get("outputs"), study.name,
                                                sweep.declared), text, keep)


def prepare(spec) -> Campaign:
    """The campaign of a sensitivity file's path or its TOML data (a dict).

    Raises:
        SceneError: the first mistake, on one line; nothing has run.
    """
    if isinstance(spec, dict):
        return campaign(parameters.parse(spec, "<dict>", None, indices.KEYS))
    if not isinstance(spec, (str, Path)):
        raise SceneError("sensitivity: must be a sensitivity file's path or its data as a dict, "
                         f"not {type(spec).__name__}")
    study = parameters.load(spec, indices.KEYS)
    return campaign(study, Path(spec).read_text(encoding="utf-8"), Path(spec))


def sensitivity(study, out: str | Path | None = None, comm: MPI.Comm | None = None, *,
                force: bool = False, progress: bool = False,
                format: str | None = None) -> SensitivityResult:
    """Run a sensitivity study: ``study`` a sensitivity file's path or its TOML data as a dict.
    Into the directory ``out`` (as ``rodfem sensitivity --out``), or in memory with
    ``out=None``. Under mpirun every rank calls it and gets the result. A signal received during
    the call stops it after the runs under way (status interrupted; ``rodfem resume`` continues
    a directory). ``format``: the figure's, png, pdf or svg (default: the base scene's
    ``output.figure_format``, else png).

    Raises:
        SceneError: a mistake in the study (nothing has run, nothing is written).
        rodfem.OutputError: ``out`` cannot be used.
    """
    with interrupts.call():
        return run_campaign(prepare(study), out, comm or MPI.COMM_WORLD, force=force,
                            progress=progress, format=format)


def run_campaign(found: Campaign, out: str | Path | None, comm: MPI.Comm, *,
                 force: bool = False, progress: bool = False,
                 format: str | None = None) -> SensitivityResult:
    """Run a prepared campaign into ``out`` (or in memory), analyse it, and write its files
    (the figure in ``format``, else the base scene's)."""
    from rodfem.studies.sweep.run import run_sweep

    if format is not None:
        from rodfem.output.figures import checked

        found = dataclasses.replace(found, figure_format=checked(format))

    if out is None:
        started = time.perf_counter()
        runs = run_sweep(found.sweep, None, comm, progress=progress)
        return _analysed(found, runs, None, comm, time.perf_counter() - started)
    out = Path(out)
    from rodfem.output.directories import prepare_directory
    from rodfem.output.files import write_json, write_text
    from rodfem.studies.sweep.files import meta as sweep_meta

    written = meta(found, sweep_meta(found.sweep, False))
    with interrupts.deferred():  # marked with its sensitivity.json, which resume reads
        prepare_directory(out, force, comm, keep=found.keep, command="sensitivity", files=FILES)
        if found.text is not None:
            write_text(out / "sensitivity.toml", found.text, comm)
        write_json(out / "sensitivity.json", written, comm)
        write_text(out / "samples.csv", samples_text(found.plan), comm)
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    started = time.perf_counter()
    runs = run_sweep(found.sweep, out / "runs", comm, progress=progress)
    return _analysed(found, runs, out, comm, time.perf_counter() - started)


def _analysed(found: Campaign, runs: SweepResult, out: Path | None, comm: MPI.Comm,
              seconds: float, ran: int | None = None) -> SensitivityResult:
    """The indices of a campaign's runs (complete, or as far as they went), with its files
    written (``out``: rank 0) and its marker's final status; ``ran``: how many ran now (None:
    as its sweep's summary says)."""
    # The runs are done: a signal now is taken after the analysis, or after its files, and
    # leaves the campaign interrupted (resume analyses its complete runs again, to the same
    # files); the files written are whole.
    with interrupts.deferred():
        rows, warnings, failed, analysis = [], [], 0, 0.0
        status = runs.status if runs.error is None else "failed"
        if status == "complete" and comm.rank == 0:
            failed = int(np.sum(runs["status"] != "complete"))
            started = time.perf_counter()
            if failed:
                warnings.append(indices.failed_line(failed, len(runs)))
            else:
                rows, warnings = indices.analyse(found.plan, {m: np.asarray(runs[m], dtype=float)
                                                              for m in found.outputs})
            analysis = time.perf_counter() - started
            warnings += coarse_warning(found.sweep, runs)
        ran = len(found.sweep) if ran is None else ran
        if out is not None and comm.rank == 0 and ran != 0:  # a resumed campaign's, this time
            try:
                ran = json.loads((out / "runs" / "summary.json").read_text())["ran_this_time"]
            except (OSError, ValueError, KeyError, TypeError):
                pass
        rows, warnings, failed, analysis, ran = comm.bcast((rows, warnings, failed, analysis, ran),
                                                           root=0)
        error = runs.error
        if status == "complete" and interrupts.agreed(comm) is not None:
            status, rows = "interrupted", []
        if out is not None:
            written, status = _write(out, found, rows, status, comm)
            error = written or error
            if error is not None:
                status = "failed"
        return SensitivityResult(found.plan.method, found.plan.columns, tuple(rows),
                                 tuple(p.key for p in found.plan.parameters), found.outputs,
                                 status, out, tuple(warnings), failed, error,
                                 {"runs": len(found.sweep), "ran": ran, "run_seconds": seconds,
                                  "analysis_seconds": analysis})


def _write(out: Path, found: Campaign, rows: list[dict], status: str,
           comm: MPI.Comm) -> tuple[str | None, str]:
    """sensitivity.csv and its figure (a complete campaign's), and the marker's status (rank
    0). Returns the line of the first file that could not be written, and the status: a stop
    signal as they were written makes it interrupted."""
    from rodfem.output.atomic import io_line, replacing
    from rodfem.output.directories import finish

    error = None
    if comm.rank == 0:
        try:
            if status == "complete":
                with replacing(out / CSV) as file:
                    file.write(indices.text(found.plan.columns, rows))
                if rows:
                    from rodfem.post.sensitivity import plot_indices  # matplotlib, when drawn

                    plot_indices(found.plan.method, rows, figure_path(out, found),
                                 found.plan.parameters, dict(found.sweep.measures))
        except OSError as err:
            error = io_line(err)
    error = comm.bcast(error, root=0)
    if status == "complete" and interrupts.agreed(comm) is not None:
        status = "interrupted"  # a signal as its files were written: taken now
    if comm.rank == 0:
        try:
            finish(out, "failed" if error else status, comm)
        except OSError as err:
            error = error or io_line(err)
    return comm.bcast(error, root=0), status


def figure_path(out: Path, found: Campaign) -> Path:
    """The figure of a campaign in ``out``: sensitivity.png, or .pdf or .svg (its format, else
    the base scene's ``output.figure_format``)."""
    from rodfem.output import figures

    output = found.sweep.base.get("output", {}) if isinstance(found.sweep.base, dict) else {}
    scene = {figures.SCENE_KEY: output.get("figure_format") if isinstance(output, dict) else None}
    return (out / FIGURE).with_suffix("." + figures.chosen(found.figure_format, scene))


def resume(out: Path, comm: MPI.Comm, progress: bool = False,
           format: str | None = None) -> SensitivityResult:
    """Continue the campaign in ``out`` (held by this command with ``reopen``): the runs its
    sweep does not hold, then the analysis; the figure in ``format`` (png, pdf or svg; default:
    the one the study was started with, else the base scene's ``output.figure_format``).

    Raises:
        SceneError: its files are not this version's, were edited, or its runs/ is another
            study's or in use: one line, nothing changed.
    """
    from rodfem.output.directories import OutputError, finish, mark_running, reopen
    from rodfem.studies.sweep.run import load_sweep, run_sweep
    from rodfem.studies.sweep.run import resume as continue_sweep

    written, runs_state = comm.bcast(_checked(out) if comm.rank == 0 else None, root=0)
    if isinstance(written, str):
        raise SceneError(written)
    found = _reread(written)
    from rodfem.output.figures import checked

    # the format asked for now, else the one the study was started with (sensitivity.json)
    found = dataclasses.replace(found, figure_format=checked(format) if format is not None
                                else written.get("figure"))
    runs = out / "runs"
    if runs_state not in (None, "complete"):
        try:
            reopen(runs, comm)
        except OutputError as err:
            raise SceneError(str(err)) from None
    mark_running(out, comm)
    started = time.perf_counter()
    if runs_state is None:  # stopped before its runs began (runs/ perhaps marked, no more)
        try:
            result = run_sweep(found.sweep, runs, comm, force=runs.exists(), progress=progress)
        except OutputError as err:  # runs/ is not rodfem's alone: untouched
            finish(out, "interrupted", comm)  # as it was: resumable once runs/ is rodfem's
            raise SceneError(str(err)) from None
    elif runs_state == "complete":
        result = comm.bcast(load_sweep(runs) if comm.rank == 0 else None, root=0)
        return _analysed(found, result, out, comm, 0.0, ran=0)
    else:
        result = continue_sweep(runs, comm, progress)
    return _analysed(found, result, out, comm, time.perf_counter() - started)


def _checked(out: Path) -> tuple[dict | str, str | None]:
    """``out``'s sensitivity.json, or the line that says why it cannot be resumed; and the state
    of its runs' sweep (None: not begun)."""
    from rodfem.output.directories import state
    from rodfem.studies.sweep.files import read_meta as read_sweep
    from rodfem.studies.sweep.run import check_complete

    runs = out / "runs"
    try:
        written = read_meta(out)
        if not (runs / "sweep.json").exists():  # its runs had not begun (a kill before)
            return written, None
        if read_sweep(runs)["digest"] != written["runs"]:
            raise SceneError(f"{runs} holds the runs of another study; run the study again "
                             "with --force")
        runs_state = state(runs)
        if runs_state == "complete":
            check_complete(runs)
        return written, runs_state
    except SceneError as err:
        return str(err), None


def _reread(written: dict) -> Campaign:
    """The campaign of a directory's sensitivity.json, without its base scene's file (its runs'
    sweep.json keeps that): the points are drawn again, as they were."""
    data, name = written["study"], written["name"]
    fixed = dict(data.get("set", {}))
    study = Study(name, data, written["scene"], fixed,
                  parameters.parameters(data.get("parameters"), name, fixed),
                  {key: data[key] for key in indices.KEYS if key in data})
    from rodfem.studies.sweep.files import meta as sweep_meta

    found = campaign(study, base=(written["base"], written["source"]))
    if sweep_meta(found.sweep, False)["digest"] != written["runs"]:
        raise SceneError(f"{name}: this SALib draws other points than the campaign's "
                         "(samples.csv); run the study again with --force")
    return found


def summary_line(result: SensitivityResult) -> str:
    """What a complete campaign found, in one line."""
    numbers = result.numbers
    kind = "Sobol indices" if result.method == "sobol" else "Morris screening"
    ran = numbers.get("ran", numbers["runs"])
    done = f" ({ran or 'none'} run now)" if ran != numbers["runs"] else ""
    return (f"{numbers['runs']} runs{done} in {numbers['run_seconds']:.2f} s; {kind} of "
            f"{len(set(r['measure'] for r in result.table))} of "
            f"{plural(len(result.outputs), 'measure')} over "
            f"{plural(len(result.parameters), 'parameter')}")

