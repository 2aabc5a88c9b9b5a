"""The obstacle as the rod's end feels it through a massless last cell.

With the mass redistributed away from x = 1 (``discretisation.mass = "redistributed"``) the end
node has no inertia, and where nothing else gives it a time derivative (ζ = 0) its equation is
static: the end sits where the last cell's spring, of compliance c = 1/K_NN, balances the
obstacle. Eliminating it leaves the rest of the rod pushing, through that spring, on the obstacle
from the end's *free position* y (where the end would be without the obstacle), with the energy

    ψ(y) = min_u ( (u − y)²/(2c) + φ(u) ),     ψ'(y) = φ'(u*),   u* = y − c ψ'(y),

the obstacle and the spring in series. It is again a contact law, convex and zero for y ≤ g:

* the paper's linear law of compliance ε gives the linear law of compliance ε + c;
* the rigid obstacle gives the linear law of compliance c: the end is at u* = min(y, g) and the
  reaction is [y − g]₊/c, the force with which the last cell is compressed against the wall;
* any other law gives ψ'(y) = the p of u + c φ'(u) = y, which its ``solve`` already finds.

Crank–Nicolson's discrete gradient of ψ then conserves the energy of the rigid contact exactly,
with the end never past the obstacle (docs/time-schemes.md).
"""

from __future__ import annotations

import numpy as np

from rodfem.model.contact.law import ContactLaw
from rodfem.model.contact.linear import LinearLaw

# Gauss–Legendre on (0, 1), 8 points: the mean of ψ' between two close positions, where their
# secant (ψ(y) − ψ(c))/(y − c) would cancel (ψ is found by a solve, to round-off only).
_T, _W = np.polynomial.legendre.leggauss(8)
_T, _W = 0.5 * (_T + 1.0), 0.5 * _W
CLOSE = 1e-3  # |y − c| up to which, relative to the penetration, the mean is taken


class InSeries(ContactLaw):
    """ψ of a law with a spring of compliance c in series (any law; the linear law and the
    rigid obstacle have closed forms, :func:`in_series`)."""

    contraction_formula = "w ψ''(y)"

    def __init__(self, law: ContactLaw, compliance: float):
        super().__init__(law.gap, law.epsilon + compliance, law.exponent)
        self.law, self.compliance = law, compliance

    def force(self, y: float) -> float:
        return self.law.solve(y, self.compliance)

    def energy(self, y: float) -> float:
        p = self.force(y)
        return 0.5 * self.compliance * p * p + self.law.energy(y - self.compliance * p)

    def slope(self, y: float) -> float:
        """dψ'/dy = φ''/(1 + c φ''), at the end's place u*."""
        curvature = self.law.slope(y - self.compliance * self.force(y))
        return curvature / (1.0 + self.compliance * curvature)

    def _close(self, y: float, c: float) -> bool:
        return y != c and abs(y - c) <= CLOSE * max(abs(y - self.gap), abs(c - self.gap))

    def gradient(self, y: float, c: float) -> float:
        """The discrete gradient; between close positions the mean of ψ' over [c, y] by
        quadrature (equal to the secant up to the quadrature's error, which there is below its
        round-off), so that Newton's residual can reach its own round-off."""
        if self._close(y, c):
            return float(sum(w * self.force(c + t * (y - c)) for t, w in zip(_T, _W)))
        return super().gradient(y, c)

    def gradient_slope(self, y: float, c: float) -> float:
        """∂/∂y of :meth:`gradient`: between close positions that of the quadrature,
        Σ wᵢ tᵢ ψ''(c + tᵢ (y − c))."""
        if self._close(y, c):
            return float(sum(w * t * self.slope(c + t * (y - c)) for t, w in zip(_T, _W)))
        return super().gradient_slope(y, c)


def in_series(law, compliance: float) -> ContactLaw:
    """The obstacle ``law`` (a :class:`ContactLaw` or the rigid obstacle) seen through a spring
    of compliance ``compliance`` > 0."""
    if law.rigid:
        return LinearLaw(law.gap, compliance)
    if isinstance(law, LinearLaw):
        return LinearLaw(law.gap, law.epsilon + compliance)
    return InSeries(law, compliance)
