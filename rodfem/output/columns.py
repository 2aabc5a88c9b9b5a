"""The recorded quantities: one table of what a run stores per step and of the history.csv
columns made from it. Importing this module needs NumPy only (the figures read it).

A time loop, in Python (:class:`rodfem.output.history.History`) or compiled, stores one *raw
row* per step, the slots of ``RAW`` in that order; the compiled loops name the same slots in
``rodfem/solver/compiled/record.h``, checked against ``RAW`` when they are built. Each column of
``history.csv`` is computed from a block of raw rows by its ``compute``, given the run's Δt and
its obstacle (:mod:`rodfem.model.contact`). No other module writes a column index.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class Slot:
    """One number a time loop stores per step."""

    name: str
    meaning: str


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of history.csv: its name, meaning, and how it is computed from the raw rows
    (a dict of slot name → array), Δt and the obstacle."""

    name: str
    meaning: str
    compute: Callable[[dict[str, np.ndarray], float, object], np.ndarray]
    integer: bool = False


RAW = (
    Slot("n", "the step n"),
    Slot("iterations", "the method's iterations of the step"),
    Slot("u_1", "Uⁿ(1)"),
    Slot("d_1", "Dⁿ(1), the displacement the velocity makes over a step at x = 1"),
    Slot("u_half", "Uⁿ(0.5), interpolated"),
    Slot("bulk_energy", "Êⁿ without its contact term: ½ (‖Θⁿ‖² + b‖Dⁿ/Δt‖² + ‖Uⁿ_x‖²) "
         "+ a θ_A (r, Uⁿ_x)"),
    Slot("pressure", "the contact force p of the step (the multiplier, for the rigid obstacle)"),
)
RAW_INDEX = {slot.name: i for i, slot in enumerate(RAW)}


def _sigma_1(raw, dt, obstacle):
    if obstacle.rigid:  # σ(1) is the multiplier
        return -raw["pressure"] + 0.0  # no −0 in the file
    return obstacle.stresses(raw["u_1"])


COLUMNS = (
    Column("t", "time tⁿ = nΔt", lambda raw, dt, obstacle: raw["n"] * dt),
    Column("u_1", "displacement u(1, tⁿ) of the end at the obstacle",
           lambda raw, dt, obstacle: raw["u_1"]),
    Column("u_half", "displacement u(0.5, tⁿ) at the middle of the rod",
           lambda raw, dt, obstacle: raw["u_half"]),
    Column("ut_1", "velocity u_t(1, tⁿ): δⁿ(1) = (Uⁿ(1) − Uⁿ⁻¹(1))/Δt in the paper's scheme, "
           "Vⁿ(1) in Crank–Nicolson's", lambda raw, dt, obstacle: raw["d_1"] / dt),
    Column("sigma_1", "contact stress σ(1, tⁿ) = −φ'(u(1)) of the obstacle's law (the rigid "
           "obstacle: −p, its multiplier)", _sigma_1),
    Column("energy", "the discrete energy Êⁿ of Remark 4.4, with the obstacle's energy φ(u(1))",
           lambda raw, dt, obstacle: raw["bulk_energy"] + obstacle.energies(raw["u_1"])),
    Column("iterations", "iterations of the method at the step (picard, newton; direct: 1)",
           lambda raw, dt, obstacle: raw["iterations"], integer=True),
)
NAMES = tuple(column.name for column in COLUMNS)
INDEX = {name: i for i, name in enumerate(NAMES)}


def columns_of(raw_rows: np.ndarray, dt: float, obstacle) -> np.ndarray:
    """The history.csv rows of a block of raw rows."""
    raw = {slot.name: raw_rows[:, i] for i, slot in enumerate(RAW)}
    return np.column_stack([column.compute(raw, dt, obstacle) for column in COLUMNS])
