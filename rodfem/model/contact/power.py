"""Normal compliance (Klarbring, Mikelić & Shillor; Kuttler & Shillor): the obstacle's reaction
grows as a power m ≥ 1 of the penetration,

    σ(1) = −(1/ε)[u(1) − g]₊^m,      φ(u) = [u − g]₊^{m+1}/((m + 1)ε).

m = 1 is the paper's law (:mod:`.linear`). The step's scalar equations are solved by the shared
:func:`~rodfem.model.contact.law.monotone_root` to round-off. The discrete gradient of two
penetrating states is written as φ'(c) · expm1((m+1) log1p(r))/((m+1) r), r = (y − c)/(c − g),
which keeps its accuracy as y → c where (φ(y) − φ(c))/(y − c) would cancel.
``rodfem/solver/compiled/contact.h`` (``rc_power_*``) repeats these formulas.
"""

from __future__ import annotations

import math

import numpy as np

from rodfem.model.contact.law import ContactLaw


class PowerLaw(ContactLaw):
    name = "power"
    code = 1
    contraction_formula = "w m [u(1) − g]₊^(m−1)/ε at the last iterate"

    def energy(self, y: float) -> float:
        d = y - self.gap
        return d ** (self.exponent + 1.0) / ((self.exponent + 1.0) * self.epsilon) if d > 0 else 0.0

    def force(self, y: float) -> float:
        d = y - self.gap
        return d ** self.exponent / self.epsilon if d > 0.0 else 0.0

    def slope(self, y: float) -> float:
        d = y - self.gap
        return self.exponent * d ** (self.exponent - 1.0) / self.epsilon if d > 0.0 else 0.0

    def energies(self, u: np.ndarray) -> np.ndarray:
        d = np.maximum(np.asarray(u, dtype=float) - self.gap, 0.0)
        return d ** (self.exponent + 1.0) / ((self.exponent + 1.0) * self.epsilon)

    def stresses(self, u: np.ndarray) -> np.ndarray:
        d = np.maximum(np.asarray(u, dtype=float) - self.gap, 0.0)
        return -(d ** self.exponent) / self.epsilon + 0.0

    def gradient(self, y: float, c: float) -> float:
        dy, dc = y - self.gap, c - self.gap
        if dy > 0.0 and dc > 0.0 and y != c:
            m1 = self.exponent + 1.0
            r = (y - c) / dc
            return dc ** self.exponent / self.epsilon * math.expm1(m1 * math.log1p(r)) / (m1 * r)
        return super().gradient(y, c)
