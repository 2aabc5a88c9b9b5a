"""One simulation of a scene, from set-up to the files of its run directory."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.discrete.discretisation import Discretisation
from rodfem.output import interrupts
from rodfem.output.atomic import io_line
from rodfem.output.checkpoint import RunFiles
from rodfem.output.columns import INDEX, for_scene, readings
from rodfem.output.directories import finish
from rodfem.output.fields import FieldFile
from rodfem.output.files import write_json, write_text
from rodfem.output.history import History
from rodfem.output.measures import Contact
from rodfem.output.pointwise import Pointwise
from rodfem.output.progress import Progress
from rodfem.output.sizes import save_every
from rodfem.scene import Scene
from rodfem.solver.compiled import compiled_loop
from rodfem.solver.errors import NotConverged, NotFinite
from rodfem.solver.linalg import free_garbage
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


STOP_EVERY = 256  # steps between two checks, agreed by all ranks, for a request to stop


@dataclasses.dataclass
class Iterations:
    """The iteration counts of the steps so far (of the history's rows)."""

    total: int = 0
    max: int = 0
    after_first: int = 0  # the sum over the steps n >= 2 (step 1 may be the paper's special one)
    rows: int = 0

    def update(self, steps: np.ndarray, iterations: np.ndarray) -> None:
        if iterations.size:
            self.total += int(iterations.sum())
            self.max = max(self.max, int(iterations.max()))
            self.after_first += int(iterations[steps >= 2].sum())
            self.rows += int(iterations.size)


@dataclasses.dataclass
class RunResult:
    status: str  # complete | failed | interrupted
    summary: dict
    error: NotConverged | None = None
    x: np.ndarray | None = None  # the nodes, in order
    theta: np.ndarray | None = None  # the last step's Θ (shifted temperature) at the nodes
    u: np.ndarray | None = None  # the last step's U at the nodes
    history: np.ndarray | None = None  # the rows of history.h5, for a run without files
    io_error: str | None = None  # a file could not be written: the line that says which
    signal: int | None = None  # the signal that interrupted the run
    fields: tuple | None = None  # keep_fields: (steps, t, {field: values}) of the saves (rank 0)


class InMemory:
    """A run's files when there are none: the history's rows collected, nothing else."""

    def __init__(self):
        self._blocks = []

    def append(self, rows: np.ndarray) -> None:
        self._blocks.append(rows)

    def rows_so_far(self) -> np.ndarray:
        return np.concatenate(self._blocks)


class SetUps:
    """The discretisations of the last few scenes, for the next ones to reuse: a scene of the
    same mesh and mass (:meth:`Discretisation.key`) on the same communicator gets the same
    mesh, spaces and compiled forms, with its own values in the constants; its method then
    assembles and factors its operators once, and nothing is compiled."""

    def __init__(self, size: int = 4):
        self.size = size
        self._kept: dict[tuple, Discretisation] = {}

    def discretisation(self, scene: Scene, comm: MPI.Comm) -> Discretisation:
        key = (comm.py2f(), Discretisation.key(scene))
        disc = self._kept.pop(key, None)
        if disc is None:
            disc = Discretisation(scene, comm)
        else:
            disc.load(scene)
        self._kept[key] = disc  # the most recent last
        while len(self._kept) > self.size:
            del self._kept[next(iter(self._kept))]
        return disc


def simulate(scene: Scene, out: Path | None, comm: MPI.Comm = MPI.COMM_WORLD,
             progress: bool = True, force_progress: bool = False,
             resume: tuple[dict, dict] | None = None, setups: SetUps | None = None,
             keep_fields: bool = False):
    """Run ``scene`` into the (already created) directory ``out``; return a :class:`RunResult`.

    With ``out=None`` nothing is written: the history is returned (``RunResult.history``), and
    with ``keep_fields`` the saved fields too (``RunResult.fields``, on rank 0).
    ``resume``: the checkpoint (arrays, metadata) of ``out`` to continue from
    (:mod:`rodfem.output.checkpoint`). ``setups``: where to find (and keep) a discretisation
    this scene can share with others (:class:`SetUps`). The progress bar is drawn on a terminal
    (``progress``), or always with ``force_progress``: under mpirun, output is not a terminal.

    Signals (Ctrl-C, SIGTERM, SIGHUP, SIGUSR1) stop the run at the end of a step, with its files
    whole and a checkpoint to resume from (:mod:`rodfem.output.interrupts`)."""
    started = time.perf_counter()
    run = Simulation(scene, out, comm, resume, setups, keep_fields)
    on_terminal = sys.stderr.isatty() or force_progress
    bar = Progress(scene.steps, enabled=progress and comm.rank == 0 and on_terminal)
    setup_seconds = time.perf_counter() - started
    with interrupts.deferred():
        status, error = run.loop(bar)
        return run.outcome(status, error, setup_seconds, bar)


class Simulation:
    """One simulation's parts: its set-up (the discretisation, the method, the history and the
    files, a checkpoint's state restored), the time loop with its saves and checkpoints
    (:meth:`loop`), and the outcome written (:meth:`outcome`)."""

    def __init__(self, scene: Scene, out: Path | None, comm: MPI.Comm,
                 resume: tuple[dict, dict] | None, setups: SetUps | None, keep_fields: bool):
        free_garbage(comm)  # the PETSc objects of the runs before (a sweep runs thousands)
        if out is not None and resume is None:
            write_text(out / "scene.toml", scene.to_toml(), comm)
        self.scene, self.out, self.comm, self.resumed = scene, out, comm, bool(resume)
        # a run of its own keeps its operators for the next (rodfem.discrete.cache)
        disc = self.disc = (setups.discretisation(scene, comm) if setups
                            else Discretisation(scene, comm, cache=True))
        method = self.method = make_method(disc)
        self.saving = out is not None or keep_fields
        # the recorded fields as maps of the state, read once: for the fields and the readings
        pointwise = (Pointwise(disc) if self.saving or readings(for_scene(scene))
                     else None)
        self.history = History(disc, pointwise=pointwise)
        meta = resume[1] if resume else {}
        self.files = (RunFiles(out, disc, scene["output.checkpoint"], meta or None, pointwise)
                      if out is not None else None)
        self.rows_out = self.files.history if self.files is not None else InMemory()
        self.kept = (FieldFile(None, disc, pointwise=pointwise)
                     if self.files is None and keep_fields else None)
        self.energy = EnergyMonitor(**meta.get("energy", {}))
        self.iterations = Iterations(**meta.get("iterations", {}))
        self.contact = Contact(**meta.get("contact", {}))  # over every step, whatever rows are kept
        self.steps, self.every, self.dt = scene.steps, save_every(scene), scene["time.dt"]
        self.io_error: list[str] = []
        # the last step whose fields are saved (a resumed run's, from its checkpoint)
        self.saved = meta["saves"][-1][0] if meta.get("saves") else -1
        if resume:
            method.restore(resume[0])
        self.kernel = compiled_loop(method, self.history)
        self.library_version = disc.library_version()
        disc.keep()
        self.loop_before = meta.get("loop_seconds", 0.0)
        self.loop_started = time.perf_counter()

    def flush(self) -> None:
        rows = self.history.take()
        steps_of = np.rint(rows[:, INDEX["t"]] / self.dt).astype(int)
        self.energy.update(steps_of, rows[:, INDEX["energy"]])
        self.iterations.update(steps_of, rows[:, INDEX["iterations"]].astype(int))
        self.contact.update(steps_of, rows[:, INDEX["u_1"]], rows[:, INDEX["sigma_1"]],
                            self.scene["obstacle.gap"])
        self.rows_out.append(rows[steps_of % self.scene["output.history_every"] == 0])

    def state_meta(self) -> dict:
        return {"step": self.method.n, "scene": self.scene.data(), "source": self.scene.source,
                "mpi_ranks": self.comm.size, "energy": dataclasses.asdict(self.energy),
                "iterations": dataclasses.asdict(self.iterations),
                "contact": dataclasses.asdict(self.contact),
                "loop_seconds": self.loop_before + time.perf_counter() - self.loop_started}

    def checkpoint(self, state_valid: bool = True) -> None:
        """The rows and fields so far, and the state to resume from (rank 0 writes; a write
        error is kept, and stops the run at the next agreed step)."""
        if self.files is None or self.io_error:
            return
        self.flush()
        try:
            self.files.checkpoint(self.method.saved_state() if state_valid else None,
                                  self.state_meta())
        except OSError as err:
            self.io_error.append(io_line(err))

    def write_fields(self) -> None:
        method = self.method
        (self.files.fields if self.kept is None else self.kept).write(
            method.n, method.n * self.dt, method.values)

    def save_fields(self) -> None:
        files, n = self.files, self.method.n
        if files is not None or self.kept is not None:
            self.write_fields()
        if files is not None and self.comm.rank == 0 and n > 0 and files.due():
            self.checkpoint()
        self.saved = n

    def observe(self) -> None:
        self.history.record(self.method)
        self.check()
        if self.history.full:
            self.flush()
        n = self.method.n
        if n % self.every == 0 or n == self.steps:
            self.save_fields()

    def check(self, since: int | None = None) -> None:
        """Stop at the first recorded step that is not finite (the rows before it are kept)."""
        history = self.history
        bad = history.first_non_finite(history.count - 1 if since is None else since)
        if bad is not None:
            raise NotFinite(self.method.name, bad[0], bad[0] * self.dt, bad[1])

    def loop(self, bar: Progress) -> tuple[str, NotConverged | None]:
        """The steps to the end, or to a failed step, a request to stop or a write error: the
        status (complete, interrupted or failed) and the failed step's error."""
        method, steps = self.method, self.steps
        try:
            if not self.resumed:
                self.observe()
            n = method.n
            while n < steps:
                if self.kernel is None or method.first_step_special:
                    # the paper's first step (U¹ = U⁰ + Δt P u₁) is the PETSc loop's
                    method.advance()
                    n += 1
                    self.observe()
                else:
                    n = self.compiled_steps(n)
                bar.update(n)
                if interrupts.requested(self.comm, n, STOP_EVERY, also=bool(self.io_error)):
                    return "interrupted", None
        except NotConverged as err:
            return "failed", err
        return "complete", None

    def compiled_steps(self, n: int) -> int:
        """As many steps as fit before the next saved fields (if any are), the end of the
        history's block and the next check the ranks agree on for a request to stop (under
        MPI), in one compiled call; the step reached."""
        history, every, steps = self.history, self.every, self.steps
        chunk = min(steps - n, history.free,
                    every - n % every if self.saving else steps,
                    STOP_EVERY - n % STOP_EVERY if self.comm.size > 1 else steps)
        since = history.count
        try:
            self.kernel.advance(chunk, history.reserve(chunk))
        except NotConverged:
            history.commit(getattr(self.kernel, "done", 0))  # the steps before the failure
            self.check(since)
            raise
        history.commit(chunk)
        self.check(since)
        n += chunk
        if history.full:
            self.flush()
        if n % every == 0 or n == steps:
            self.save_fields()
        return n

    def outcome(self, status: str, error: NotConverged | None, setup_seconds: float,
                bar: Progress) -> RunResult:
        """The run's last files (its last fields, checkpoint, summary and marker) and result."""
        loop_seconds = self.loop_before + time.perf_counter() - self.loop_started
        bar.close()
        files, kept, io_error, method = self.files, self.kept, self.io_error, self.method
        valid = not isinstance(error, NotFinite)
        if status == "interrupted" and io_error:
            status = "failed"
        if self.saved != method.n and valid and (files is not None or kept is not None):
            self.write_fields()  # a failed or interrupted run keeps its last step's fields too
        if files is not None:
            self.checkpoint(valid)
            files.close()
        else:
            self.flush()
        summary = _summary(self.scene, status, error, self.iterations, self.energy,
                           setup_seconds, loop_seconds, self.comm, resumed=self.resumed,
                           dolfinx=self.library_version)
        summary["contact"] = dataclasses.asdict(self.contact)
        if files is not None:
            summary["checkpoint_seconds"] = files.seconds  # rank 0's: it writes them
        if io_error:
            summary["error"] = io_error[0]
        if self.out is not None:
            self.write_summary(summary, status)
        return RunResult(status, summary, error, self.disc.nodes.x.copy(),
                         method.theta.array_r.copy(), method.u.array_r.copy(),
                         self.rows_out.rows_so_far() if files is None else None,
                         io_error[0] if io_error else None, interrupts.signal_received(),
                         kept.kept() if kept is not None else None)

    def write_summary(self, summary: dict, status: str) -> None:
        """summary.json and the marker's final status (a write error is kept; every rank
        returns once rank 0 has written them)."""
        comm, io_error = self.comm, self.io_error
        try:
            write_json(self.out / "summary.json", summary, comm)
            finish(self.out, "failed" if io_error else status, comm)
        except OSError as err:
            io_error.append(io_line(err))
        io_error[:] = comm.bcast(io_error, root=0)
        comm.barrier()


def _summary(scene, status, error, iterations, energy, setup_seconds, loop_seconds, comm,
             resumed: bool, dolfinx: str) -> dict:
    from petsc4py import PETSc

    done = iterations.rows - 1
    summary = {
        "status": status,
        "scene": scene.source,
        "method": scene["solver.method"],
        "obstacle": scene["obstacle.kind"],
        "law": scene["obstacle.law"] if scene["obstacle.kind"] == "elastic" else None,
        "time_scheme": scene["time.scheme"],
        "steps": done,
        "steps_planned": scene.steps,
        # A failed step's iterations count too (it is not in the history).
        "iterations_total": iterations.total + (error.iterations if error else 0),
        "iterations_max": max(iterations.max, error.iterations if error else 0),
        "iterations_mean": float(iterations.after_first / max(1, done - 1)),
        "setup_seconds": setup_seconds,
        "loop_seconds": loop_seconds,
        "us_per_step": 1e6 * loop_seconds / max(1, done),
        "energy_non_increasing": bool(energy.non_increasing()),
        "energy_max_increase": energy.max_increase if done >= 2 else None,
        "mpi_ranks": comm.size,
        "resumed": resumed,
        "versions": {
            "rodfem": rodfem.__version__,
            "dolfinx": dolfinx,
            "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
        },
    }
    if error is not None:
        summary["error"] = str(error)
    return summary
