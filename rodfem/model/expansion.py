r"""The laws at x = 1 to third order about a steady state: all of the model's nonlinearity.

In the semi-discretisation M ẋ = f(x) that the spectra linearise (:mod:`rodfem.solver.spectrum`)
everything is linear except two terms at the end x = 1, each a function of the end's
temperature θ = θ(1) and displacement u = u(1) alone:

* the heat row of x = 1 holds the exchange −h(u) (θ − θ_O), with h(u) = k + q(u, P(u));
* the momentum row of x = 1 holds the obstacle's reaction −P(u), P(u) = φ'(u) the contact law's
  force (0 where separated).

About a state (θ*, u*) these expand as

    −h(u)(θ − θ_O) = −h (θ̃ + J) − h′ ũ J − h′ θ̃ ũ − h″ ũ² J/2 − h″ θ̃ ũ²/2 − h‴ ũ³ J/6 − …,
    −P(u) = −P − P′ ũ − P″ ũ²/2 − P‴ ũ³/6 − …,

J = θ* − θ_O, with h′, h″, h‴ the total derivatives of h along the contact law, by the chain
rule from the exchange law's partial derivatives D[i, j] = ∂^(i+j) q/∂yⁱ ∂pʲ
(``extra_derivatives_at``) and the contact law's P′, P″, P‴ (``pressure_derivatives``):

    h′ = D₁₀ + D₀₁ P′,
    h″ = D₂₀ + 2 D₁₁ P′ + D₀₂ P′² + D₀₁ P″,
    h‴ = D₃₀ + 3 D₂₁ P′ + 3 D₁₂ P′² + D₀₃ P′³ + 3 D₁₁ P″ + 3 D₀₂ P′ P″ + D₀₁ P‴.

A separated end (no penetration) has P ≡ 0 about it, and only the derivatives in y remain. The
rigid obstacle in contact holds u(1): its reaction is a multiplier, not a function of u, and it
has no expansion here (:attr:`Expansion.held`).
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Expansion:
    """The end's laws about a state: ``jump`` J = θ(1) − θ_O, ``h`` = (h, h′, h″, h‴) and
    ``force`` = (P, P′, P″, P‴) as functions of u(1); ``held``: the rigid obstacle in contact
    (no expansion)."""

    jump: float
    h: tuple[float, float, float, float]
    force: tuple[float, float, float, float]
    held: bool = False


def chain(D, P) -> tuple[float, float, float, float]:
    """(h − k, h′, h″, h‴) of h(u) = k + q(u, P(u)) from q's partial derivatives D[i, j] and
    (P, P′, P″, P‴) (the module's doc). Terms in P′, P″, P‴ are left out where these vanish (a
    separated end, where D's derivatives in p may be infinite)."""
    _, P1, P2, P3 = P

    def times(*factors) -> float:  # a product that is 0 if a law's factor is 0
        out = 1.0
        for f in factors:
            if f == 0.0:
                return 0.0
            out *= f
        return out

    h1 = D[1][0] + times(D[0][1], P1)
    h2 = D[2][0] + 2.0 * times(D[1][1], P1) + times(D[0][2], P1, P1) + times(D[0][1], P2)
    h3 = (D[3][0] + 3.0 * times(D[2][1], P1) + 3.0 * times(D[1][2], P1, P1)
          + times(D[0][3], P1, P1, P1) + 3.0 * times(D[1][1], P2) + 3.0 * times(D[0][2], P1, P2)
          + times(D[0][1], P3))
    return float(D[0][0]), float(h1), float(h2), float(h3)


def expand(steady, state) -> Expansion:
    """The end's laws of a :class:`~rodfem.model.steady.Steady` problem expanded about one of
    its :class:`~rodfem.model.steady.SteadyState`\\ s."""
    obstacle, exchange = steady.obstacle, steady.exchange
    jump = state.theta_1 - exchange.temperature
    if obstacle.rigid and state.contact:
        return Expansion(jump, (state.h, 0.0, 0.0, 0.0), (state.p, 0.0, 0.0, 0.0), held=True)
    pressed = (not obstacle.rigid) and state.excess > 0.0
    P = tuple(float(v) for v in obstacle.pressure_derivatives(state.offset)) if pressed \
        else (0.0, 0.0, 0.0, 0.0)
    D = exchange.extra_derivatives_at(steady.gap, state.offset, state.p)
    q, h1, h2, h3 = chain(D, P)
    return Expansion(jump, (exchange.k + q, h1, h2, h3), P)
