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

The search runs in the excess t = s − g, the laws evaluated at the offset u(1) − g and the
penetration themselves: near g the doubles of s are 3.5e-18 apart at g = 0.02, while a pressure
law q = k₁ p^m with m = 0.1 puts the touching state at p = 1.5e-37 and the gap law with
ℓ = 1e-300 puts it 8e-300 short of g. In s, F jumps across one spacing there and the bisection
stops at a jump, not at a root. Every state carries the residual of its equation and that
residual's round-off (:meth:`Steady.state`): a root beyond the doubles' range (m = 0.001 needs
p ≈ 1e-3700) is still a jump, and its state says so (``resolved`` false).

P1 on this 1D problem is exact at the nodes (the H¹_E projection interpolates), so the scheme's
steady states are these at the nodes.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

MAX_EVALUATIONS = 1_000_000  # of F; the search needs a few hundred per root
# How many times the bracket is halved: intervals of 2⁻²⁶ of it (√ε_mach), all of one width.
# Near a double root s − F grows as the square of the distance, so that two roots closer than
# this are one tangential root to the round-off of s − F. A root where s − F changes sign is
# then bisected to adjacent doubles.
DEPTH = 26
EPS = float(np.finfo(float).eps)
# A state's residual within this × eps of its scale is round-off (the few roundings of θ(1)
# and of a (θ_A + θ(1))/2 − g, and t's own); measured up to 11 on the tests' random scenes.
ROUNDOFF = 32.0


class SearchError(RuntimeError):
    """The root search would not end (F is not the monotone function it should be)."""


@dataclasses.dataclass(frozen=True)
class SteadyState:
    """One steady state: the end's displacement u(1), the contact force p = −σ(1), the end's
    temperature θ(1) and the exchange coefficient h there, and s = u(1) + p; ``offset`` is
    u(1) − g held exactly (u(1) rounds it to the doubles near g) and ``excess`` t = s − g.
    ``residual`` is that of the steady equation u(1) + p = a (θ_A + θ(1))/2 at the state, and
    ``tolerance`` its round-off there (:meth:`Steady.state`)."""

    u_1: float
    p: float
    theta_1: float
    h: float
    s: float
    contact: bool
    tangential: bool  # a double root: the state sits on a fold of the branches
    theta_A: float
    a: float
    offset: float = 0.0
    excess: float = 0.0
    residual: float = 0.0
    tolerance: float = math.inf

    @property
    def resolved(self) -> bool:
        """Whether the state satisfies its equation to round-off: a root, not a jump of the
        equation between two adjacent doubles."""
        return abs(self.residual) <= self.tolerance

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
    (a law of :mod:`rodfem.model.exchange`: its ``k``, ``temperature`` θ_O and ``extra`` q).

    The search runs in the excess t = s − g, in which the laws are evaluated at the offset
    e = u(1) − g and the penetration themselves: a state whose u(1) lies closer to g than the
    doubles near g resolve (a contact pressure of 1e-37, a gap of 1e-300) is still found."""

    def __init__(self, a: float, theta_A: float, obstacle, exchange):
        self.a, self.theta_A = float(a), float(theta_A)
        self.obstacle, self.exchange = obstacle, exchange
        self.gap = float(obstacle.gap)
        self.evaluations = 0

    def end(self, t: float) -> tuple[float, float]:
        """(e, p) of the end whose excess is t: the offset e = u(1) − g and the force p with
        e + p = t (the rigid obstacle's end: e = min(t, 0))."""
        if t <= 0.0:
            return t, 0.0
        if self.obstacle.rigid:
            return 0.0, t
        return self.obstacle.penetration(t)

    def end_temperature(self, h: float) -> float:
        """θ(1) = (θ_A + h θ_O)/(1 + h)."""
        return (self.theta_A + h * self.exchange.temperature) / (1.0 + h)

    def coefficient(self, t: float) -> float:
        """h = k + q at the end whose excess is t."""
        e, p = self.end(t)
        return self.exchange.k + self.exchange.extra_at(self.gap, e, p)

    def free(self, theta_1: float) -> float:
        """a (θ_A + θ(1))/2 − g: where the end would sit, past the gap, without contact."""
        return 0.5 * self.a * (self.theta_A + theta_1) - self.gap

    def F(self, t: float) -> float:
        """a (θ_A + θ(1))/2 − g at the end whose excess is t: its roots t = F(t) are the states."""
        self.evaluations += 1
        if self.evaluations > MAX_EVALUATIONS:
            raise SearchError(f"the steady states' search took more than {MAX_EVALUATIONS} "
                              "evaluations")
        return self.free(self.end_temperature(self.coefficient(t)))

    def bracket(self) -> tuple[float, float]:
        """[t₀, t₁] holding every root: F between h = k and h = ∞ (θ(1) = θ_O)."""
        ends = (self.free(self.end_temperature(self.exchange.k)),
                self.free(self.exchange.temperature))
        return min(ends), max(ends)

    def slope(self, t: float, e: float, p: float, h: float) -> float:
        """dF/dt at the end (e, p) whose excess is t, one-sided from below where t ≤ 0."""
        dq_dy, dq_dp = self.exchange.extra_slopes_at(self.gap, e, p)
        if t <= 0.0:
            de, dp = 1.0, 0.0
        elif self.obstacle.rigid:
            de, dp = 0.0, 1.0
        else:
            kappa = self.obstacle.pressure_slope(e)
            de, dp = (1.0 / (1.0 + kappa), kappa / (1.0 + kappa)) if math.isfinite(kappa) \
                else (0.0, 1.0)
        dq = (dq_dy * de if de else 0.0) + (dq_dp * dp if dp else 0.0)
        return 0.5 * self.a * (self.exchange.temperature - self.theta_A) / (1.0 + h) ** 2 * dq

    def separated(self, t: float) -> float | None:
        """The separated state near the excess t < 0 in u(1) itself: where u(1) is far from g,
        t = u(1) − g carries round-off of g, which the root of u − a (θ_A + θ(1))/2, bisected
        to adjacent doubles of u(1) across ROUNDOFF × eps × max(|g|, |u(1)|) about g + t, does
        not (None where it changes no sign there: the state is t's)."""
        def G(u: float) -> float:
            h = self.exchange.k + self.exchange.extra_at(self.gap, u - self.gap, 0.0)
            return u - 0.5 * self.a * (self.theta_A + self.end_temperature(h))

        u = self.gap + t
        reach = ROUNDOFF * EPS * max(abs(self.gap), abs(u))
        lo, hi = u - reach, min(u + reach, self.gap)
        g_lo, g_hi = G(lo), G(hi)
        if g_lo == 0.0 or g_hi == 0.0 or (g_lo < 0.0) == (g_hi < 0.0):
            return None
        while True:
            mid = lo + 0.5 * (hi - lo)
            if not lo < mid < hi:
                return lo if abs(g_lo) <= abs(g_hi) else hi
            g_mid = G(mid)
            if g_mid == 0.0:
                return mid
            if (g_mid < 0.0) == (g_lo < 0.0):
                lo, g_lo = mid, g_mid
            else:
                hi, g_hi = mid, g_mid

    def state(self, t: float, tangential: bool = False) -> SteadyState:
        """The steady state at the excess t, or the separated one found again in u(1)
        (:meth:`separated`) where that satisfies its equation in u(1) to round-off (it does
        not where the exchange changes within a spacing of the doubles near g)."""
        found = self._state(t, tangential)
        u_1 = self.separated(t) if t < 0.0 and not tangential else None
        if u_1 is None:
            return found
        again = self._state(u_1 - self.gap, tangential, u_1)
        return again if again.resolved else found

    def _state(self, t: float, tangential: bool, u_1: float | None = None) -> SteadyState:
        """The state at t (at u(1) = ``u_1`` if given), with the residual of its equation and
        that residual's round-off: ROUNDOFF × eps × (the scale of u(1), p, g and a θ, and
        |t F'(t)|, by which rounding t to a double moves F)."""
        e, p = self.end(t)
        h = self.exchange.k + self.exchange.extra_at(self.gap, e, p)
        theta_1 = self.end_temperature(h)
        contact = p > 0.0 or (self.obstacle.rigid and e >= 0.0)
        residual = (e + p) - self.free(theta_1) if u_1 is None else \
            u_1 - 0.5 * self.a * (self.theta_A + theta_1)
        scale = max(abs(self.gap), abs(self.gap + e), p, abs(self.a) * max(
            abs(self.theta_A), abs(self.exchange.temperature), abs(theta_1)))
        sensitivity = abs(t * self.slope(t, e, p, h))
        if math.isfinite(sensitivity):
            scale += sensitivity
        return SteadyState(u_1=self.gap + e if u_1 is None else u_1, p=p, theta_1=theta_1, h=h, s=self.gap + t,
                           contact=bool(contact), tangential=tangential,
                           theta_A=self.theta_A, a=self.a, offset=e, excess=t,
                           residual=residual, tolerance=ROUNDOFF * EPS * scale)

    def linearise(self, state: SteadyState) -> Linearisation:
        """The laws at x = 1 linearised about ``state`` (one-sided slopes at a kink)."""
        held = bool(self.obstacle.rigid and state.contact)
        kappa = 0.0 if self.obstacle.rigid or state.excess <= 0.0 else \
            self.obstacle.pressure_slope(state.offset)
        dq_dy, dq_dp = self.exchange.extra_slopes_at(self.gap, state.offset, state.p)
        jump = state.theta_1 - self.exchange.temperature
        # ∂q/∂p may be infinite at p = 0 (a pressure law with m < 1): only κ > 0 takes it
        through_p = dq_dp * kappa if kappa > 0.0 else 0.0
        return Linearisation(h=state.h, kappa=kappa, exchange_u=jump * (dq_dy + through_p),
                             exchange_p=jump * dq_dp if held else 0.0, held=held)

    def roots(self) -> list[tuple[float, bool]]:
        """Every root t of t = F(t), increasing, each with whether it is tangential."""
        lo, hi = self.bracket()
        if lo == hi:
            return [(lo, False)]
        self.evaluations = 0
        leaves = []
        stack = [(lo, self.F(lo), hi, self.F(hi), 0)]
        while stack:
            s0, f0, s1, f1, depth = stack.pop()
            if s0 - max(f0, f1) > 0.0 or s1 - min(f0, f1) < 0.0:
                continue  # t − F(t) cannot vanish on [s0, s1]
            mid = s0 + 0.5 * (s1 - s0)
            if depth == DEPTH or not s0 < mid < s1:
                leaves.append((s0, s0 - f0, s1, s1 - f1))
                continue
            fm = self.F(mid)
            stack.append((mid, fm, s1, f1, depth + 1))
            stack.append((s0, f0, mid, fm, depth + 1))  # popped first: leaves come in order
        found = []
        for cluster in _clusters(leaves):
            points = [leaf[:2] for leaf in cluster] + [cluster[-1][2:]]  # (t, t − F) in order
            crossing = [s for s, g in points if g == 0.0] + [
                self._refined(s0, g0, s1, g1) for (s0, g0), (s1, g1) in zip(points, points[1:])
                if g0 != 0.0 and g1 != 0.0 and (g0 < 0.0) != (g1 < 0.0)]
            if crossing:
                found.extend((s, False) for s in sorted(crossing))
            else:  # t − F touches 0 here without crossing, within the resolution: a fold
                found.append((min((abs(g), s) for s, g in points)[1], True))
        return found

    def _refined(self, s0: float, g0: float, s1: float, g1: float) -> float:
        """The root where t − F changes sign on [s0, s1], bisected to adjacent doubles."""
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
        return [self.state(t, tangential) for t, tangential in self.roots()]


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
