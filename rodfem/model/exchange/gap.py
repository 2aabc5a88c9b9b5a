"""Kuttler and Shillor's gap-dependent exchange: q = k₁ exp(min(u(1) − g, 0)/ℓ).

Continuous in the end's displacement: k₁ in contact (u(1) ≥ g), falling off by a factor e for
every ℓ of gap; the heat crosses a narrow gap almost as well as the contact."""

from __future__ import annotations

import math

from rodfem.model.exchange.law import ExchangeLaw


class GapLaw(ExchangeLaw):
    name = "gap"

    def __init__(self, k: float, temperature: float, k1: float, gap: float, length: float):
        super().__init__(k, temperature)
        self.k1, self.gap, self.length = float(k1), float(gap), float(length)

    def extra(self, y: float, p: float) -> float:
        return self.k1 * math.exp(min(y - self.gap, 0.0) / self.length)

    def extra_slopes(self, y: float, p: float) -> tuple[float, float]:
        if y >= self.gap:
            return 0.0, 0.0
        return self.extra(y, p) / self.length, 0.0
