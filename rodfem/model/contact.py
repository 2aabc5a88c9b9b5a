"""The contact force at x = 1 of each time scheme, and the one scalar equation a step solves.

The elastic obstacle stores the energy φ(u) = [u − g]_+²/(2ε) and pushes back with φ'(u).

* The paper's scheme (3.2) takes the force at the new step: p = φ'(Uⁿ(1)) = (1/ε)[Uⁿ(1) − g]_+.
* Crank–Nicolson takes its discrete gradient between the two steps (Gonzalez's energy-consistent
  rule), p = (φ(Uⁿ(1)) − φ(Uⁿ⁻¹(1)))/(Uⁿ(1) − Uⁿ⁻¹(1)), so that p ΔUⁿ(1) = φ(Uⁿ(1)) − φ(Uⁿ⁻¹(1))
  exactly: the contact neither makes nor loses energy, and the scheme's energy identity holds
  with the obstacle as for the free rod (docs/time-schemes.md).

Both forces are non-decreasing in y = Uⁿ(1) (secant slopes of a convex φ increase), so the
step's equation y + w p(y) = s, with s the U(1) the step would reach without contact and w > 0 the
rod's compliance over the step, has exactly one solution. :func:`solve` gives it in closed form.
"""

from __future__ import annotations

import math


def penalty_force(y: float, gap: float, epsilon: float) -> float:
    """φ'(y) = (1/ε)[y − g]_+."""
    return max(y - gap, 0.0) / epsilon


def discrete_gradient(y: float, c: float, gap: float, epsilon: float) -> float:
    """(φ(y) − φ(c))/(y − c), and φ'(c) where y = c."""
    dy, dc = y - gap, c - gap
    if dy <= 0.0 and dc <= 0.0:
        return 0.0
    if dy > 0.0 and dc > 0.0:
        return (dy + dc) / (2.0 * epsilon)
    if y == c:
        return max(dy, 0.0) / epsilon
    # Just one of them penetrates.
    return (max(dy, 0.0) ** 2 - max(dc, 0.0) ** 2) / (2.0 * epsilon * (y - c))


def discrete_gradient_slope(y: float, c: float, gap: float, epsilon: float) -> float:
    """∂/∂y of :func:`discrete_gradient` (one-sided where it has a kink): the Jacobian entry of
    semismooth Newton."""
    dy, dc = y - gap, c - gap
    if dy <= 0.0 and dc <= 0.0:
        return 0.0
    if dy > 0.0 and dc > 0.0:
        return 1.0 / (2.0 * epsilon)
    if y == c:
        return 1.0 / epsilon if dy > 0.0 else 0.0
    p = discrete_gradient(y, c, gap, epsilon)
    slope = max(dy, 0.0) / epsilon  # φ'(y)
    return (slope - p) / (y - c)


def _positive_root(A: float, B: float, C: float) -> float:
    """The root q ≥ 0 of A q² + B q + C = 0 for A > 0, C ≤ 0, without cancellation."""
    disc = math.sqrt(B * B - 4.0 * A * C)
    return -2.0 * C / (B + disc) if B >= 0.0 else (-B + disc) / (2.0 * A)


def solve(s: float, w: float, gap: float, epsilon: float, rule: str, c: float = 0.0) -> float:
    """The contact force p of the step: y + w p(y) = s for y = Uⁿ(1), with p the penalty force
    (``rule="penalty"``), the discrete gradient from c = Uⁿ⁻¹(1) (``"gradient"``), or Signorini's
    multiplier of the rigid obstacle, y ≤ g, p ≥ 0, p (y − g) = 0 (``"rigid"``).

    Then Uⁿ(1) = s − w p."""
    if rule == "rigid" or rule == "penalty":
        if s <= gap:
            return 0.0
        return (s - gap) / (w if rule == "rigid" else epsilon + w)
    assert rule == "gradient"
    sigma = s - gap  # how far past the obstacle the free step would go
    e = c - gap
    if e <= 0.0:  # the rod was not in contact: p = 0 unless the free step reaches the obstacle
        if sigma <= 0.0:
            return 0.0
        # y = g + d, d > 0: d + w d²/(2ε(d − e)) = σ, i.e. (2ε + w) d² − 2ε(e + σ) d + 2εσe = 0
        two_eps = 2.0 * epsilon
        d = _positive_root(two_eps + w, -two_eps * (e + sigma), two_eps * sigma * e)
        return d * d / (2.0 * epsilon * (d - e))
    # The rod was in contact. If it stays (y > g): p = (y − g + e)/(2ε), linear in y, and with
    # y = s − w p that is p = (σ + e)/(2ε + w), free of cancellation.
    if sigma > w * e / (2.0 * epsilon):  # s > g + w p(g), p(g) = e/(2ε)
        return (sigma + e) / (2.0 * epsilon + w)
    # It leaves (y = g − q, q ≥ 0): p = e²/(2ε(e + q)) and −q + w p = σ, i.e.
    # 2ε q² + 2ε(e + σ) q + (2εσe − w e²) = 0.
    two_eps = 2.0 * epsilon
    q = _positive_root(two_eps, two_eps * (e + sigma), e * (two_eps * sigma - w * e))
    return e * e / (2.0 * epsilon * (e + q))
