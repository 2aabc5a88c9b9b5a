"""What every elastic contact law provides, and the scalar solves written once for all of them.

A law is its energy φ(u), convex and zero for u ≤ g. The paper's scheme takes the force at the new
step, p = φ'(Uⁿ(1)); Crank–Nicolson takes the discrete gradient between the steps (Gonzalez's
energy-consistent rule), p = (φ(Uⁿ(1)) − φ(Uⁿ⁻¹(1)))/(Uⁿ(1) − Uⁿ⁻¹(1)), so that
p ΔUⁿ(1) = φ(Uⁿ(1)) − φ(Uⁿ⁻¹(1)) and the contact neither makes nor loses energy.

Both forces are non-decreasing in y = Uⁿ(1) (φ' is, and so are the secant slopes of a convex φ),
so a step's equation y + w p(y) = s, with s the U(1) the step would reach without contact and
w > 0 the rod's compliance over the step, has exactly one solution. :func:`monotone_root` finds
it to round-off for any law: no tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

MAX_ITERATIONS = 4000  # bisection alone would end within ~2100 halvings of a double's range


def monotone_root(F: Callable[[float], float], dF: Callable[[float], float], lo: float,
                  hi: float) -> float:
    """The y in [lo, hi] with F(y) = 0, F non-decreasing, F(lo) ≤ 0 ≤ F(hi), to round-off.

    Newton's steps from hi, kept inside the bracket (a bisection where one would leave it),
    until F vanishes or the bracket can shrink no more (its ends adjacent doubles, or no step
    moves). Returns whichever end has the smaller |F|."""
    y = hi
    f_lo, f_hi = -math.inf, math.inf
    for _ in range(MAX_ITERATIONS):
        f = F(y)
        if f == 0.0:
            return y
        if f > 0.0:
            hi, f_hi = y, f
        else:
            lo, f_lo = y, f
        d = dF(y)
        step = y - f / d if d > 0.0 else math.nan
        if not lo < step < hi:
            step = lo + 0.5 * (hi - lo)
        if not lo < step < hi:  # lo and hi are adjacent: nothing lies between
            break
        y = step
    return lo if abs(f_lo) < abs(f_hi) else hi


class ContactLaw:
    """An elastic obstacle at x = g with compliance ε: its energy, force and their solves.

    Subclasses give :meth:`energy`, :meth:`force` and :meth:`slope` (φ, φ', φ'' at y, 0 for
    y ≤ g); everything else follows from them, and a subclass may replace any of it with a
    closed form. ``code`` is the law's number in ``rodfem/solver/compiled/contact.h``."""

    name = ""
    code = -1
    rigid = False
    contraction_formula = "w φ''(u(1))"  # how :meth:`contraction` reads in a message

    def __init__(self, gap: float, epsilon: float, exponent: float = 1.0):
        self.gap, self.epsilon, self.exponent = float(gap), float(epsilon), float(exponent)

    def energy(self, y: float) -> float:
        raise NotImplementedError

    def force(self, y: float) -> float:
        raise NotImplementedError

    def slope(self, y: float) -> float:
        raise NotImplementedError

    def energies(self, u: np.ndarray) -> np.ndarray:
        """φ at each entry of u (the history's contact energy)."""
        return np.array([self.energy(y) for y in np.asarray(u, dtype=float)])

    def stresses(self, u: np.ndarray) -> np.ndarray:
        """σ(1) = −φ'(u) at each entry of u, without −0."""
        return np.array([-self.force(y) for y in np.asarray(u, dtype=float)]) + 0.0

    def contraction(self, w: float, y: float) -> float:
        """w φ''(y): the factor by which Picard's iteration (3.4) changes an error in U(1) while
        the rod presses the obstacle at y; it converges where this is below 1."""
        return w * self.slope(y)

    # The law in the penetration d = y − g itself, for the steady states (rodfem.model.steady),
    # whose penetration may be far below the spacing of the doubles near g.

    def pressure(self, d: float) -> float:
        """φ'(g + d) for the penetration d, without rounding g + d."""
        raise NotImplementedError

    def pressure_slope(self, d: float) -> float:
        """φ''(g + d) for the penetration d > 0 (0 for d ≤ 0)."""
        raise NotImplementedError

    def pressure_derivatives(self, d: float) -> tuple[float, float, float, float]:
        """(P, P′, P″, P‴) at the penetration d > 0, P(d) = φ'(g + d) the force: its first
        three derivatives in u(1), the law's Taylor expansion to third order that the first
        Lyapunov coefficient of a Hopf point needs (:mod:`rodfem.model.expansion`)."""
        raise NotImplementedError

    def penetration(self, t: float) -> tuple[float, float]:
        """(d, p): the penetration and force with d + p(d) = t, the end's excess t = y + p − g
        over the gap (0, 0 for t ≤ 0), to round-off in d and p however small t is."""
        if t <= 0.0:
            return 0.0, 0.0
        d = monotone_root(lambda d: d + self.pressure(d) - t,
                          lambda d: 1.0 + self.pressure_slope(d), 0.0, t)
        return d, self.pressure(d)

    # Crank–Nicolson's force: the discrete gradient from c = Uⁿ⁻¹(1).

    def gradient(self, y: float, c: float) -> float:
        """(φ(y) − φ(c))/(y − c), and φ'(c) where y = c."""
        if y == c:
            return self.force(c)
        if y <= self.gap and c <= self.gap:
            return 0.0
        return (self.energy(y) - self.energy(c)) / (y - c)

    def gradient_slope(self, y: float, c: float) -> float:
        """∂/∂y of :meth:`gradient` (one-sided at a kink): the Jacobian entry of Newton."""
        if y == c:
            return 0.5 * self.slope(y)
        return (self.force(y) - self.gradient(y, c)) / (y - c)

    # The step's scalar equation y + w p(y) = s, which gives p; then Uⁿ(1) = s − w p.

    def solve(self, s: float, w: float) -> float:
        """p = φ'(y) with y + w φ'(y) = s (the paper's scheme)."""
        if s <= self.gap:
            return 0.0
        y = monotone_root(lambda y: y + w * self.force(y) - s,
                          lambda y: 1.0 + w * self.slope(y), self.gap, s)
        return self.force(y)

    def solve_gradient(self, s: float, w: float, c: float) -> float:
        """p = gradient(y, c) with y + w p = s (Crank–Nicolson). The root lies in
        [s − w p(s), s], since p ≥ 0 is non-decreasing."""
        if s <= self.gap and c <= self.gap:
            return 0.0
        lo = s - w * self.gradient(s, c)
        y = monotone_root(lambda y: y + w * self.gradient(y, c) - s,
                          lambda y: 1.0 + w * self.gradient_slope(y, c), lo, s)
        return self.gradient(y, c)
