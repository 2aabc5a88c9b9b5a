"""Barber's pressure-dependent exchange: q = k₁ p^m, p = −σ(1) ≥ 0 the contact pressure.

Separated (p = 0) the end exchanges only k; pressed, the contact conducts more, the more so the
harder it is pressed. With a hot obstacle this feeds back: heat expands the rod, which presses
harder and takes more heat, the source of the non-uniqueness and instability of steady states
(``rodfem steady``)."""

from __future__ import annotations

import math

import numpy as np

from rodfem.model.exchange.law import ExchangeLaw


class PressureLaw(ExchangeLaw):
    name = "pressure"
    code = 1

    def __init__(self, k: float, temperature: float, k1: float, exponent: float = 1.0):
        super().__init__(k, temperature)
        self.k1, self.exponent = float(k1), float(exponent)

    def extra(self, y: float, p: float) -> float:
        return self.k1 * p**self.exponent if p > 0.0 else 0.0

    def coefficients(self, y, p) -> np.ndarray:
        y, p = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(p, dtype=float))
        pressed = p > 0.0
        extra = np.zeros(p.shape)
        extra[pressed] = self.k1 * p[pressed] ** self.exponent
        return self.k + extra

    def extra_slopes(self, y: float, p: float) -> tuple[float, float]:
        m = self.exponent
        if p > 0.0:
            try:
                return 0.0, self.k1 * m * p ** (m - 1.0)
            except OverflowError:  # m < 1 and p near the smallest doubles: C's pow gives inf
                return 0.0, math.inf
        if m == 1.0:
            return 0.0, self.k1
        return 0.0, (0.0 if m > 1.0 or self.k1 == 0.0 else math.inf)

    def extra_derivatives_at(self, gap: float, e: float, p: float) -> np.ndarray:
        """k₁ m (m − 1) … (m − j + 1) p^(m−j) in D[0, j]: q does not depend on y."""
        found = np.zeros((4, 4))
        if p <= 0.0:
            return found
        m, factor = self.exponent, self.k1
        for j in range(4):
            if factor:
                try:
                    found[0, j] = factor * p ** (m - j)
                except OverflowError:  # p near the smallest doubles, m < j: C's pow gives inf
                    found[0, j] = math.copysign(math.inf, factor)
            factor *= m - j
        return found
