"""The paper's obstacle (1.5): σ(1) = −(1/ε)[u(1) − g]₊, energy φ(u) = [u − g]₊²/(2ε).

Every solve is in closed form: the paper's step is linear in y once in contact, and
Crank–Nicolson's discrete gradient makes it a linear or a quadratic equation, solved without
cancellation. ``rodfem/solver/compiled/contact.h`` (``rc_linear_*``) repeats these formulas
operation for operation.
"""

from __future__ import annotations

import math

import numpy as np

from rodfem.model.contact.law import ContactLaw


def positive_root(A: float, B: float, C: float) -> float:
    """The root q ≥ 0 of A q² + B q + C = 0 for A > 0, C ≤ 0, without cancellation."""
    disc = math.sqrt(B * B - 4.0 * A * C)
    return -2.0 * C / (B + disc) if B >= 0.0 else (-B + disc) / (2.0 * A)


class LinearLaw(ContactLaw):
    name = "linear"
    code = 0
    contraction_formula = "w/ε"

    def energy(self, y: float) -> float:
        return 0.5 * max(y - self.gap, 0.0) ** 2 / self.epsilon

    def force(self, y: float) -> float:
        return max(y - self.gap, 0.0) / self.epsilon

    def slope(self, y: float) -> float:
        return 1.0 / self.epsilon if y > self.gap else 0.0

    def energies(self, u: np.ndarray) -> np.ndarray:
        return 0.5 * np.maximum(u - self.gap, 0.0) ** 2 / self.epsilon

    def pressure(self, d: float) -> float:
        return max(d, 0.0) / self.epsilon

    def pressure_slope(self, d: float) -> float:
        return 1.0 / self.epsilon if d > 0.0 else 0.0

    def pressure_derivatives(self, d: float) -> tuple[float, float, float, float]:
        """d/ε, 1/ε and no curvature: the law is linear in contact."""
        if d <= 0.0:
            return 0.0, 0.0, 0.0, 0.0
        return d / self.epsilon, 1.0 / self.epsilon, 0.0, 0.0

    def penetration(self, t: float) -> tuple[float, float]:
        """p = t/(1 + ε) and d = ε p (not t − p, which cancels for a small ε)."""
        if t <= 0.0:
            return 0.0, 0.0
        p = t / (1.0 + self.epsilon)
        return self.epsilon * p, p

    def stresses(self, u: np.ndarray) -> np.ndarray:
        return -np.maximum(u - self.gap, 0.0) / self.epsilon + 0.0

    def contraction(self, w: float, y: float) -> float:
        """w/ε wherever the rod presses the obstacle (Picard's factor does not depend on y)."""
        return w / self.epsilon

    def gradient(self, y: float, c: float) -> float:
        dy, dc = y - self.gap, c - self.gap
        if dy <= 0.0 and dc <= 0.0:
            return 0.0
        if dy > 0.0 and dc > 0.0:
            return (dy + dc) / (2.0 * self.epsilon)
        if y == c:
            return max(dy, 0.0) / self.epsilon
        # Just one of them penetrates.
        return (max(dy, 0.0) ** 2 - max(dc, 0.0) ** 2) / (2.0 * self.epsilon * (y - c))

    def gradient_slope(self, y: float, c: float) -> float:
        dy, dc = y - self.gap, c - self.gap
        if dy <= 0.0 and dc <= 0.0:
            return 0.0
        if dy > 0.0 and dc > 0.0:
            return 1.0 / (2.0 * self.epsilon)
        if y == c:
            return 1.0 / self.epsilon if dy > 0.0 else 0.0
        return (max(dy, 0.0) / self.epsilon - self.gradient(y, c)) / (y - c)

    def solve(self, s: float, w: float) -> float:
        if s <= self.gap:
            return 0.0
        return (s - self.gap) / (self.epsilon + w)

    def solve_gradient(self, s: float, w: float, c: float) -> float:
        epsilon = self.epsilon
        sigma = s - self.gap  # how far past the obstacle the free step would go
        e = c - self.gap
        two_eps = 2.0 * epsilon
        if e <= 0.0:  # the rod was not in contact: p = 0 unless the free step reaches it
            if sigma <= 0.0:
                return 0.0
            # y = g + d, d > 0: d + w d²/(2ε(d − e)) = σ, i.e.
            # (2ε + w) d² − 2ε(e + σ) d + 2εσe = 0
            d = positive_root(two_eps + w, -two_eps * (e + sigma), two_eps * sigma * e)
            return d * d / (2.0 * epsilon * (d - e))
        # The rod was in contact. If it stays (y > g): p = (y − g + e)/(2ε), linear in y, and
        # with y = s − w p that is p = (σ + e)/(2ε + w), free of cancellation.
        if sigma > w * e / two_eps:  # s > g + w p(g), p(g) = e/(2ε)
            return (sigma + e) / (two_eps + w)
        # It leaves (y = g − q, q ≥ 0): p = e²/(2ε(e + q)) and −q + w p = σ, i.e.
        # 2ε q² + 2ε(e + σ) q + (2εσe − w e²) = 0.
        q = positive_root(two_eps, two_eps * (e + sigma), e * (two_eps * sigma - w * e))
        return e * e / (2.0 * epsilon * (e + q))
