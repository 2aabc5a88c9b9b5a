"""The dealing of a sweep's scenes to the MPI ranks: a shared counter from which whichever rank
is free takes the next scene, each scene run alone on ``MPI.COMM_SELF`` into its results line,
and a progress line on rank 0.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time

import numpy as np
from mpi4py import MPI

from rodfem.output import interrupts
from rodfem.output import results as table
from rodfem.output.atomic import io_line
from rodfem.output.columns import for_scene
from rodfem.output.measures import measures
from rodfem.studies.sweep.design import Sweep


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

    from rodfem.studies.accuracy.ladder import LadderFailed
    from rodfem.studies.accuracy.run import simulate_to_target

    scene = sweep.scene(index)
    point = sweep.points[index]
    targeted, accuracy = sweep.targeted, None
    try:
        if targeted:  # the mesh and step chosen for the targets; the finest run reported
            scene, result, record = simulate_to_target(scene, None, MPI.COMM_SELF,
                                                       setups=setups)
            accuracy = accuracy_columns(record)
        else:
            result = simulate(scene, None, MPI.COMM_SELF, progress=False, setups=setups)
    except LadderFailed as err:  # a run of the choice failed or was stopped: the scene's
        scene, result = err.scene, err.result
    except (NotConverged, ArithmeticError, RuntimeError, ValueError,
            np.linalg.LinAlgError) as err:  # a set-up that fails: this scene's, not the sweep's
        message = " ".join(f"{type(err).__name__}: {err}".split())
        return Outcome(index, "failed", table.line(index, point, sweep.axes, "failed", {},
                                                   message, sweep.declared, targeted=targeted),
                       None)
    rows = result.history
    summary = result.summary
    names = (column.name for column in for_scene(scene))  # an adaptive run's t, dt and event too
    values = measures({name: rows[:, j] for j, name in enumerate(names)}, scene, summary)
    error = " ".join(summary.get("error", "").split())
    line = table.line(index, point, sweep.axes, result.status, values, error, sweep.declared,
                      run_columns(scene, {**summary, "status": result.status}), targeted,
                      accuracy)
    return Outcome(index, result.status, line, rows if keep_history else None)


def accuracy_columns(record: dict) -> dict:
    """results.csv's accuracy columns of a scene run to its targets
    (:func:`rodfem.output.results.accuracy_names`)."""
    columns = {f"{name}{table.ERROR_SUFFIX}": math.nan if error is None else error
               for name, error in record["errors"].items()}
    return {**columns, table.ACCURACY_MET: int(record["accuracy"]["met"])}


def run_columns(scene, summary: dict) -> dict[str, int]:
    """What results.csv says of a scene's run beside its measures
    (:data:`rodfem.output.results.RUN`): its steps, the steps an adaptive run rejected, and
    whether its fixed step was coarse for its contact
    (:func:`rodfem.model.timescales.coarse_run`)."""
    from rodfem.model.timescales import coarse_run

    return {"steps": int(summary.get("steps", 0)),
            "rejected_steps": int((summary.get("adaptive") or {}).get("rejected", 0)),
            "coarse": int(coarse_run(scene, summary) is not None)}


class Progress:
    """A line every few seconds on rank 0 (on a terminal, or always with ``force``): of the
    scenes run, or with ``doing="checked"`` of the scenes validated before any runs."""

    def __init__(self, total: int, done: int, enabled: bool, every: float = 2.0,
                 doing: str = ""):
        self.total, self.done_before, self.enabled = total, done, enabled
        self.started = self.last = time.perf_counter()
        self.every, self.doing = every, doing

    def update(self, done: int) -> None:
        now = time.perf_counter()
        if not self.enabled or now - self.last < self.every:
            return
        self.last = now
        rate = (done - self.done_before) / max(now - self.started, 1e-9)
        left = (self.total - done) / rate if rate > 0 else float("inf")
        doing = f"{self.doing} " if self.doing else ""
        print(f"sweep: {doing}{done}/{self.total} scenes, {rate:.1f} scenes/s, about "
              f"{left:.0f} s left", file=sys.stderr, flush=True)


def deal(sweep: Sweep, todo: list[int], comm: MPI.Comm, record, keep_history: bool,
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
