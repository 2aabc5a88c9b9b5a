"""The rigid obstacle: Signorini's condition u(1) ≤ g, σ(1) ≤ 0, σ(1)(u(1) − g) = 0.

It stores no energy; σ(1) is the multiplier p of the constraint. A step's equation
y + w p = s with y ≤ g, p ≥ 0, p (y − g) = 0 gives p = (s − g)/w where the free step would pass
the obstacle (s > g), and 0 elsewhere; ``rodfem/solver/compiled/contact.h`` (``rc_rigid_solve``)
repeats it.
"""

from __future__ import annotations

import numpy as np


class RigidObstacle:
    name = "rigid"
    code = 2
    rigid = True
    epsilon = 0.0
    exponent = 1.0

    def __init__(self, gap: float):
        self.gap = float(gap)

    def energy(self, y: float) -> float:
        return 0.0

    def energies(self, u: np.ndarray) -> np.ndarray:
        return np.zeros(np.shape(u))

    def solve(self, s: float, w: float) -> float:
        """The multiplier of the step whose free end would reach s."""
        if s <= self.gap:
            return 0.0
        return (s - self.gap) / w
