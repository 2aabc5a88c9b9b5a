"""``rodfem sweep``: many scenes of one sweep file (:mod:`rodfem.studies.design`), their measures
in one table, across MPI ranks.

**Cost.** Every scene runs in this process, on ``MPI.COMM_SELF``; scenes that share a mesh and
mass share its discretisation and compiled forms (:class:`rodfem.run.SetUps`), so a scene costs
one assembly, one factorisation and its time loop: no process start, no compilation.

**Ranks.** Under ``mpirun -n N`` the ranks take scenes one at a time from a shared counter (an
MPI one-sided fetch-and-add on rank 0): whichever rank is free takes the next, so long and short
scenes balance. Each rank writes its own journal (:mod:`rodfem.output.journal`); rank 0 writes
``results.csv`` from the journals, in the sweep's order. A scene's row depends only on its scene,
so the table is the same for any N (but for the timing ``loop_seconds``).

**Stopping.** A scene that fails (a method that does not converge, values that overflow) is a row
with status ``failed`` and its message. A signal stops every rank after its current scene (that
scene's row says ``interrupted``); ``rodfem resume DIR`` runs the scenes the journals do not hold
as complete or failed, whatever stopped the sweep (a signal, SIGKILL, a full disk), and writes the
table an uninterrupted sweep would have.

The directory: ``sweep.toml`` (the file as given), ``sweep.json`` (the sweep and its base scene,
resolved: what resume reads), ``results.csv``, ``summary.json``, with ``--histories``
``histories.h5`` (every scene's history, ``/scenes/<index>``), and ``journal/`` until the sweep is
complete.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from rodfem.output import interrupts, journal
from rodfem.output import results as table
from rodfem.output.atomic import io_line, replacing
from rodfem.output.columns import NAMES as HISTORY_COLUMNS
from rodfem.output.columns import for_scene, named
from rodfem.output.measures import measures
from rodfem.scene import SceneError
from rodfem.studies import design
from rodfem.studies.design import Sweep

FILES = ("sweep.toml", "sweep.json", table.NAME, "summary.json", "histories.h5",
         journal.DIRECTORY)
HISTORIES = "histories.h5"
FORMAT = 1


class Counter:
    """The next scene to take, shared by the ranks of ``comm``: one atomic fetch-and-add on
    rank 0's window per scene (a plain count on one rank)."""

    def __init__(self, comm: MPI.Comm):
        self.comm, self._local = comm, 0
        if comm.size > 1:
            self._memory = np.zeros(1, dtype=np.int64) if comm.rank == 0 else None
            self._window = MPI.Win.Create(self._memory, disp_unit=8, comm=comm)
            self._one, self._got = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)

    def take(self, add: int = 1) -> int:
        """The counter's value before adding ``add`` (0: just read it)."""
        if self.comm.size == 1:
            value, self._local = self._local, self._local + add
            return value
        self._one[0] = add
        self._window.Lock(0, MPI.LOCK_SHARED)
        self._window.Fetch_and_op(self._one, self._got, 0, 0, MPI.SUM)
        self._window.Unlock(0)
        return int(self._got[0])

    def free(self) -> None:
        if self.comm.size > 1:
            self._window.Free()


@dataclasses.dataclass
class Outcome:
    """What one scene gave: its results line and (with histories) its history rows."""

    index: int
    status: str
    line: str
    history: np.ndarray | None


def run_scene(sweep: Sweep, index: int, setups, keep_history: bool) -> Outcome:
    """Run scene ``index`` of ``sweep`` alone (on MPI.COMM_SELF), sharing ``setups``."""
    from rodfem.run import simulate
    from rodfem.solver.errors import NotConverged

    scene = sweep.scene(index)
    point = sweep.points[index]
    try:
        result = simulate(scene, None, MPI.COMM_SELF, progress=False, setups=setups)
    except (NotConverged, ArithmeticError, RuntimeError, ValueError,
            np.linalg.LinAlgError) as err:  # a set-up that fails: this scene's, not the sweep's
        message = " ".join(f"{type(err).__name__}: {err}".split())
        return Outcome(index, "failed", table.line(index, point, sweep.axes, "failed", {},
                                                   message), None)
    rows = result.history
    summary = result.summary
    values = measures({name: rows[:, j] for j, name in enumerate(HISTORY_COLUMNS)}, scene,
                      summary)
    error = " ".join(summary.get("error", "").split())
    line = table.line(index, point, sweep.axes, result.status, values, error)
    return Outcome(index, result.status, line, rows if keep_history else None)


class Progress:
    """A line every few seconds on rank 0 (on a terminal, or always with ``force``)."""

    def __init__(self, total: int, done: int, enabled: bool, every: float = 2.0):
        self.total, self.done_before, self.enabled = total, done, enabled
        self.started = self.last = time.perf_counter()
        self.every = every

    def update(self, done: int) -> None:
        now = time.perf_counter()
        if not self.enabled or now - self.last < self.every:
            return
        self.last = now
        rate = (done - self.done_before) / max(now - self.started, 1e-9)
        left = (self.total - done) / rate if rate > 0 else float("inf")
        print(f"sweep: {done}/{self.total} scenes, {rate:.1f} scenes/s, about {left:.0f} s "
              "left", file=sys.stderr, flush=True)


def _work(sweep: Sweep, todo: list[int], comm: MPI.Comm, record, keep_history: bool,
          progress: Progress) -> tuple[str | None, int]:
    """Deal ``todo`` among the ranks; ``record(outcome)`` keeps each. Returns the line of a
    failed write, if one stopped this rank, and how many scenes this rank recorded."""
    from rodfem.run import SetUps

    counter, setups, error, ran = Counter(comm), SetUps(), None, 0
    started = progress.done_before
    try:
        with interrupts.deferred():
            while interrupts.signal_received() is None:
                k = counter.take()
                if k >= len(todo):
                    break
                outcome = run_scene(sweep, todo[k], setups, keep_history)
                try:
                    record(outcome)
                except OSError as err:
                    error = io_line(err)
                    break
                ran += 1
                if comm.rank == 0:
                    progress.update(started + min(counter.take(0), len(todo)))
            if interrupts.signal_received() is not None or error is not None:
                counter.take(len(todo))  # the other ranks stop after their current scene too
    finally:
        comm.barrier()  # every rank has stopped taking scenes before the window goes
        counter.free()
    return error, ran


@dataclasses.dataclass(frozen=True)
class SweepResult:
    """A sweep's table: ``result["model.k"]``, ``result["u_1_final"]`` are its columns (arrays
    in the sweep's order); ``axes`` are the swept keys; :meth:`history` reads a scene's history
    from ``histories.h5`` (a sweep run with ``--histories``).

    Attributes:
        columns: every column of results.csv by name.
        axes: the swept keys.
        status: complete, or interrupted (a sweep that was stopped; resume continues it), or
            failed (a file could not be written: ``error`` says which).
        path: the sweep directory, or None for a sweep run in memory.
    """

    columns: dict[str, np.ndarray]
    axes: tuple[str, ...]
    status: str
    path: Path | None = None
    _histories: dict[int, tuple] | None = None  # in memory: the rows and their columns
    error: str | None = None  # a file that could not be written, which stopped the sweep

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["index"])

    def history(self, index: int) -> np.ndarray:
        """The history of scene ``index`` as a structured array (as :attr:`rodfem.Result.history`).

        Raises:
            KeyError: the sweep kept no histories, or none for that scene.
        """
        from rodfem.api import named_history

        if self._histories is not None:
            return named_history(*self._histories[index])
        if self.path is None or not (self.path / HISTORIES).is_file():
            raise KeyError(f"no histories kept (run the sweep with --histories): scene {index}")
        import h5py

        with h5py.File(self.path / HISTORIES, "r") as file:
            name = f"scenes/{index}"
            if name not in file:
                raise KeyError(f"{self.path / HISTORIES} has no history of scene {index}")
            data = file[name]
            names = data.attrs.get("columns", file.attrs["columns"])
            return named_history(data[...], named(str(names).split(",")))


def _result_from(lines: dict[int, str], axes, status, path=None, histories=None) -> SweepResult:
    _, columns = table.parse(table.text(axes, [lines[i] for i in sorted(lines)]))
    return SweepResult(columns, tuple(axes), status, path, histories)


def _as_sweep(spec) -> Sweep:
    if isinstance(spec, Sweep):
        return spec
    if isinstance(spec, dict):
        return design.parse(spec, "<dict>")
    if not isinstance(spec, (str, Path)):
        raise SceneError("sweep: must be a sweep file's path or its data as a dict, not "
                         f"{type(spec).__name__}")
    return design.load(spec)


def _validate_all(sweep: Sweep, comm: MPI.Comm) -> None:
    """Every scene validated (shared among the ranks) before any runs; SceneError on every rank
    for the first refused."""
    error = None
    for i in range(comm.rank, len(sweep), comm.size):
        try:
            sweep.scene(i)
        except SceneError as err:
            error = (i, str(err))
            break
    errors = [e for e in comm.allgather(error) if e is not None]
    if errors:
        raise SceneError(min(errors)[1])


def run_sweep(spec, out: str | Path | None = None, comm: MPI.Comm | None = None, *,
              histories: bool = False, force: bool = False, progress: bool = False,
              text: str | None = None) -> SweepResult:
    """Run a sweep: ``spec`` a sweep file's path, its TOML data as a dict, or a parsed
    :class:`~rodfem.studies.design.Sweep`. Into the directory ``out`` (as ``rodfem sweep
    --out``), or in memory with ``out=None`` (then ``histories`` keeps every history in the
    result). Under mpirun every rank calls it; every rank gets the table.

    Raises:
        SceneError: a mistake in the sweep or a scene (nothing has run).
        rodfem.OutputError: ``out`` cannot be used.
    """
    comm = comm or MPI.COMM_WORLD
    sweep = _as_sweep(spec)
    _validate_all(sweep, comm)
    progress_line = Progress(len(sweep), 0, progress and comm.rank == 0)
    if out is None:
        return _in_memory(sweep, comm, histories, progress_line)
    out = Path(out)
    from rodfem.output.directories import prepare_directory
    from rodfem.output.files import write_json, write_text

    if text is None and isinstance(spec, (str, Path)):
        text = Path(spec).read_text(encoding="utf-8")
    # A directory marked is one with its sweep.json, which resume reads: a signal between the
    # two is taken after both.
    with interrupts.deferred():
        prepare_directory(out, force, comm, command="sweep", files=FILES)
        if text is not None:
            write_text(out / "sweep.toml", text, comm)
        write_json(out / "sweep.json", {
            "format": FORMAT, "name": sweep.name, "sweep": sweep.data, "base": sweep.base,
            "source": sweep.source, "axes": list(sweep.axes), "design": sweep.design,
            "grid": sweep.grid, "histories": histories, "scenes": len(sweep)}, comm)
    if interrupts.signal_received() is not None:
        raise interrupts.Interrupted(interrupts.signal_received())
    return _run_into(out, sweep, comm, histories, 0, {}, progress_line)


def _in_memory(sweep: Sweep, comm: MPI.Comm, histories: bool, progress) -> SweepResult:
    kept: list[Outcome] = []
    _work(sweep, list(range(len(sweep))), comm, kept.append, histories, progress)
    every = [o for part in comm.allgather(kept) for o in part]
    lines = {o.index: o.line for o in every}
    status = "complete" if len(lines) == len(sweep) and all(
        o.status != "interrupted" for o in every) else "interrupted"
    return _result_from(lines, sweep.axes, status, None,
                        {o.index: (o.history, for_scene(sweep.scene(o.index))) for o in every}
                        if histories else None)


def _run_into(out: Path, sweep: Sweep, comm: MPI.Comm, histories: bool, session: int,
              done: dict, progress) -> SweepResult:
    """Run the scenes not ``done`` into ``out`` (held by this command), then write its table."""
    from rodfem.output.directories import finish

    todo = [i for i in range(len(sweep)) if i not in done]
    log = journal.Journal(out, session, comm.rank)
    progress.done_before = len(done)

    def record(outcome: Outcome) -> None:
        log.append(outcome.index, outcome.line, outcome.history)

    started, ran = time.perf_counter(), 0
    try:
        error, ran = _work(sweep, todo, comm, record, histories, progress)
    finally:
        try:
            log.close()
        except OSError as err:
            error = io_line(err)
    seconds = time.perf_counter() - started
    errors = [e for e in comm.allgather(error) if e]
    ran = comm.allreduce(ran)  # every journal is closed
    status, message = "interrupted", None
    if comm.rank == 0:
        try:
            status = _write_table(out, sweep, histories, ran, seconds, comm.size,
                                  failed_write=bool(errors))
        except OSError as err:
            errors.append(io_line(err))
    status, errors = comm.bcast((status, errors), root=0)
    if errors:
        message = errors[0]
        status = "failed"
    finish(out, status, comm)
    result = None
    if comm.rank == 0:
        try:
            result = dataclasses.replace(load_sweep(out), error=message)
        except (OSError, table.ResultsError) as err:  # results.csv itself could not be written
            result = SweepResult({}, sweep.axes, "failed", out, error=message or str(err))
    return comm.bcast(result, root=0)


def _write_table(out: Path, sweep: Sweep, histories: bool, ran: int, seconds: float,
                 ranks: int, failed_write: bool) -> str:
    """results.csv (and histories.h5, summary.json) from the journals (rank 0). Returns the
    sweep's status."""
    records = journal.read(out)
    lines = [records[i].line for i in sorted(records)]
    counts = {s: 0 for s in table.STATUSES}
    for record in records.values():
        counts[table.status(record.line, sweep.axes)] += 1
    complete = (len(records) == len(sweep) and counts["interrupted"] == 0 and not failed_write)
    with replacing(out / table.NAME) as file:
        file.write(table.text(sweep.axes, lines))
    if complete and histories:
        _write_histories(out / HISTORIES, records, sweep)
    status = "complete" if complete else "interrupted"
    summary = {"status": status, "scenes": len(sweep), "recorded": len(records),
               **{f"scenes_{s}": n for s, n in counts.items()},
               "ran_this_time": ran, "seconds": seconds,
               "scenes_per_second": ran / seconds if seconds > 0 else None,
               "mpi_ranks": ranks}
    with replacing(out / "summary.json") as file:
        json.dump(summary, file, indent=2)
        file.write("\n")
    if complete:
        journal.remove(out)  # all of it is in the table
    return status


def _write_histories(path: Path, records: dict[int, journal.Record], sweep) -> None:
    """histories.h5, whole or not at all. HDF5 closing a file on a full disk can crash the
    process (h5py 3.7: a segmentation fault in H5F__close_cb), so the room is checked first and
    a disk without it is the OSError any full disk is."""
    import errno

    import h5py

    need = sum(8 * r.rows * r.columns + 4096 for r in records.values()) + 2**20
    if shutil.disk_usage(path.parent).free < need:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    part = path.with_name(f".{path.name}.{os.getpid()}")
    try:
        with h5py.File(part, "w") as file:
            file.attrs["columns"] = ",".join(HISTORY_COLUMNS)
            group = file.create_group("scenes")
            for i in sorted(records):
                rows = records[i].history()
                if rows is not None:
                    dataset = group.create_dataset(str(i), data=rows)
                    # the scene's own columns: the default ones, then what its [output] adds
                    dataset.attrs["columns"] = ",".join(c.name for c in for_scene(sweep.scene(i)))
        with open(part, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise


def load_sweep(path: str | Path) -> SweepResult:
    """The table of a sweep directory (complete or stopped: the rows it has)."""
    from rodfem.output.directories import state

    path = Path(path)
    if journal.exists(path):  # stopped: its rows are in the journal
        axes = _parsed(path, _meta(path)).axes
        records = journal.read(path)
        return _result_from({i: r.line for i, r in records.items()}, axes,
                            state(path) or "interrupted", path)
    axes, columns = table.read(path / table.NAME)
    return SweepResult(columns, axes, state(path) or "complete", path)


KEYS = {"name": str, "sweep": dict, "base": dict, "source": str, "histories": bool}


def _meta(out: Path) -> dict[str, Any]:
    try:
        meta = json.loads((out / "sweep.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise SceneError(f"{out}: no readable sweep.json ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise SceneError(f"{out}/sweep.json is not one this version of rodfem reads")
    for key, kind in KEYS.items():
        if not isinstance(meta.get(key), kind):
            raise SceneError(f"{out}/sweep.json: '{key}' is missing or not a {kind.__name__} "
                             "(was it edited?)")
    return meta


def _parsed(out: Path, meta: dict) -> Sweep:
    """The sweep of a directory's sweep.json (SceneError, one line, if it is not one)."""
    try:
        return design.parse(meta["sweep"], meta["name"], base=(meta["base"], meta["source"]))
    except (KeyError, TypeError, AttributeError, IndexError) as err:
        raise SceneError(f"{out}/sweep.json is not a sweep's ({type(err).__name__}: {err})") \
            from None


def resume(out: Path, comm: MPI.Comm, progress: bool = False) -> SweepResult:
    """Continue the sweep in ``out`` (held by this command with ``reopen``): the scenes the
    journals do not hold as complete or failed."""
    from rodfem.output.directories import mark_running

    meta = _meta(out)
    sweep = _parsed(out, meta)
    _validate_all(sweep, comm)
    records = journal.read(out) if comm.rank == 0 else None
    records = comm.bcast(records, root=0)
    for i, record in records.items():  # each what sweep.json says it is
        expected = table.line(i, sweep.points[i], sweep.axes, "", {}) if i < len(sweep) else ""
        cells = len(sweep.axes) + 1
        if next(csv.reader([record.line]))[:cells] != next(csv.reader([expected]))[:cells]:
            raise SceneError(f"{out}: its journal holds a scene {i} that is not sweep.json's "
                             "(was it edited?); run the sweep again with --force")
    done = {i: r for i, r in records.items()
            if table.status(r.line, sweep.axes) in ("complete", "failed")}
    session = comm.bcast(journal.sessions(out) if comm.rank == 0 else None, root=0)
    mark_running(out, comm)
    return _run_into(out, sweep, comm, bool(meta.get("histories")), session, done,
                     Progress(len(sweep), len(done), progress and comm.rank == 0))
