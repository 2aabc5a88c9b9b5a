"""Normal compliance (Klarbring, Mikelić & Shillor; Kuttler & Shillor): the obstacle's reaction
grows as a power m ≥ 1 of the penetration,

    σ(1) = −(1/ε)[u(1) − g]₊^m,      φ(u) = [u − g]₊^{m+1}/((m + 1)ε).

m = 1 is the paper's law (:mod:`.linear`). The step's scalar equations are solved by the shared
:func:`~rodfem.model.contact.law.monotone_root` to round-off. The discrete gradient of two
penetrating states close to each other (|r| ≤ ½, r = (y − c)/(c − g)) is written as
φ'(c) · expm1((m+1) log1p(r))/((m+1) r), which keeps its accuracy as y → c where
(φ(y) − φ(c))/(y − c) would cancel; farther apart the secant does not cancel and is used as it
is (the product form would overflow there). Powers that exceed the double range are +inf, as in
C, not an OverflowError.
``rodfem/solver/compiled/contact.h`` (``rc_power_*``) repeats these formulas.
"""

from __future__ import annotations

import math

import numpy as np

from rodfem.model.contact.law import ContactLaw

CLOSE = 0.5  # |r| up to which the discrete gradient takes its product form


def _power(d: float, m: float) -> float:
    """d**m for d > 0, +inf past the double range (C's pow does the same)."""
    try:
        return d ** m
    except OverflowError:
        return math.inf


class PowerLaw(ContactLaw):
    name = "power"
    code = 1
    contraction_formula = "w m [u(1) − g]₊^(m−1)/ε at the deepest iterate"

    def energy(self, y: float) -> float:
        d = y - self.gap
        m1 = self.exponent + 1.0
        return _power(d, m1) / (m1 * self.epsilon) if d > 0.0 else 0.0

    def force(self, y: float) -> float:
        d = y - self.gap
        return _power(d, self.exponent) / self.epsilon if d > 0.0 else 0.0

    def slope(self, y: float) -> float:
        d = y - self.gap
        return self.exponent * _power(d, self.exponent - 1.0) / self.epsilon if d > 0.0 else 0.0

    def pressure(self, d: float) -> float:
        return _power(d, self.exponent) / self.epsilon if d > 0.0 else 0.0

    def pressure_slope(self, d: float) -> float:
        return self.exponent * _power(d, self.exponent - 1.0) / self.epsilon if d > 0.0 else 0.0

    def pressure_derivatives(self, d: float) -> tuple[float, float, float, float]:
        """dʲ/ddʲ d^m/ε = m (m − 1) … (m − j + 1) d^(m−j)/ε, j = 0 … 3."""
        if d <= 0.0:
            return 0.0, 0.0, 0.0, 0.0
        m, found, factor = self.exponent, [], 1.0
        for j in range(4):
            found.append(factor * _power(d, m - j) / self.epsilon if factor else 0.0)
            factor *= m - j
        return tuple(found)

    def energies(self, u: np.ndarray) -> np.ndarray:
        d = np.maximum(np.asarray(u, dtype=float) - self.gap, 0.0)
        with np.errstate(over="ignore"):
            return d ** (self.exponent + 1.0) / ((self.exponent + 1.0) * self.epsilon)

    def stresses(self, u: np.ndarray) -> np.ndarray:
        d = np.maximum(np.asarray(u, dtype=float) - self.gap, 0.0)
        with np.errstate(over="ignore"):
            return -(d ** self.exponent) / self.epsilon + 0.0

    def gradient(self, y: float, c: float) -> float:
        dy, dc = y - self.gap, c - self.gap
        if dy > 0.0 and dc > 0.0 and y != c and abs(y - c) <= CLOSE * dc:
            m1 = self.exponent + 1.0
            r = (y - c) / dc
            return (_power(dc, self.exponent) / self.epsilon
                    * math.expm1(m1 * math.log1p(r)) / (m1 * r))
        return super().gradient(y, c)
