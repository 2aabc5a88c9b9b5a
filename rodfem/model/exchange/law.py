"""What every heat-exchange law provides; the constant law, the paper's.

A law gives q ≥ 0, the exchange the contact adds to k, as a function of the end's displacement
y = u(1) and the contact pressure p = −σ(1) ≥ 0, and its partial derivatives (Newton's Jacobian,
the linearisation of steady states). Everything else follows: h = k + q and the heat flux into
the obstacle h (θ(1) − θ_O).
"""

from __future__ import annotations

import numpy as np


class ExchangeLaw:
    """h = k + q(y, p) at x = 1, with the obstacle at θ_O = ``temperature``."""

    name = ""
    code = -1  # the law's number in rodfem/solver/compiled/exchange.h
    variable = True  # whether q can be other than 0
    k1 = 0.0

    def __init__(self, k: float, temperature: float = 0.0):
        self.k, self.temperature = float(k), float(temperature)

    def extra(self, y: float, p: float) -> float:
        """q at u(1) = y under the contact pressure p."""
        raise NotImplementedError

    def extra_slopes(self, y: float, p: float) -> tuple[float, float]:
        """(∂q/∂y, ∂q/∂p), one-sided (from above) at a kink."""
        raise NotImplementedError

    # The law at u(1) = g + e with the offset e from the obstacle's gap g given exactly, for the
    # steady states (rodfem.model.steady), which may sit far closer to g than the doubles near
    # it resolve. A law that does not depend on u(1) near g needs nothing more.

    def extra_at(self, gap: float, e: float, p: float) -> float:
        """q at u(1) = g + e under the contact pressure p."""
        return self.extra(gap + e, p)

    def extra_slopes_at(self, gap: float, e: float, p: float) -> tuple[float, float]:
        """(∂q/∂y, ∂q/∂p) at u(1) = g + e, one-sided (from above) at a kink."""
        return self.extra_slopes(gap + e, p)

    def extra_derivatives_at(self, gap: float, e: float, p: float) -> np.ndarray:
        """D[i, j] = ∂^(i+j) q/∂yⁱ ∂pʲ at u(1) = g + e under the pressure p, for i + j ≤ 3 (the
        rest 0): the law's Taylor expansion to third order, which the first Lyapunov
        coefficient of a Hopf point needs (:mod:`rodfem.model.expansion`). Where p = 0 only the
        derivatives in y are used (the end is separated, and p stays 0 about it)."""
        raise NotImplementedError

    def extra_slope_bounds(self, y_lo: float, y_hi: float, p_lo: float,
                           p_hi: float) -> tuple[float, float]:
        """Upper bounds of ∂q/∂y and ∂q/∂p on [y_lo, y_hi] × [p_lo, p_hi] (the direct step's
        uniqueness test, rodfem.solver.methods.exchange_step): the largest at the corners, for a
        law whose slopes are monotone there."""
        corners = [self.extra_slopes(y, p) for y in (y_lo, y_hi) for p in (p_lo, p_hi)]
        return max(c[0] for c in corners), max(c[1] for c in corners)

    def coefficient(self, y: float, p: float) -> float:
        """h = k + q."""
        return self.k + self.extra(y, p)

    def coefficients(self, y, p) -> np.ndarray:
        """h at each pair of entries of y and p (a law may give the same in NumPy's terms)."""
        y, p = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(p, dtype=float))
        return np.array([self.coefficient(a, b) for a, b in zip(y.ravel(), p.ravel(),
                                                                 strict=True)]).reshape(y.shape)

    def flux(self, theta_1, y, p) -> np.ndarray:
        """The heat flux into the obstacle, −θ_x(1) = h (θ(1) − θ_O)."""
        return self.coefficients(y, p) * (np.asarray(theta_1, dtype=float) - self.temperature)

    def offset(self, theta_A: float) -> float:
        """θ(1) − θ_O of the steady state of the constant law, (θ_A − θ_O)/(k + 1): the end's
        temperature above the obstacle's is the shifted temperature Θ(1) plus this
        (forms.copetti.exchange)."""
        return (theta_A - self.temperature) / (self.k + 1.0)


class ConstantLaw(ExchangeLaw):
    """h = k: the paper's −θ_x(1) = k θ(1) for θ_O = 0."""

    name = "constant"
    code = 0
    variable = False

    def extra(self, y: float, p: float) -> float:
        return 0.0

    def extra_slopes(self, y: float, p: float) -> tuple[float, float]:
        return 0.0, 0.0

    def coefficients(self, y, p) -> np.ndarray:
        y, p = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(p, dtype=float))
        return np.full(y.shape, self.k)

    def extra_derivatives_at(self, gap: float, e: float, p: float) -> np.ndarray:
        return np.zeros((4, 4))
