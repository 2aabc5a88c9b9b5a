r"""Every steady state of the model: the rod at rest against its obstacle, heat crossing the
contact by the scene's heat-exchange law.

At rest (u_t = θ_t = 0) the heat equation gives θ_xx = 0, θ(0) = θ_A and −θ_x(1) = h (θ(1) − θ_O),
so θ is linear with

    θ(1) = (θ_A + h θ_O)/(1 + h),      h = k + q(u(1), p),

and the momentum equation gives a constant stress σ = u_x − aθ, so u(x) = σ x + a ∫₀ˣ θ and
u(1) = σ + a (θ_A + θ(1))/2, with σ = −p, p the obstacle's force at u(1). In the variable
s = u(1) + p, which increases strictly along the end's states for every contact law (the rigid
obstacle's too: u(1) = min(s, g), p = [s − g]₊), the steady states are the roots of

    s = F(s) = a (θ_A + θ(1))/2,

where q, hence h, is non-decreasing in s and θ(1) is monotone in h (increasing if θ_O > θ_A):
F is monotone and continuous, and bounded by its values at h = k and h = ∞ (θ(1) = θ_O). On an
interval [s₀, s₁], s − F(s) lies in [s₀ − max F, s₁ − min F] with F's extremes at the ends: an
interval where that excludes 0 holds no root. :meth:`Steady.states` halves every interval it
cannot exclude down to 2⁻²⁶ of the bracket, so it cannot miss a root: where s − F changes sign
across what is left, the root is bisected to adjacent doubles; where it touches 0 without a
change of sign, the root is a tangential one (a fold of the branches), to the resolution that
round-off allows near a double root.

P1 on this 1D problem is exact at the nodes (the H¹_E projection interpolates), so the scheme's
steady states are these at the nodes.
"""

from __future__ import annotations

import dataclasses

import numpy as np

MAX_EVALUATIONS = 1_000_000  # of F; the search needs a few hundred per root
# How many times the bracket is halved: intervals of 2⁻²⁶ of it (√ε_mach), all of one width.
# Near a double root s − F grows as the square of the distance, so that two roots closer than
# this are one tangential root to the round-off of s − F. A root where s − F changes sign is
# then bisected to adjacent doubles.
DEPTH = 26


class SearchError(RuntimeError):
    """The root search would not end (F is not the monotone function it should be)."""


@dataclasses.dataclass(frozen=True)
class SteadyState:
    """One steady state: the end's displacement u(1), the contact force p = −σ(1), the end's
    temperature θ(1) and the exchange coefficient h there, and s = u(1) + p."""

    u_1: float
    p: float
    theta_1: float
    h: float
    s: float
    contact: bool
    tangential: bool  # a double root: the state sits on a fold of the branches
    theta_A: float
    a: float

    @property
    def sigma_1(self) -> float:
        """The constant stress σ = −p (no −0)."""
        return -self.p + 0.0

    def temperature(self, x: np.ndarray) -> np.ndarray:
        """θ(x) = θ_A + (θ(1) − θ_A) x."""
        return self.theta_A + (self.theta_1 - self.theta_A) * np.asarray(x)

    def displacement(self, x: np.ndarray) -> np.ndarray:
        """u(x) = σ x + a (θ_A x + (θ(1) − θ_A) x²/2)."""
        x = np.asarray(x)
        return self.sigma_1 * x + self.a * (self.theta_A * x + (self.theta_1 - self.theta_A)
                                            * x**2 / 2.0)


@dataclasses.dataclass(frozen=True)
class Linearisation:
    """What the dynamic problem linearised about a steady state needs of the laws at x = 1
    (:mod:`rodfem.solver.spectrum`): the exchange coefficient h; the contact's slope
    κ = dp/du(1) (0 when separated); the change of the exchange flux h (θ(1) − θ_O) with the
    end's place at fixed θ, c_u = (θ(1) − θ_O)(∂q/∂u(1) + ∂q/∂p κ), and with the contact force,
    c_p = (θ(1) − θ_O) ∂q/∂p; ``held``: the rigid obstacle in contact holds u(1), p its reaction."""

    h: float
    kappa: float
    exchange_u: float
    exchange_p: float
    held: bool


class Steady:
    """The steady states of a rod with coupling ``a`` and end temperature ``theta_A`` against
    ``obstacle`` (a contact law of :mod:`rodfem.model.contact`) exchanging heat by ``exchange``
    (a law of :mod:`rodfem.model.exchange`: its ``k``, ``temperature`` θ_O and ``extra`` q)."""

    def __init__(self, a: float, theta_A: float, obstacle, exchange):
        self.a, self.theta_A = float(a), float(theta_A)
        self.obstacle, self.exchange = obstacle, exchange
        self.evaluations = 0

    def end(self, s: float) -> tuple[float, float]:
        """(u(1), p) of the end whose s = u(1) + p: p solves u + p(u) = s (the law's own solve
        with compliance 1; the rigid obstacle's end is min(s, g))."""
        p = self.obstacle.solve(s, 1.0)
        if self.obstacle.rigid:
            return min(s, self.obstacle.gap), p
        return s - p, p

    def end_temperature(self, h: float) -> float:
        """θ(1) = (θ_A + h θ_O)/(1 + h)."""
        return (self.theta_A + h * self.exchange.temperature) / (1.0 + h)

    def coefficient(self, s: float) -> float:
        """h = k + q at the end whose s is given."""
        y, p = self.end(s)
        return self.exchange.k + self.exchange.extra(y, p)

    def F(self, s: float) -> float:
        """a (θ_A + θ(1))/2 at the end whose s is given."""
        self.evaluations += 1
        if self.evaluations > MAX_EVALUATIONS:
            raise SearchError(f"the steady states' search took more than {MAX_EVALUATIONS} "
                              "evaluations")
        return 0.5 * self.a * (self.theta_A + self.end_temperature(self.coefficient(s)))

    def bracket(self) -> tuple[float, float]:
        """[s₀, s₁] holding every root: F between h = k and h = ∞ (θ(1) = θ_O)."""
        ends = (0.5 * self.a * (self.theta_A + self.end_temperature(self.exchange.k)),
                0.5 * self.a * (self.theta_A + self.exchange.temperature))
        return min(ends), max(ends)

    def state(self, s: float, tangential: bool = False) -> SteadyState:
        """The steady state at s."""
        y, p = self.end(s)
        h = self.exchange.k + self.exchange.extra(y, p)
        contact = p > 0.0 or (self.obstacle.rigid and y >= self.obstacle.gap)
        return SteadyState(u_1=y, p=p, theta_1=self.end_temperature(h), h=h, s=s,
                           contact=bool(contact), tangential=tangential,
                           theta_A=self.theta_A, a=self.a)

    def linearise(self, state: SteadyState) -> Linearisation:
        """The laws at x = 1 linearised about ``state`` (one-sided slopes at a kink)."""
        held = bool(self.obstacle.rigid and state.contact)
        kappa = 0.0 if self.obstacle.rigid else self.obstacle.slope(state.u_1)
        dq_dy, dq_dp = self.exchange.extra_slopes(state.u_1, state.p)
        jump = state.theta_1 - self.exchange.temperature
        # ∂q/∂p may be infinite at p = 0 (a pressure law with m < 1): only κ > 0 takes it
        through_p = dq_dp * kappa if kappa > 0.0 else 0.0
        return Linearisation(h=state.h, kappa=kappa, exchange_u=jump * (dq_dy + through_p),
                             exchange_p=jump * dq_dp if held else 0.0, held=held)

    def roots(self) -> list[tuple[float, bool]]:
        """Every root s of s = F(s), increasing, each with whether it is tangential."""
        lo, hi = self.bracket()
        if lo == hi:
            return [(lo, False)]
        self.evaluations = 0
        leaves = []
        stack = [(lo, self.F(lo), hi, self.F(hi), 0)]
        while stack:
            s0, f0, s1, f1, depth = stack.pop()
            if s0 - max(f0, f1) > 0.0 or s1 - min(f0, f1) < 0.0:
                continue  # s − F(s) cannot vanish on [s0, s1]
            mid = s0 + 0.5 * (s1 - s0)
            if depth == DEPTH or not s0 < mid < s1:
                leaves.append((s0, s0 - f0, s1, s1 - f1))
                continue
            fm = self.F(mid)
            stack.append((mid, fm, s1, f1, depth + 1))
            stack.append((s0, f0, mid, fm, depth + 1))  # popped first: leaves come in order
        found = []
        for cluster in _clusters(leaves):
            points = [leaf[:2] for leaf in cluster] + [cluster[-1][2:]]  # (s, s − F) in order
            crossing = [s for s, g in points if g == 0.0] + [
                self._refined(s0, g0, s1, g1) for (s0, g0), (s1, g1) in zip(points, points[1:])
                if g0 != 0.0 and g1 != 0.0 and (g0 < 0.0) != (g1 < 0.0)]
            if crossing:
                found.extend((s, False) for s in sorted(crossing))
            else:  # s − F touches 0 here without crossing, within the resolution: a fold
                found.append((min((abs(g), s) for s, g in points)[1], True))
        return found

    def _refined(self, s0: float, g0: float, s1: float, g1: float) -> float:
        """The root where s − F changes sign on [s0, s1], bisected to adjacent doubles."""
        while g0 != 0.0 and g1 != 0.0:
            mid = s0 + 0.5 * (s1 - s0)
            if not s0 < mid < s1:
                break
            gm = mid - self.F(mid)
            if (gm < 0.0) == (g0 < 0.0):
                s0, g0 = mid, gm
            else:
                s1, g1 = mid, gm
        return s0 if abs(g0) <= abs(g1) else s1

    def states(self) -> list[SteadyState]:
        """Every steady state, in increasing u(1) (and s)."""
        return [self.state(s, tangential) for s, tangential in self.roots()]


def _clusters(leaves):
    """Runs of leaves that touch end to start."""
    runs: list[list] = []
    for leaf in leaves:
        if runs and runs[-1][-1][2] == leaf[0]:
            runs[-1].append(leaf)
        else:
            runs.append([leaf])
    return runs


def of_scene(scene) -> Steady:
    """The steady states' problem of a validated scene."""
    from rodfem.model import contact, exchange

    return Steady(scene["model.a"], scene["model.theta_A"], contact.of_scene(scene),
                  exchange.of_scene(scene))


def stationary(x: np.ndarray, a: float, theta_A: float, k: float, epsilon: float, gap: float):
    """u*(x) and the constant stress σ* of the paper's one steady state (the constant law, an
    obstacle at temperature 0, the linear contact law), in closed form.

    θ* = θ_A (1 − c x), c = k/(k+1), so u*(1) = σ + U*, U* = a θ_A (1 − c/2); without contact
    (U* ≤ g) σ = 0, with it σ = −(u*(1) − g)/ε gives σ = (g − U*)/(1 + ε). The shifted
    temperature Θ* = θ* + θ_A r vanishes."""
    c = k / (k + 1.0)
    free = a * theta_A * (1.0 - c / 2.0)
    sigma = (gap - free) / (1.0 + epsilon) if free > gap else 0.0
    return sigma * x + a * theta_A * (x - c * x**2 / 2.0), sigma
