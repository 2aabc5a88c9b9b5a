"""The raw row a time loop stores per step, in Python (:class:`rodfem.output.history.History`)
or compiled: the slots of ``RAW`` in that order. The compiled loops name the same slots in
``rodfem/solver/compiled/record.h``, checked against ``RAW`` when they are built; the columns of
history.h5 are made from these rows (:mod:`rodfem.output.columns`). NumPy-free.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Slot:
    """One number a time loop stores per step."""

    name: str
    meaning: str


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
