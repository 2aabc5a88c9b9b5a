"""The measures of a run: one number each, made from its history (the columns of
:mod:`rodfem.output.columns`), its scene and its summary. A sweep's ``results.csv`` has a column
per measure (:mod:`rodfem.studies.sweep`), and :attr:`rodfem.Result.measures` gives them for any
run. Importing this module needs NumPy only.

The rod is *in contact* at tⁿ when the obstacle pushes on it: σ(1, tⁿ) < 0 (the elastic laws:
u(1, tⁿ) > g; the rigid obstacle: a positive multiplier). Counts and fractions are over the steps
n = 1 … N that the run took (the initial state, n = 0, is data, not a step).

A run keeps the measures of contact over every step as it goes (:class:`Contact`, in its summary
as ``contact``), so that they are the same whatever rows its history keeps
(``output.history_every``); without that record (a run killed before it wrote its summary) they
are computed from the history's rows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class Measure:
    """One measure: its name, meaning, and how it is computed from the history's columns (a dict
    of name → array over n = 0 … N), the scene and the run's summary."""

    name: str
    meaning: str
    compute: Callable[[dict[str, np.ndarray], object, dict], float]
    integer: bool = False


def in_contact(history: dict[str, np.ndarray]) -> np.ndarray:
    """Whether the rod is in contact at each step n = 1 … N (the module's docstring)."""
    return history["sigma_1"][1:] < 0.0


def _final(name: str):
    return lambda history, scene, summary: float(history[name][-1])


@dataclasses.dataclass
class Contact:
    """The measures of contact over every step, updated block by block as a run records its
    rows (and continued from a checkpoint): what :data:`MEASURES` computes from a history of
    every step, bit for bit."""

    steps: int = 0  # steps n ≥ 1 seen
    touching: int = 0  # of them in contact
    intervals: int = 0
    last_change: int | None = None  # the step n of the last change of contact state
    last_change_t: float | None = None  # and its time tⁿ (none: a record kept before it was)
    was: bool = False  # in contact at the last step seen (none: not)
    max_penetration: float = 0.0  # max over n ≥ 0 of [u(1, tⁿ) − g]₊
    time: float = 0.0  # tⁿ of the last step seen
    touching_time: float = 0.0  # Σ tⁿ − tⁿ⁻¹ over the steps n in contact, summed in order

    def update(self, steps: np.ndarray, t: np.ndarray, u_1: np.ndarray, sigma_1: np.ndarray,
               gap: float) -> None:
        """Count the rows of the steps ``steps`` at the times ``t`` (non-uniform with adaptive
        steps)."""
        if steps.size == 0:
            return
        self.max_penetration = max(self.max_penetration,
                                   float(np.max(np.maximum(u_1 - gap, 0.0))))
        taken = steps >= 1
        touching = sigma_1[taken] < 0.0
        if touching.size == 0:
            return
        change = np.diff(touching.astype(np.int8), prepend=np.int8(self.was))
        t = t[taken]
        lengths = np.diff(t, prepend=self.time)[touching]
        # step after step, so that the sum does not depend on how the rows come in blocks
        self.touching_time = float(np.add.accumulate(np.append(self.touching_time, lengths))[-1])
        self.time = float(t[-1])
        self.steps += int(touching.size)
        self.touching += int(np.count_nonzero(touching))
        self.intervals += int(np.count_nonzero(change == 1))
        changed = np.flatnonzero(change != 0)
        if changed.size:
            self.last_change = int(steps[taken][changed[-1]])
            self.last_change_t = float(t[changed[-1]])
        self.was = bool(touching[-1])


def _kept(summary: dict) -> dict | None:
    """The run's record of contact over every step (:class:`Contact`), if it has one."""
    kept = summary.get("contact")
    return kept if isinstance(kept, dict) else None


def _max_penetration(history, scene, summary) -> float:
    if (kept := _kept(summary)) is not None:
        return float(kept["max_penetration"])
    return float(np.max(np.maximum(history["u_1"] - scene["obstacle.gap"], 0.0)))


def _contact_fraction(history, scene, summary) -> float:
    if (kept := _kept(summary)) is not None and scene["time.adaptive"]:
        # steps of all sizes: each counts for its length (equal lengths: the fraction of steps)
        return kept["touching_time"] / kept["time"] if kept["time"] else 0.0
    if kept is not None:
        return kept["touching"] / kept["steps"] if kept["steps"] else 0.0
    touching = in_contact(history)
    return float(touching.mean()) if touching.size else 0.0


def _contact_intervals(history, scene, summary) -> int:
    if (kept := _kept(summary)) is not None:
        return int(kept["intervals"])
    touching = in_contact(history).astype(np.int8)
    return int(np.count_nonzero(np.diff(touching, prepend=0) == 1))


def _last_contact_change(history, scene, summary) -> float:
    if (kept := _kept(summary)) is not None:
        step, t = kept["last_change"], kept.get("last_change_t")
        if t is not None:
            return float(t)
        # a record from before it kept the time: of a run of fixed steps
        return float(step * scene["time.dt"]) if step is not None else float("nan")
    touching = in_contact(history)
    changed = np.flatnonzero(np.diff(touching.astype(np.int8), prepend=0) != 0)
    return float(history["t"][1:][changed[-1]]) if changed.size else float("nan")


MEASURES = (
    Measure("t_final", "the time the run reached: T if it is complete", _final("t")),
    Measure("u_1_final", "u(1, t) at the last step", _final("u_1")),
    Measure("sigma_1_final", "the contact stress σ(1, t) at the last step", _final("sigma_1")),
    Measure("max_penetration", "max over the steps of [u(1, tⁿ) − g]₊ (the rigid obstacle: "
            "round-off)", _max_penetration),
    Measure("contact_fraction", "the fraction of the steps in contact (adaptive steps: of the "
            "time, each step counted for its length)", _contact_fraction),
    Measure("contact_intervals", "how many separate intervals of contact (runs of steps in "
            "contact)", _contact_intervals, integer=True),
    Measure("last_contact_change", "the time tⁿ of the last step whose contact state differs "
            "from the step before's (nan if it never changes; a run starting in contact counts "
            "as a change at t¹)", _last_contact_change),
    Measure("energy_final", "the discrete energy Êⁿ at the last step", _final("energy")),
    Measure("iterations_max", "the most iterations any step took (a failed step's included)",
            lambda history, scene, summary: int(summary["iterations_max"]), integer=True),
    Measure("loop_seconds", "wall time of the time loop, s (a timing: it varies from run to "
            "run)", lambda history, scene, summary: float(summary["loop_seconds"])),
)
NAMES = tuple(measure.name for measure in MEASURES)
TIMINGS = ("loop_seconds",)  # the measures that are not reproducible bit for bit


def measures(history: dict[str, np.ndarray], scene, summary: dict) -> dict[str, float | int]:
    """Every measure of a run, by name. ``history``: its columns by name (at least the row of
    n = 0)."""
    return {m.name: m.compute(history, scene, summary) for m in MEASURES}
