"""``rodfem sweep``: many scenes of one sweep file (:mod:`rodfem.studies.sweep.design`), their
measures in one table, across MPI ranks.

**Cost.** Every scene runs in this process, on ``MPI.COMM_SELF``; scenes that share a mesh and
mass share its discretisation and compiled forms (:class:`rodfem.run.SetUps`), so a scene costs
one assembly, one factorisation and its time loop: no process start, no compilation.

**Ranks.** Under ``mpirun -n N`` the ranks take scenes one at a time from a shared counter (an
MPI one-sided fetch-and-add on rank 0, :mod:`rodfem.studies.sweep.dealing`): whichever rank is free
takes the next, so long and short scenes balance. Each rank writes its own journal
(:mod:`rodfem.output.journal`); rank 0 writes ``results.csv`` from the journals, in the sweep's
order. A scene's row depends only on its scene, so the table is the same for any N (but for the
timing ``loop_seconds``).

**Stopping.** A scene that fails (a method that does not converge, values that overflow) is a row
with status ``failed`` and its message. A signal stops every rank after its current scene (that
scene's row says ``interrupted``); ``rodfem resume DIR`` runs the scenes the journals do not hold
as complete or failed, whatever stopped the sweep (a signal, SIGKILL, a full disk), and writes the
table an uninterrupted sweep would have.

The directory (:mod:`rodfem.studies.sweep.files`): ``sweep.toml`` (the file as given),
``sweep.json`` (the sweep and its base scene, resolved: what resume reads, with their digest),
``results.csv``, ``summary.json``, with ``--histories`` ``histories.h5`` (every scene's history,
``/scenes/<index>``), and ``journal/`` until the sweep is complete. Resume refuses a sweep.json
edited since (its digest), or a journal of another sweep (each record carries the digest's start):
a sweep's rows are never mixed with another's.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from mpi4py import MPI

from rodfem.output import interrupts, journal
from rodfem.output import results as table
from rodfem.output.atomic import io_line
from rodfem.output.columns import for_scene
from rodfem.scene import SceneError
from rodfem.studies.sweep import design
from rodfem.studies.sweep.dealing import Outcome, Progress, deal
from rodfem.studies.sweep.design import Sweep
from rodfem.studies.sweep.files import (
    HISTORIES,
    SweepResult,
    check_complete,
    load_sweep,
    meta,
    parsed,
    read_meta,
    reserve_marker,
    result_from,
    tag,
    write_table,
)

__all__ = ["SweepResult", "check_complete", "load_sweep", "resume", "run_sweep"]


def _as_sweep(spec) -> Sweep:
    if isinstance(spec, Sweep):
        return spec
    if isinstance(spec, dict):
        return design.parse(spec, "<dict>")
    if not isinstance(spec, (str, Path)):
        raise SceneError("sweep: must be a sweep file's path or its data as a dict, not "
                         f"{type(spec).__name__}")
    return design.load(spec)


def _validate_all(sweep: Sweep, comm: MPI.Comm, progress: bool = False) -> None:
    """Every scene validated (shared among the ranks) before any runs, with a progress line on
    rank 0 for a long sweep; SceneError on every rank for the first refused. The compiled loops
    the scenes use are built on every rank (:func:`rodfem.solver.compiled.ready_for`):
    KernelUnavailable on every rank if one cannot be."""
    from rodfem.solver.compiled import compiled_kind, ready_for

    error, line = None, Progress(len(sweep), 0, progress and comm.rank == 0, doing="checked")
    kinds = set()
    for i in range(comm.rank, len(sweep), comm.size):
        try:
            kinds.add(compiled_kind(sweep.scene(i)))
        except SceneError as err:
            error = (i, str(err))
            break
        line.update(min(i + comm.size, len(sweep)))  # about where the other ranks are too
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise SceneError(min(errors)[1])
    ready_for(set().union(*comm.allgather(kinds)), comm)


def run_sweep(spec, out: str | Path | None = None, comm: MPI.Comm | None = None, *,
              histories: bool = False, force: bool = False, progress: bool = False,
              text: str | None = None, keep: str | Path | None = None) -> SweepResult:
    """Run a sweep: ``spec`` a sweep file's path, its TOML data as a dict, or a parsed
    :class:`~rodfem.studies.sweep.design.Sweep`. Into the directory ``out`` (as ``rodfem sweep
    --out``), or in memory with ``out=None`` (then ``histories`` keeps every history in the
    result). Under mpirun every rank calls it; every rank gets the table. ``force`` replaces a
    sweep directory, never one that holds the sweep file (``spec``'s path, or ``keep``).

    Raises:
        SceneError: a mistake in the sweep or a scene (nothing has run, nothing is written).
        rodfem.OutputError: ``out`` cannot be used.
    """
    comm = comm or MPI.COMM_WORLD
    sweep = _as_sweep(spec)
    _validate_all(sweep, comm, progress)
    progress_line = Progress(len(sweep), 0, progress and comm.rank == 0)
    if out is None:
        return _warned(sweep, _in_memory(sweep, comm, histories, progress_line), comm)
    out = Path(out)
    from rodfem.output.directories import prepare_directory
    from rodfem.output.files import write_json, write_text

    if isinstance(spec, (str, Path)):
        keep = keep if keep is not None else spec
        text = text if text is not None else Path(spec).read_text(encoding="utf-8")
    written = meta(sweep, histories)  # SceneError before anything is written
    files = (*(["sweep.toml"] if text is not None else []), "sweep.json", table.NAME,
             "summary.json", *([HISTORIES] if histories else []), journal.DIRECTORY)
    # A directory marked is one with its sweep.json, which resume reads: a signal between the
    # two is taken after both.
    with interrupts.deferred():
        prepare_directory(out, force, comm, keep=Path(keep) if keep is not None else None,
                          command="sweep", files=files)
        reserve_marker(out, comm)
        if text is not None:
            write_text(out / "sweep.toml", text, comm)
        write_json(out / "sweep.json", written, comm)
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    return _warned(sweep, _run_into(out, sweep, comm, histories, tag(written), 0, {},
                                    progress_line), comm)


def scene_list(indices: list[int], total: int) -> str:
    """Scenes by index, compactly: "scene 4 of 12", "scenes 2, 3, 5–9 of 12" (three or more in
    a row as a range)."""
    runs: list[list[int]] = []
    for i in sorted(indices):
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    parts = [f"{r[0]}–{r[-1]}" if len(r) >= 3 else ", ".join(map(str, r)) for r in runs]
    return f"scene{'s' if len(indices) > 1 else ''} {', '.join(parts)} of {total}"


def coarse_steps(sweep: Sweep, result: SweepResult) -> tuple[str, ...]:
    """The warnings of the scenes whose fixed step was coarse for their contact (results.csv's
    ``coarse``: :func:`rodfem.model.timescales.coarse_run`): one line for each kind, naming
    every such scene, with the judgement of the one with the fewest steps per contact time."""
    from rodfem.model.timescales import coarse_step

    found: dict[str, tuple[list[int], int, object]] = {}  # kind: (indices, worst, judgement)
    for index, coarse in zip(result.columns.get("index", ()), result.columns.get("coarse", ()),
                             strict=True):
        judged = coarse_step(sweep.scene(int(index))) if coarse == 1 else None
        if judged is None:
            continue
        indices, worst, before = found.get(judged.kind, ([], int(index), judged))
        if judged.steps < before.steps:
            worst, before = int(index), judged
        found[judged.kind] = ([*indices, int(index)], worst, before)
    return tuple(scene_list(indices, len(result))
                 + (f" (the coarsest: scene {worst})" if len(indices) > 1
                    and judged.kind == "elastic" else "")
                 + f": {judged.line}" for indices, worst, judged in found.values())


def accuracy_missed(result: SweepResult) -> str | None:
    """The warning of the scenes whose accuracy targets were not met (results.csv's
    ``accuracy_met`` = 0, complete scenes), naming every one; None: all were met, or the sweep
    holds no measure to a target."""
    met = result.columns.get(table.ACCURACY_MET)
    if met is None:
        return None
    missed = [int(i) for i, m, status in zip(result.columns["index"], met,
                                             result.columns["status"], strict=True)
              if m == 0 and status == "complete"]
    if not missed:
        return None
    return (f"accuracy target not met in {scene_list(missed, len(result))} (results.csv: "
            "accuracy_met = 0; each scene's <measure>_error is its estimate): raise "
            "accuracy.cells_max or accuracy.runs_max, or lower the target")


def coarse_study_line(sweep: Sweep, result: SweepResult, where: str) -> str | None:
    """The one line of a study whose runs are ``sweep`` (``rodfem sensitivity``): how many of
    them were coarse (results.csv's ``coarse``), flagged ``where``, and the fix
    (:func:`rodfem.model.timescales.study_line`); None: none was."""
    from rodfem.model.timescales import coarse_step, study_line

    judged = [coarse_step(sweep.scene(int(index))) for index, coarse in zip(
        result.columns.get("index", ()), result.columns.get("coarse", ()), strict=True)
        if coarse == 1]
    return study_line([j for j in judged if j is not None], len(result), where)


def _warned(sweep: Sweep, result: SweepResult, comm: MPI.Comm) -> SweepResult:
    """``result`` with its :func:`coarse_steps` (judged on rank 0) and
    :func:`accuracy_missed`."""
    lines = comm.bcast(coarse_steps(sweep, result) if comm.rank == 0 else None, root=0)
    return dataclasses.replace(result, coarse_steps=lines,
                               accuracy_missed=accuracy_missed(result))


def sweep(spec, out: str | Path | None = None, comm=None, *, histories: bool = False,
          force: bool = False, progress: bool = False):
    """Run a sweep: ``spec`` a sweep file's path, its TOML data as a dict, or a parsed
    :class:`~rodfem.studies.sweep.design.Sweep`. Into the directory ``out`` (as ``rodfem sweep
    --out``), or in memory with ``out=None`` (then ``histories`` keeps every history in the
    result). Under mpirun every rank calls it; every rank gets the table
    (:class:`~rodfem.studies.sweep.run.SweepResult`). ``force`` replaces a sweep directory, never
    one that holds the sweep file. A signal received during the call stops it (its scenes so far
    kept, ``status`` interrupted), not the next. Scenes that touched the obstacle with a fixed
    step coarse for it warn (:class:`rodfem.CoarseStepWarning`, rank 0), once for each kind.

    Raises:
        SceneError: a mistake in the sweep or a scene (nothing has run, nothing is written).
        rodfem.OutputError: ``out`` cannot be used.
    """
    import warnings

    from rodfem.model.timescales import CoarseStepWarning
    from rodfem.studies.accuracy.ladder import AccuracyWarning

    with interrupts.call():
        result = run_sweep(spec, out, comm, histories=histories, force=force, progress=progress)
    if (comm or MPI.COMM_WORLD).rank == 0:
        for line in result.coarse_steps:
            warnings.warn(line, CoarseStepWarning, stacklevel=2)
        if result.accuracy_missed:
            warnings.warn(result.accuracy_missed, AccuracyWarning, stacklevel=2)
    return result


def _in_memory(sweep: Sweep, comm: MPI.Comm, histories: bool, progress) -> SweepResult:
    kept: list[Outcome] = []
    deal(sweep, list(range(len(sweep))), comm, kept.append, histories, progress)
    every = [o for part in comm.allgather(kept) for o in part]
    lines = {o.index: o.line for o in every}
    status = "complete" if len(lines) == len(sweep) and all(
        o.status != "interrupted" for o in every) else "interrupted"
    return result_from(lines, sweep.axes, status, None,
                       {o.index: (o.history, for_scene(sweep.scene(o.index))) for o in every}
                       if histories else None, sweep.declared, sweep)


def _run_into(out: Path, sweep: Sweep, comm: MPI.Comm, histories: bool, journal_tag: bytes,
              session: int, done: dict, progress) -> SweepResult:
    """Run the scenes not ``done`` into ``out`` (held by this command), then write its table
    and its marker's status. The first file that could not be written is the one named."""
    todo = [i for i in range(len(sweep)) if i not in done]
    log = journal.Journal(out, session, comm.rank, journal_tag)
    progress.done_before = len(done)

    def record(outcome: Outcome) -> None:
        log.append(outcome.index, outcome.line, outcome.history)

    started, ran = time.perf_counter(), 0
    try:
        error, ran = deal(sweep, todo, comm, record, histories, progress)
    finally:
        try:
            log.close()
        except OSError as err:
            error = io_line(err)
    seconds = time.perf_counter() - started
    errors = [e for e in comm.allgather(error) if e]
    ran = comm.allreduce(ran)  # every journal is closed
    _finish(out, sweep, comm, histories, errors, ran, seconds, journal_tag)
    message = errors[0] if errors else None
    result = None
    if comm.rank == 0:
        try:
            result = dataclasses.replace(load_sweep(out), error=message)
        except (OSError, table.ResultsError) as err:  # results.csv itself could not be written
            result = SweepResult({}, sweep.axes, "failed", out, error=message or str(err))
    return comm.bcast(result, root=0)


def _finish(out: Path, sweep: Sweep, comm: MPI.Comm, histories: bool, errors: list[str],
            ran: int, seconds: float, journal_tag: bytes) -> str:
    """Write the table from the journals and the marker's status (rank 0); ``errors`` gets
    what could not be written, after what stopped the sweep. Returns the status."""
    from rodfem.output.directories import finish

    status = "interrupted"
    if comm.rank == 0:
        try:
            status = write_table(out, sweep, histories, ran, seconds, comm.size,
                                 failed_write=bool(errors), tag=journal_tag)
        except OSError as err:
            errors.append(io_line(err))
        if errors:
            status = "failed"
        try:
            finish(out, status, comm)
        except OSError as err:  # the marker says running, and is read as killed
            errors.append(io_line(err))
    status, errors[:] = comm.bcast((status, errors), root=0)
    return status


def resume(out: Path, comm: MPI.Comm, progress: bool = False) -> SweepResult:
    """Continue the sweep in ``out`` (held by this command with ``reopen``): the scenes the
    journals do not hold as complete or failed.

    Raises:
        SceneError: its sweep.json or journal is not this sweep's (edited, or of another
            sweep): one line, nothing changed.
    """
    from rodfem.output.directories import mark_running

    written = read_meta(out)
    sweep = parsed(out, written)
    _validate_all(sweep, comm, progress)
    records = _journal(out, sweep, tag(written), comm)
    done = {i: r for i, r in records.items()
            if table.status(r.line, sweep.axes) in ("complete", "failed")}
    session = comm.bcast(journal.sessions(out) if comm.rank == 0 else None, root=0)
    mark_running(out, comm)
    reserve_marker(out, comm)
    return _warned(sweep, _run_into(out, sweep, comm, bool(written.get("histories")),
                                    tag(written), session, done,
                                    Progress(len(sweep), len(done), progress and comm.rank == 0)),
                   comm)


def _journal(out: Path, sweep: Sweep, journal_tag: bytes, comm: MPI.Comm) -> dict:
    """The whole records of ``out``'s journal, each checked to be a scene of ``sweep`` (on
    every rank); SceneError, one line, for a journal of another sweep."""
    error, records = None, None
    if comm.rank == 0:
        try:
            where = out / journal.DIRECTORY
            if where.is_symlink() or (where.exists() and not where.is_dir()):
                raise journal.JournalError(f"{journal.DIRECTORY} is not the directory of its "
                                           "journal")
            records = journal.read(out, journal_tag)
            cells = len(sweep.axes) + 1
            for i, record in records.items():  # each what sweep.json says it is
                if not 0 <= i < len(sweep) or table.cells(record.line)[:cells] != table.cells(
                        table.line(i, sweep.points[i], sweep.axes, "", {}))[:cells]:
                    raise journal.JournalError(f"its journal holds a scene {i} that is not "
                                               "sweep.json's (was it edited?)")
                table.status(record.line, sweep.axes)  # ResultsError if it has none
        except (journal.JournalError, table.ResultsError) as err:
            error = f"{out}: {err}; run the sweep again with --force"
    error, records = comm.bcast((error, records), root=0)
    if error is not None:
        raise SceneError(error)
    return records
