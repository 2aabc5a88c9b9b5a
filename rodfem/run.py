"""One simulation of a scene, from set-up to the files of its run directory."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import dolfinx
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

import rodfem
from rodfem.discretisation import Discretisation
from rodfem.history import History
from rodfem.output import FieldFile, HistoryFile, write_json, write_text
from rodfem.picard import PicardNotConverged, PicardScheme
from rodfem.progress import Progress
from rodfem.scene import Scene

# Êⁿ is non-increasing in exact arithmetic (Remark 4.4). An increase counts only if it exceeds the
# round-off of Ê, a sum of a few O(max |Ê|) terms each good to a few ulps.
ENERGY_ROUNDOFF = 64 * np.finfo(float).eps


@dataclasses.dataclass
class EnergyMonitor:
    """Tracks max_{n ≥ 2} (Êⁿ − Êⁿ⁻¹) over the rows of a run."""

    last: float = np.nan
    max_increase: float = -np.inf
    scale: float = 0.0

    def update(self, steps: np.ndarray, energy: np.ndarray) -> None:
        if steps.size == 0:
            return
        previous = np.concatenate([[self.last], energy[:-1]])
        judged = steps >= 2
        if judged.any():
            self.max_increase = max(self.max_increase, float(np.max((energy - previous)[judged])))
        self.scale = max(self.scale, float(np.max(np.abs(energy))))
        self.last = float(energy[-1])

    def non_increasing(self) -> bool:
        return self.max_increase <= ENERGY_ROUNDOFF * self.scale


@dataclasses.dataclass
class RunResult:
    status: str  # complete | failed | interrupted
    summary: dict
    error: PicardNotConverged | None = None
    x: np.ndarray | None = None  # the nodes, in order
    theta: np.ndarray | None = None  # the last step's Θ (shifted temperature) at the nodes
    u: np.ndarray | None = None  # the last step's U at the nodes


def simulate(scene: Scene, out: Path, comm: MPI.Comm = MPI.COMM_WORLD, progress: bool = True):
    """Run ``scene`` into the (already created) directory ``out``; return a :class:`RunResult`."""
    started = time.perf_counter()
    write_text(out / "scene.toml", scene.to_toml(), comm)
    disc = Discretisation(scene, comm)
    scheme = PicardScheme(disc)
    history = History(disc)
    history_file = HistoryFile(out / "history.csv", comm)
    field_file = FieldFile(out / "fields.xdmf", disc)
    energy = EnergyMonitor()
    steps, every, dt = scene.steps, scene["output.every"], scene["time.dt"]
    bar = Progress(steps, enabled=progress and comm.rank == 0 and sys.stderr.isatty())
    iterations = []

    def flush() -> None:
        rows = history.take()
        history_file.append(rows)
        energy.update(np.rint(rows[:, 0] / dt).astype(int), rows[:, 5])
        iterations.extend(rows[:, 6].astype(int).tolist())

    def observe() -> None:
        history.record(scheme)
        if history.full:
            flush()
        if scheme.n % every == 0 or scheme.n == steps:
            field_file.write(scheme.n * dt, scheme.theta, scheme.u, scheme.u_prev)

    setup_seconds = time.perf_counter() - started
    status, error = "complete", None
    loop_started = time.perf_counter()
    try:
        observe()
        for n in range(1, steps + 1):
            scheme.advance()
            observe()
            bar.update(n)
    except PicardNotConverged as err:
        status, error = "failed", err
    except KeyboardInterrupt:
        status = "interrupted"
    loop_seconds = time.perf_counter() - loop_started
    bar.close()
    flush()
    history_file.close()
    field_file.close()
    done = len(iterations) - 1
    summary = {
        "status": status,
        "scene": scene.source,
        "steps": done,
        "steps_planned": steps,
        "iterations_total": int(sum(iterations)),
        "iterations_max": int(max(iterations)),
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
    write_json(out / "summary.json", summary, comm)
    comm.barrier()  # every rank returns once rank 0 has written the run's files
    return RunResult(status, summary, error, disc.nodes.x.copy(), scheme.theta.array_r.copy(),
                     scheme.u.array_r.copy())
