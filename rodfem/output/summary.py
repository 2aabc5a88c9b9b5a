"""A run's summary.json: what the run was, how it ended, what it counted and cost."""

from __future__ import annotations

import dataclasses

import numpy as np

import rodfem

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



def run_summary(scene, status, error, iterations, energy, setup_seconds, loop_seconds, comm,
                resumed: bool, dolfinx: str, petsc: str) -> dict:
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
            "petsc": petsc,
        },
    }
    if error is not None:
        summary["error"] = str(error)
    return summary
