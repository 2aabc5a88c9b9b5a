"""One simulation of a scene, from set-up to the files of its run directory."""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import sys
import threading
import time
from pathlib import Path

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

import rodfem
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.columns import INDEX
from rodfem.output.directories import finish
from rodfem.output.files import FieldFile, HistoryFile, write_json, write_text
from rodfem.output.history import History
from rodfem.output.progress import Progress
from rodfem.scene import Scene
from rodfem.solver.compiled import compiled_loop
from rodfem.solver.errors import NotConverged
from rodfem.solver.methods import make_method

# Êⁿ is non-increasing in exact arithmetic (Remark 4.4). An increase counts only if it exceeds the
# round-off of Ê, a sum of a few O(max |Ê|) terms each good to a few ulps.
ENERGY_ROUNDOFF = 64 * np.finfo(float).eps


@dataclasses.dataclass
class EnergyMonitor:
    """Tracks max_{n ≥ 2} (Êⁿ − Êⁿ⁻¹) over the rows of a run."""

    last: float = np.nan
    max_increase: float = -np.inf
    scale: float = 0.0
    finite: bool = True

    def update(self, steps: np.ndarray, energy: np.ndarray) -> None:
        if steps.size == 0:
            return
        if not np.isfinite(energy).all():
            self.finite = False
            return
        previous = np.concatenate([[self.last], energy[:-1]])
        judged = steps >= 2
        if judged.any():
            self.max_increase = max(self.max_increase, float(np.max((energy - previous)[judged])))
        self.scale = max(self.scale, float(np.max(np.abs(energy))))
        self.last = float(energy[-1])

    def non_increasing(self) -> bool:
        return self.finite and self.max_increase <= ENERGY_ROUNDOFF * self.scale


@contextlib.contextmanager
def stop_requests(comm: MPI.Comm, every: int = 256):
    """Turn Ctrl-C (SIGINT) or SIGUSR1 into a request to stop at the end of a step, so that
    nothing is written half.

    Yields a function ``requested(n)``; under MPI the ranks agree on it every ``every`` steps, so
    they stop at the same step. (Open MPI's mpirun kills the ranks on Ctrl-C but forwards SIGUSR1:
    ``kill -USR1 <pid of mpirun>`` stops a parallel run cleanly.)"""
    flag = [False]
    installed = threading.current_thread() is threading.main_thread()
    signals = (signal.SIGINT, signal.SIGUSR1)
    if installed:
        previous = [signal.signal(s, lambda *_: flag.__setitem__(0, True)) for s in signals]

    def requested(n: int) -> bool:
        if comm.size == 1:
            return flag[0]
        return n % every == 0 and comm.allreduce(flag[0], op=MPI.LOR)

    try:
        yield requested
    finally:
        if installed:
            for s, handler in zip(signals, previous, strict=True):
                signal.signal(s, handler)


STOP_EVERY = 256  # steps between two checks, agreed by all ranks, for a request to stop


@dataclasses.dataclass
class RunResult:
    status: str  # complete | failed | interrupted
    summary: dict
    error: NotConverged | None = None
    x: np.ndarray | None = None  # the nodes, in order
    theta: np.ndarray | None = None  # the last step's Θ (shifted temperature) at the nodes
    u: np.ndarray | None = None  # the last step's U at the nodes
    history: np.ndarray | None = None  # the rows of history.csv, for a run without files


class InMemory:
    """Collects the history's rows instead of writing them."""

    def __init__(self):
        self._blocks = []

    def append(self, rows: np.ndarray) -> None:
        self._blocks.append(rows)

    def close(self) -> None:
        self.rows = np.concatenate(self._blocks)


def simulate(scene: Scene, out: Path | None, comm: MPI.Comm = MPI.COMM_WORLD,
             progress: bool = True, force_progress: bool = False):
    """Run ``scene`` into the (already created) directory ``out``; return a :class:`RunResult`.

    With ``out=None`` nothing is written: the history is returned (``RunResult.history``).
    The progress bar is drawn on a terminal (``progress``), or always with ``force_progress``:
    under mpirun, output is not a terminal."""
    started = time.perf_counter()
    if out is not None:
        write_text(out / "scene.toml", scene.to_toml(), comm)
    disc = Discretisation(scene, comm)
    method = make_method(disc)
    history = History(disc)
    history_file = HistoryFile(out / "history.csv", comm) if out is not None else InMemory()
    field_file = FieldFile(out / "fields.xdmf", disc) if out is not None else None
    energy = EnergyMonitor()
    steps, every, dt = scene.steps, scene["output.every"], scene["time.dt"]
    on_terminal = sys.stderr.isatty() or force_progress
    bar = Progress(steps, enabled=progress and comm.rank == 0 and on_terminal)
    iterations = []

    def flush() -> None:
        rows = history.take()
        history_file.append(rows)
        energy.update(np.rint(rows[:, INDEX["t"]] / dt).astype(int), rows[:, INDEX["energy"]])
        iterations.extend(rows[:, INDEX["iterations"]].astype(int).tolist())

    saved = [-1]

    def save_fields() -> None:
        if field_file is not None:
            field_file.write(method.n * dt, method.theta, method.u, method.velocity_back)
        saved[0] = method.n

    def observe() -> None:
        history.record(method)
        if history.full:
            flush()
        if method.n % every == 0 or method.n == steps:
            save_fields()

    kernel = compiled_loop(method, history)
    setup_seconds = time.perf_counter() - started
    status, error = "complete", None
    loop_started = time.perf_counter()
    with stop_requests(comm, STOP_EVERY) as stop_requested:
        try:
            observe()
            n = 0
            while n < steps:
                if kernel is None or method.first_step_special:
                    # the paper's first step (U¹ = U⁰ + Δt P u₁) is the PETSc loop's
                    method.advance()
                    n += 1
                    observe()
                else:
                    # As many steps as fit before the next saved fields, the end of the history's
                    # block and the next check for a stop request, in one compiled call.
                    chunk = min(steps - n, every - n % every, history.free,
                                STOP_EVERY - n % STOP_EVERY)
                    try:
                        kernel.advance(chunk, history.reserve(chunk))
                    except NotConverged:
                        history.commit(getattr(kernel, "done", 0))  # the steps before the failure
                        raise
                    history.commit(chunk)
                    n += chunk
                    if history.full:
                        flush()
                    if n % every == 0 or n == steps:
                        save_fields()
                bar.update(n)
                if stop_requested(n):
                    status = "interrupted"
                    break
        except NotConverged as err:
            status, error = "failed", err
    loop_seconds = time.perf_counter() - loop_started
    bar.close()
    if saved[0] != method.n:  # a failed or interrupted run keeps its last step's fields too
        save_fields()
    flush()
    history_file.close()
    if field_file is not None:
        field_file.close()
    done = len(iterations) - 1
    summary = {
        "status": status,
        "scene": scene.source,
        "method": scene["solver.method"],
        "obstacle": scene["obstacle.kind"],
        "steps": done,
        "steps_planned": steps,
        # A failed step's iterations count too (it is not in the history).
        "iterations_total": int(sum(iterations)) + (error.iterations if error else 0),
        "iterations_max": int(max(iterations + ([error.iterations] if error else []))),
        "iterations_mean": float(sum(iterations[2:]) / max(1, done - 1)),
        "setup_seconds": setup_seconds,
        "loop_seconds": loop_seconds,
        "us_per_step": 1e6 * loop_seconds / max(1, done),
        "energy_non_increasing": bool(energy.non_increasing()),
        "energy_max_increase": energy.max_increase if done >= 2 else None,
        "mpi_ranks": comm.size,
        "versions": {
            "rodfem": rodfem.__version__,
            "dolfinx": dolfinx.__version__,
            "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
        },
    }
    if error is not None:
        summary["error"] = str(error)
    if out is not None:
        write_json(out / "summary.json", summary, comm)
        finish(out, status, comm)
        comm.barrier()  # every rank returns once rank 0 has written the run's files
    return RunResult(status, summary, error, disc.nodes.x.copy(), method.theta.array_r.copy(),
                     method.u.array_r.copy(), getattr(history_file, "rows", None))
