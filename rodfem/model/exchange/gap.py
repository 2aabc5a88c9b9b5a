"""Kuttler and Shillor's gap-dependent exchange: q = k₁ exp(min(u(1) − g, 0)/ℓ).

Continuous in the end's displacement: k₁ in contact (u(1) ≥ g), falling off by a factor e for
every ℓ of gap; the heat crosses a narrow gap almost as well as the contact."""

from __future__ import annotations

import math

import numpy as np

from rodfem.model.exchange.law import ExchangeLaw


class GapLaw(ExchangeLaw):
    name = "gap"
    code = 2

    def __init__(self, k: float, temperature: float, k1: float, gap: float, length: float):
        super().__init__(k, temperature)
        self.k1, self.gap, self.length = float(k1), float(gap), float(length)

    def extra(self, y: float, p: float) -> float:
        return self.k1 * math.exp(min(y - self.gap, 0.0) / self.length)

    def coefficients(self, y, p) -> np.ndarray:
        y, p = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(p, dtype=float))
        return self.k + self.k1 * np.exp(np.minimum(y - self.gap, 0.0) / self.length)

    def extra_slopes(self, y: float, p: float) -> tuple[float, float]:
        if y >= self.gap:
            return 0.0, 0.0
        return self.extra(y, p) / self.length, 0.0

    def extra_at(self, gap: float, e: float, p: float) -> float:
        """k₁ exp(min(e, 0)/ℓ) with e = u(1) − g given exactly (``gap`` is the law's own g)."""
        return self.k1 * math.exp(min(e, 0.0) / self.length)

    def extra_slopes_at(self, gap: float, e: float, p: float) -> tuple[float, float]:
        if e >= 0.0:
            return 0.0, 0.0
        return self.extra_at(gap, e, p) / self.length, 0.0

    def extra_derivatives_at(self, gap: float, e: float, p: float) -> np.ndarray:
        """k₁ exp(e/ℓ)/ℓⁱ in D[i, 0] for e < 0; in contact q = k₁ is constant (one-sided from
        above at e = 0, as :meth:`extra_slopes_at`)."""
        found = np.zeros((4, 4))
        q = self.extra_at(gap, e, p)
        found[0, 0] = q
        if e < 0.0:
            for i in range(1, 4):
                found[i, 0] = q / self.length**i
        return found

    def extra_slope_bounds(self, y_lo: float, y_hi: float, p_lo: float,
                           p_hi: float) -> tuple[float, float]:
        """∂q/∂y = q/ℓ grows with y up to its left limit k₁/ℓ at g, and is 0 beyond: q(y_hi)/ℓ
        bounds it (q is continuous)."""
        return self.extra(y_hi, p_hi) / self.length, 0.0
