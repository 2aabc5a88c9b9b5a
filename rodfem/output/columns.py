"""The recorded quantities: the table of history.csv's columns, each made from the raw rows a
time loop stores (:data:`rodfem.solver.record.RAW`). Importing this module needs NumPy only
(the figures read it).

Each column of ``history.csv`` is computed from a block of raw rows by its ``compute``, given the
run's Δt and its obstacle (:mod:`rodfem.model.contact`). No other module writes a column index.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from rodfem.solver.record import RAW, RAW_INDEX  # noqa: F401 (re-exported)


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of history.csv: its name, meaning, and how it is computed from the raw rows
    (a dict of slot name → array), Δt and the obstacle."""

    name: str
    meaning: str
    compute: Callable[[dict[str, np.ndarray], float, object], np.ndarray]
    integer: bool = False




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
