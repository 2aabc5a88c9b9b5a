"""One simulation of a scene, from set-up to the files of its run directory."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.discretisation import Discretisation
from rodfem.output import interrupts
from rodfem.parallel import world
from rodfem.output.atomic import io_line
from rodfem.output.checkpoint import RunFiles
from rodfem.output.columns import INDEX, for_scene, readings
from rodfem.output.directories import finish
from rodfem.output.fields import FieldFile
from rodfem.output.files import write_json, write_text
from rodfem.output.history import History
from rodfem.output.measures import Contact, measures
from rodfem.output.pointwise import Pointwise
from rodfem.output.progress import Progress
from rodfem.output.reductions import Reductions
from rodfem.output.sizes import frame, save_every, save_interval
from rodfem.output.summary import EnergyMonitor, Iterations, run_summary
from rodfem.scene import Scene
from rodfem.solver.compiled import compiled_kind, compiled_loop, loop_name, loops_of
from rodfem.solver.errors import NotConverged, NotFinite
from rodfem.solver.linalg import free_garbage
from rodfem.solver.methods import make_method

if TYPE_CHECKING:
    from mpi4py import MPI

STOP_EVERY = 256  # steps between two checks, agreed by all ranks, for a request to stop


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


def simulate(scene: Scene, out: Path | None, comm: MPI.Comm | None = None,
             progress: bool = True, force_progress: bool = False,
             resume: tuple[dict, dict] | None = None, setups: SetUps | None = None,
             keep_fields: bool = False, annotate: dict | None = None):
    """Run ``scene`` into the (already created) directory ``out``; return a :class:`RunResult`.

    With ``out=None`` nothing is written: the history is returned (``RunResult.history``), and
    with ``keep_fields`` the saved fields too (``RunResult.fields``, on rank 0).
    ``resume``: the checkpoint (arrays, metadata) of ``out`` to continue from
    (:mod:`rodfem.output.checkpoint`). ``setups``: where to find (and keep) a discretisation
    this scene can share with others (:class:`SetUps`). ``annotate``: entries added to the
    summary (an accuracy target's estimates: :mod:`rodfem.studies.accuracy`). The progress bar
    is drawn on a terminal (``progress``), or always with ``force_progress``: under mpirun,
    output is not a terminal.

    Signals (Ctrl-C, SIGTERM, SIGHUP, SIGUSR1) stop the run at the end of a step, with its files
    whole and a checkpoint to resume from (:mod:`rodfem.output.interrupts`). ``comm``: MPI's
    COMM_WORLD by default (in a process no launcher started, a world without MPI:
    :func:`rodfem.parallel.world`)."""
    started = time.perf_counter()
    if comm is None:
        comm = world()
    run = Simulation(scene, out, comm, resume, setups, keep_fields)
    run.annotate = annotate or {}
    on_terminal = sys.stderr.isatty() or force_progress
    enabled = progress and comm.rank == 0 and on_terminal
    bar = (Progress(scene["time.end"], enabled, of_time=True) if scene.adaptive
           else Progress(scene.steps, enabled))
    setup_seconds = time.perf_counter() - started
    with interrupts.deferred():
        status, error = run.loop(bar)
        return run.outcome(status, error, setup_seconds, bar)


def numpy_run(scene: Scene, comm: MPI.Comm) -> bool:
    """Whether a run's operators and state can be NumPy's (:mod:`rodfem.discrete.arrays`): on
    one rank, with steps that a compiled loop takes (:func:`compiled_kind`), fixed or adaptive,
    and a constant heat exchange, so that PETSc would do nothing but hold arrays (the paper
    scheme's first step, the first rows and the adaptive stepper's hand-over and estimate, done
    in NumPy with PETSc's arithmetic). The PETSc loops and parallel runs keep PETSc's objects."""
    return (comm.size == 1 and compiled_kind(scene) is not None
            and scene["heat_exchange.law"] == "constant")


class Simulation:
    """One simulation's parts: its set-up (the discretisation, the method, the history and the
    files, a checkpoint's state restored), the time loop with its saves and checkpoints
    (:meth:`loop`), and the outcome written (:meth:`outcome`)."""

    annotate: dict = {}  # entries added to the summary (simulate's)

    def __init__(self, scene: Scene, out: Path | None, comm: MPI.Comm,
                 resume: tuple[dict, dict] | None, setups: SetUps | None, keep_fields: bool):
        free_garbage(comm)  # the PETSc objects of the runs before (a sweep runs thousands)
        if out is not None and resume is None:
            write_text(out / "scene.toml", scene.to_toml(), comm)
        self.scene, self.out, self.comm, self.resumed = scene, out, comm, bool(resume)
        # a run of its own keeps its operators for the next (rodfem.discrete.cache), in NumPy
        # where PETSc takes none of its steps
        disc = self.disc = (setups.discretisation(scene, comm) if setups
                            else Discretisation(scene, comm, cache=True,
                                                petsc=not numpy_run(scene, comm)))
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
        self.reductions = Reductions(scene.measures, meta.get("reductions"))  # the same
        last = meta.get("last_row")  # the last step's row, for the measures
        self.last_row = np.array([last]) if last is not None else None
        self.steps, self.every, self.dt = scene.steps, save_every(scene), scene["time.dt"]
        self.io_error: list[str] = []
        # the last step whose fields are saved (a resumed run's, from its checkpoint), and with
        # adaptive steps the save interval of its time (fields are saved by time)
        self.saved = meta["saves"][-1][0] if meta.get("saves") else -1
        self.interval = save_interval(scene) if scene.adaptive else None
        self.frame = (frame(meta["saves"][-1][1], self.interval)
                      if self.interval and meta.get("saves") else -1)
        if resume:
            method.restore(resume[0])
        self.kernel = compiled_loop(method, self.history)
        self.regular = None  # adaptive steps' regular ones in compiled code, where a loop is
        self.loops = loops_of(meta if resume else None, method.n, loop_name(scene))
        self.stepper = self._stepper(resume) if scene.adaptive else None
        self.library_version = disc.library_version()
        self.petsc_version = disc.petsc_version()
        disc.keep()
        self.loop_before = meta.get("loop_seconds", 0.0)
        self.loop_started = time.perf_counter()

    def _stepper(self, resume):
        """Adaptive steps (:mod:`rodfem.solver.adaptive`): for each new step size a compiled
        loop formed from the operators' parts and bound to the run's method
        (:mod:`rodfem.solver.compiled.family`), or where there is none a method (and compiled
        loop) made for it."""
        from rodfem.solver.adaptive.stepper import AdaptiveStepper
        from rodfem.solver.compiled.families import step_family

        disc, history, kernel = self.disc, self.history, self.kernel
        family = step_family(self.method, history, kernel)

        def make(h: float, once: bool):
            if family is not None:
                return self.method, family.loop(h)
            with disc.at_step(h):
                method = make_method(disc, h)
            if kernel is None:
                return method, None
            return method, compiled_loop(method, history, compress=not once)

        stepper = AdaptiveStepper(self.method, self.scene, make, kernel, self.record_step,
                                  history.width)
        if resume:
            stepper.restore(resume[0], resume[1].get("adaptive"))
        if kernel is not None:
            from rodfem.solver.adaptive.compiled import CompiledSteps

            self.regular = CompiledSteps(stepper, history, family)
        return stepper

    def time(self) -> float:
        """The time of the method's state."""
        return self.stepper.t if self.stepper is not None else self.method.n * self.dt

    def saved_state(self) -> dict:
        """The method's state and, with adaptive steps, the controller's."""
        saved = self.method.saved_state()
        return saved if self.stepper is None else {**saved, **self.stepper.saved()}

    def flush(self) -> None:
        rows = self.history.take()
        steps_of = self.history.steps
        self.energy.update(steps_of, rows[:, INDEX["energy"]])
        self.iterations.update(steps_of, rows[:, INDEX["iterations"]].astype(int))
        names = [column.name for column in self.history.columns]
        event = rows[:, names.index("event")] if "event" in names else None
        self.contact.update(steps_of, rows[:, INDEX["u_1"]], rows[:, INDEX["sigma_1"]],
                            self.scene["obstacle.gap"], t=rows[:, INDEX["t"]], event=event)
        self.reductions.update(rows[:, INDEX["t"]], {name: rows[:, j] for j, name in
                                                     enumerate(names)})
        if len(rows):  # the last step's row, kept or not, for the final values
            self.last_row = rows[-1:].copy()
        self.rows_out.append(rows[steps_of % self.scene["output.history_every"] == 0])

    def state_meta(self) -> dict:
        return {"step": self.method.n, "scene": self.scene.data(), "source": self.scene.source,
                "mpi_ranks": self.comm.size, "energy": dataclasses.asdict(self.energy),
                "iterations": dataclasses.asdict(self.iterations),
                "contact": dataclasses.asdict(self.contact),
                "reductions": self.reductions.saved(),
                "last_row": None if self.last_row is None else self.last_row[0].tolist(),
                "loop_seconds": self.loop_before + time.perf_counter() - self.loop_started,
                "loops": self.loops,
                **({} if self.stepper is None else
                   {"adaptive": {"rejected": self.stepper.rejected,
                                 "events": self.stepper.events}})}

    def checkpoint(self, state_valid: bool = True) -> None:
        """The rows and fields so far, and the state to resume from (rank 0 writes; a write
        error is kept, and stops the run at the next agreed step)."""
        if self.files is None or self.io_error:
            return
        self.flush()
        try:
            self.files.checkpoint(self.saved_state() if state_valid else None,
                                  self.state_meta())
        except OSError as err:
            self.io_error.append(io_line(err))

    def write_fields(self) -> None:
        method = self.method
        (self.files.fields if self.kept is None else self.kept).write(
            method.n, self.time(), method.values)

    def save_fields(self, resumable: bool = True) -> None:
        """The fields of the step reached, and a checkpoint when one is due and the state is
        one to resume from (``resumable``)."""
        files, n = self.files, self.method.n
        if files is not None or self.kept is not None:
            self.write_fields()
        if files is not None and self.comm.rank == 0 and n > 0 and resumable and files.due():
            self.checkpoint()
        self.saved = n
        if self.interval is not None:
            self.frame = frame(self.time(), self.interval)

    def observe(self) -> None:
        self.history.record(self.method, (0.0, 0.0, 0.0) if self.stepper else None)
        self.check()
        if self.history.full:
            self.flush()
        n = self.method.n
        if n % self.every == 0 or n == self.steps:
            self.save_fields()

    def record_step(self, h: float, event: bool, whole: bool) -> None:
        """An adaptive step's row, and its fields when due: at the first step of each save
        interval (:func:`rodfem.output.sizes.save_interval`); a checkpoint only where the
        stepper's state is ``whole`` (:mod:`rodfem.solver.adaptive.stepper`)."""
        t = self.stepper.t
        self.history.record(self.method, (t, h, float(event)))
        self.check()
        if self.history.full:
            self.flush()
        if frame(t, self.interval) > self.frame:
            self.save_fields(whole)

    def adaptive_steps(self, bar: Progress) -> str:
        """Adaptive steps to the end, or to a request to stop: the status."""
        stepper, end, calls, handed = self.stepper, self.scene["time.end"], 0, False
        while stepper.t < end:
            if self.regular is not None and self.regular.ready() and not handed:
                taken, handed = self.regular_steps(calls)
                calls += taken
            else:
                stepper.step()
                calls += 1
                handed = False
            bar.update(stepper.t, self.method.n)
            if interrupts.requested(self.comm, calls, STOP_EVERY, also=bool(self.io_error)):
                return "interrupted"
        if self.saved != self.method.n:
            self.save_fields()
        return "complete"

    def regular_steps(self, calls: int) -> tuple[int, bool]:
        """Adaptive steps in one compiled call (:mod:`rodfem.solver.adaptive.compiled`), to the
        next check the ranks agree on at most: the steps taken (each counted as a call of the
        stepper), and whether the next step is handed back to the stepper (one it takes again:
        an event, a failure or a restart of the estimate the call did not take)."""
        regular, stepper = self.regular, self.stepper
        every = STOP_EVERY - calls % STOP_EVERY
        since = self.history.count
        saving = self.files is not None or self.kept is not None  # else no save to stop at
        code = regular.advance(every if self.comm.size > 1 else 1 << 30,
                               self.interval if saving else None, self.frame)
        self.check(since)
        if self.history.full:
            self.flush()
        if regular.written and frame(stepper.t, self.interval) > self.frame:
            self.save_fields()
        codes = regular.codes
        return regular.written, code in (codes["RA_EVENT"], codes["RA_FAILED"],
                                         codes["RA_RESTART"])

    def check(self, since: int | None = None) -> None:
        """Stop at the first recorded step that is not finite (the rows before it are kept)."""
        history = self.history
        bad = history.first_non_finite(history.count - 1 if since is None else since)
        if bad is not None:  # an adaptive step is checked as it is recorded: at stepper.t
            t = self.stepper.t if self.stepper is not None else bad[0] * self.dt
            raise NotFinite(self.method.name, bad[0], t, bad[1])

    def loop(self, bar: Progress) -> tuple[str, NotConverged | None]:
        """The steps to the end, or to a failed step, a request to stop or a write error: the
        status (complete, interrupted or failed) and the failed step's error."""
        method, steps = self.method, self.steps
        try:
            if not self.resumed:
                self.observe()
                if self.stepper is not None:
                    self.stepper.start()
            if self.stepper is not None:
                return self.adaptive_steps(bar), None
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
        summary = run_summary(self.scene, status, error, self.iterations, self.energy,
                           setup_seconds, loop_seconds, self.comm, resumed=self.resumed,
                           dolfinx=self.library_version, petsc=self.petsc_version)
        summary["loops"] = self.loops
        summary["contact"] = dataclasses.asdict(self.contact)
        summary["measures"] = self.measures(summary)
        if self.stepper is not None:
            summary["adaptive"] = self.stepper.counts()
        if files is not None:
            summary["checkpoint_seconds"] = files.seconds  # rank 0's: it writes them
        if io_error:
            summary["error"] = io_error[0]
        summary.update(self.annotate)
        if self.out is not None:
            self.write_summary(summary, status)
        return RunResult(status, summary, error, self.disc.nodes.x.copy(),
                         method.theta.array_r.copy(), method.u.array_r.copy(),
                         self.rows_out.rows_so_far() if files is None else None,
                         io_error[0] if io_error else None, interrupts.signal_received(),
                         kept.kept() if kept is not None else None)

    def measures(self, summary: dict) -> dict:
        """The run's measures (:func:`rodfem.output.measures.measures`): the declared ones
        reduced over every step; the built-in ones of the last step's row and the
        summary's records (of contact, over every step). Empty without a row."""
        if self.last_row is None:
            return {}
        names = [column.name for column in self.history.columns]
        last = {name: self.last_row[:, j] for j, name in enumerate(names)}
        return measures(last, self.scene, {**summary, "measures": self.reductions.values()})

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
