r"""Branches of steady states followed through a scene value by pseudo-arclength continuation,
with their folds and grazing points located.

The steady states are the roots t of one scalar equation (:mod:`rodfem.model.steady`),

    R(t, λ) = t − F(t; λ) = 0,

t = u(1) + p − g the end's excess and λ the scene value continued over: the branches are the
curves of R = 0 in the (t, λ) plane. They are followed in coordinates scaled by the spans of t
and of λ, from every state at either end of the range, by pseudo-arclength steps: a step ds
along the tangent (R_λ, −R_t) then back onto the curve along the normal, a scalar root found by
Newton's method kept inside a bracket. The step grows where the curve is straight and shrinks
where it turns, so that folds, where the branch turns back in λ, are passed like any other point.

What is located on a branch, each to the doubles' resolution in λ:

* a **grazing point**, where the branch crosses t = 0: the free end (t < 0) meets the obstacle
  and presses it (t > 0). There R(0, λ) = 0, a scalar equation in λ, solved by bracketed
  secant steps. R's slope in t jumps there (the contact and exchange laws change), and where it
  changes sign the branch turns back at the grazing point itself (``turns``): a corner fold, as in
  Barber's hot obstacle, where a free stable branch ends and a pressed unstable one begins;
* a **fold**, where R_t = 1 − F'(t) changes sign along a smooth piece of the branch: the branch
  turns back in λ, and one state's eigenvalue passes through 0. Near it λ(t), the root of
  R(t, λ) = 0 at fixed t, has an extremum, which is found as the root of R_t(t, λ(t)) in t: λ at
  the fold is then as accurate as the equation's round-off (an error δt in t moves λ by δt²).

A scene value that changes no steady state (a model's ζ or b) gives vertical branches t =
const: they are followed all the same, for the spectra along them (:mod:`.points`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rodfem.model import steady

# Steps along a branch, in the scaled plane (the spans of t and λ are 1): the first one, the
# largest, and the smallest before the branch is given up.
FIRST_STEP, MAX_STEP, MIN_STEP = 0.01, 0.04, 1e-9
# The tangent may turn by at most this angle (radians) over one step: beyond it the step is
# halved, so that a branch is drawn smoothly and a turn is not jumped over.
MAX_TURN = 0.2
MAX_POINTS = 5000  # on one branch
EPS = float(np.finfo(float).eps)
# A point of R = 0 found by Newton's method: |R| within this of t's span (round-off is 1e-15 of
# it; a step that stalls on a steep slope leaves more, and the search for a change of sign
# takes over).
RESIDUAL = 1e-12


class ContinuationError(RuntimeError):
    """A branch that cannot be followed (its step fell below :data:`MIN_STEP`)."""


def at(scene, key: str, value: float):
    """``scene`` with ``key`` set to ``value``: no new validation (the ends of the range are
    validated, and the schema's bounds are intervals)."""
    section, _, name = key.partition(".")
    sections = {s: dict(keys) for s, keys in scene.sections.items()}
    sections[section][name] = int(value) if isinstance(sections[section][name], int) \
        else float(value)
    return dataclasses.replace(scene, sections=sections)


@dataclasses.dataclass(frozen=True)
class Point:
    """A point of a branch: the excess t and the value λ, and what it is (``kind``: a point
    followed, a ``grazing`` point or a ``fold``; ``end`` at an end of the range)."""

    t: float
    value: float
    kind: str = ""
    turns: bool = False



class Curve:
    """R(t, λ) = t − F(t; λ) over ``key`` of ``scene``, for λ in [lo, hi], in the plane scaled
    by t's span (the roots' brackets at both ends, and the gap) and λ's (hi − lo)."""

    def __init__(self, scene, key: str, lo: float, hi: float):
        self.scene, self.key, self.lo, self.hi = scene, key, float(lo), float(hi)
        self._problems: dict[float, steady.Steady] = {}
        brackets = [self.problem(v).bracket() for v in (self.lo, self.hi)]
        width = max(max(b) - min(b) for b in brackets)
        self.t_scale = max(width, abs(scene["obstacle.gap"]), 1e-300)
        self.v_scale = self.hi - self.lo

    def scene_at(self, value: float):
        return at(self.scene, self.key, value)

    def problem(self, value: float) -> steady.Steady:
        found = self._problems.get(value)
        if found is None:
            if len(self._problems) > 256:
                self._problems.clear()
            found = self._problems[value] = steady.of_scene(self.scene_at(value))
        return found

    def residual(self, t: float, value: float) -> float:
        return t - self.problem(value).F(t)

    def slope_t(self, t: float, value: float, side: int) -> float:
        """R_t = 1 − F'(t), one-sided at t = 0: from below (``side`` < 0) or above (> 0)."""
        problem = self.problem(value)
        if side > 0 and t <= 0.0:
            t = 1e-300  # the first contact's laws (their slopes at p → 0⁺)
        e, p = problem.end(t)
        return 1.0 - problem.slope(t, e, p, problem.coefficient(t))

    def slope_value(self, t: float, value: float) -> float:
        """R_λ by differences, central where both sides lie in [lo, hi]."""
        step = 1e-6 * self.v_scale
        lo, hi = max(value - step, self.lo), min(value + step, self.hi)
        return (self.residual(t, hi) - self.residual(t, lo)) / (hi - lo)

    def scaled(self, t: float, value: float) -> np.ndarray:
        return np.array([t / self.t_scale, value / self.v_scale])

    def unscaled(self, x: np.ndarray) -> tuple[float, float]:
        return float(x[0] * self.t_scale), float(x[1] * self.v_scale)

    def gradient(self, x: np.ndarray, side: int) -> np.ndarray:
        """∇R in the scaled plane at x, its t-slope from the side ``side`` of t = 0."""
        t, value = self.unscaled(x)
        return np.array([self.slope_t(t, value, side) * self.t_scale,
                         self.slope_value(t, value) * self.v_scale])

    def tangent(self, x: np.ndarray, side: int, along: np.ndarray | None = None) -> np.ndarray:
        """The unit tangent at x (an infinite slope in t: along t), pointing as ``along``."""
        g = self.gradient(x, side)
        if not math.isfinite(g[0]):
            g = np.array([1.0, 0.0])
        tangent = np.array([-g[1], g[0]]) / np.hypot(*g)
        return tangent if along is None or tangent @ along >= 0.0 else -tangent

    def on_line(self, origin: np.ndarray, direction: np.ndarray, reach: float):
        """The point of R = 0 on origin + s·direction (|direction| = 1) with |s| ≤ reach
        nearest s = 0: Newton's method, kept inside a bracket once it has one, and a search for
        a change of sign outward from 0 where it fails (None: none)."""
        def g(s: float) -> float:
            t, value = self.unscaled(origin + s * direction)
            return self.residual(t, value) / self.t_scale

        def slope(s: float) -> float:
            x = origin + s * direction
            return float(self.gradient(x, 1 if x[0] > 0.0 else -1) @ direction) / self.t_scale

        s, gs = 0.0, g(0.0)
        bracket: tuple[float, float] | None = None
        for _ in range(60):
            if gs == 0.0:
                return origin + s * direction
            d = slope(s)
            new = s - gs / d if d != 0.0 and math.isfinite(d) else math.nan
            if bracket is not None and not min(bracket) < new < max(bracket):
                new = 0.5 * (bracket[0] + bracket[1])
            if not math.isfinite(new) or abs(new) > reach:
                break
            g_new = g(new)
            if (g_new < 0.0) != (gs < 0.0):
                bracket = (s, new)
            if abs(new - s) <= 2.0 * EPS * max(abs(new), 1e-3 * reach) and \
                    abs(g_new) <= RESIDUAL:
                return origin + new * direction
            s, gs = new, g_new
        found = _sign_change(g, reach)
        return None if found is None else origin + found * direction


def _sign_change(g, reach: float) -> float | None:
    """The root of g nearest 0 in [−reach, reach] from a change of sign among 16 samples each
    way, by Brent's method to the doubles (None: no change of sign)."""
    import scipy.optimize

    g0 = g(0.0)
    if g0 == 0.0:
        return 0.0
    best = None
    for sign in (1.0, -1.0):
        before, g_before = 0.0, g0
        for j in range(1, 17):
            s = sign * reach * j / 16.0
            gs = g(s)
            if gs == 0.0 or (gs < 0.0) != (g_before < 0.0):
                root = s if gs == 0.0 else float(scipy.optimize.brentq(
                    g, min(before, s), max(before, s), xtol=1e-300, rtol=4 * EPS))
                if best is None or abs(root) < abs(best):
                    best = root
                break
            before, g_before = s, gs
    return best


def _side(t: float) -> int:
    """The side of t = 0: contact (1) or free (−1, t ≤ 0)."""
    return 1 if t > 0.0 else -1


class Tracer:
    """Follows the branches of a :class:`Curve` and locates their points (the module's doc)."""

    def __init__(self, curve: Curve):
        self.curve = curve

    def follow(self, t: float, value: float, upward: bool) -> list[Point]:
        """The branch through the state (t, value), followed from it with λ increasing
        (``upward``) or decreasing, until it leaves [lo, hi]: its points in order, with the
        grazing points and folds on it."""
        curve = self.curve
        x = curve.scaled(t, value)
        points = [Point(t, value, "end" if value in (curve.lo, curve.hi) else "")]
        tangent = curve.tangent(x, _side(t), np.array([0.0, 1.0 if upward else -1.0]))
        if tangent[1] == 0.0:  # on a fold at the end: along t, into the range
            tangent = np.array([1.0, 0.0])
        ds = FIRST_STEP
        while len(points) < MAX_POINTS:
            if ds < MIN_STEP:
                raise ContinuationError(
                    f"the branch through {curve.key} = {points[-1].value:.10g} could not be "
                    "followed further (its step fell below the smallest allowed)")
            here = points[-1]
            predicted = x + ds * tangent
            v_predicted = curve.unscaled(predicted)[1]
            if not curve.lo <= v_predicted <= curve.hi:
                end = self.boundary(here, predicted, ds)
                if end is not None:
                    points.append(end)
                    return points
                ds *= 0.5
                continue
            found = curve.on_line(predicted, np.array([-tangent[1], tangent[0]]), 2.0 * ds)
            # the step crosses t = 0 (predicted or found): to the grazing point there
            beyond = predicted if found is None else found
            t_new, v_new = curve.unscaled(beyond)
            if here.t != 0.0 and _side(t_new) != _side(here.t):
                graze = self.grazing(here, Point(t_new, v_new))
                if graze is None or np.hypot(*(curve.scaled(0.0, graze.value) - x)) > 2.0 * ds:
                    ds *= 0.5
                    continue
                points.append(graze)
                x = curve.scaled(0.0, graze.value)
                side = _side(t_new)
                tangent = curve.tangent(x, side, np.array([float(side), 0.0]))
                ds = FIRST_STEP
                continue
            if found is None or not curve.lo <= v_new <= curve.hi:
                ds *= 0.5
                continue
            turned = curve.tangent(found, _side(t_new) if t_new != 0.0 else _side(here.t),
                                   tangent)
            if float(turned @ tangent) < math.cos(MAX_TURN) and ds > 16 * MIN_STEP:
                ds *= 0.5
                continue
            fold = self.fold(here, Point(t_new, v_new))
            if fold is not None:
                points.append(fold)
            points.append(Point(t_new, v_new))
            x, tangent = found, turned
            ds = min(1.5 * ds, MAX_STEP)
        return points

    def grazing(self, before: Point, after: Point) -> Point | None:
        """The point where the branch crosses t = 0 between two of its points: the root of
        R(0, λ) = 0 near them, and whether the branch turns back in λ there (R_t changes sign
        across it)."""
        curve = self.curve
        lo, hi = sorted((before.value, after.value))
        width = max(hi - lo, 1e-3 * curve.v_scale)
        value = _root(lambda v: curve.residual(0.0, v), max(lo - width, curve.lo),
                      min(hi + width, curve.hi), lo, hi)
        if value is None:
            return None
        below, above = curve.slope_t(0.0, value, -1), curve.slope_t(0.0, value, 1)
        return Point(0.0, value, "grazing", turns=bool(below * above < 0.0))

    def fold(self, before: Point, after: Point) -> Point | None:
        """A fold between two points of one side of t = 0 where R_t changes sign: the
        extremum of λ(t), the root of R_t(t, λ(t)) (None: R_t keeps its sign)."""
        curve = self.curve
        side = _side(before.t) if before.t != 0.0 else _side(after.t)
        r0 = curve.slope_t(before.t, before.value, side)
        r1 = curve.slope_t(after.t, after.value, side)
        if not (math.isfinite(r0) and math.isfinite(r1)) or (r0 < 0.0) == (r1 < 0.0) \
                or r0 == 0.0 or r1 == 0.0:
            return None
        value_at = _ValueAt(curve, before, after)
        lo, hi = sorted((before.t, after.t))
        if side > 0:
            lo = max(lo, math.ulp(0.0))
        t = _root(lambda t: curve.slope_t(t, value_at(t), side), lo, hi, lo, hi)
        if t is None:
            return None
        return Point(t, value_at(t), "fold")

    def boundary(self, here: Point, predicted: np.ndarray, ds: float) -> Point | None:
        """The branch's point at the end of the range the step to ``predicted`` crossed:
        R(t, end) = 0 for t near the chord's."""
        curve = self.curve
        t_p, v_p = curve.unscaled(predicted)
        value = curve.hi if v_p > curve.hi else curve.lo
        share = (value - here.value) / (v_p - here.value)
        t = here.t + share * (t_p - here.t)
        found = curve.on_line(curve.scaled(t, value), np.array([1.0, 0.0]), 2.0 * ds)
        if found is None:
            return None
        t_end = curve.unscaled(found)[0]
        if here.t != 0.0 and _side(t_end) != _side(here.t):
            return None  # a grazing point first: a smaller step finds it
        return Point(t_end, value, "end")


class _ValueAt:
    """λ(t): the root of R(t, λ) = 0 in λ near a branch's piece between two points, by Newton's
    method from the chord (R_λ ≠ 0 at a fold)."""

    def __init__(self, curve: Curve, before: Point, after: Point):
        self.curve, self.before, self.after = curve, before, after

    def __call__(self, t: float) -> float:
        curve, a, b = self.curve, self.before, self.after
        share = (t - a.t) / (b.t - a.t) if b.t != a.t else 0.5
        value = a.value + share * (b.value - a.value)
        for _ in range(50):
            r = curve.residual(t, value)
            d = curve.slope_value(t, value)
            if r == 0.0 or d == 0.0:
                break
            step = r / d
            value = min(max(value - step, curve.lo), curve.hi)
            if abs(step) <= 2.0 * EPS * max(abs(value), 1e-6 * curve.v_scale):
                break
        return value


def _root(f, lo: float, hi: float, inner_lo: float, inner_hi: float) -> float | None:
    """A root of f by Brent's method to the doubles, on [inner_lo, inner_hi] where f changes
    sign there, else on [lo, hi]; None where it changes sign on neither."""
    import scipy.optimize

    for a, b in ((inner_lo, inner_hi), (lo, hi)):
        if not a < b:
            continue
        fa, fb = f(a), f(b)
        if fa == 0.0:
            return a
        if fb == 0.0:
            return b
        if (fa < 0.0) != (fb < 0.0):
            return float(scipy.optimize.brentq(f, a, b, xtol=1e-300, rtol=4 * EPS,
                                               maxiter=400))
    return None


def branches(scene, key: str, lo: float, hi: float) -> list[list[Point]]:
    """Every branch through a state at either end of [lo, hi], each followed into the range
    once: a branch that reaches the other end, or comes back to its own, ends on a state found
    there, which starts no branch of its own."""
    curve = Curve(scene, key, lo, hi)
    tracer = Tracer(curve)
    starts = [(t, lo, True) for t, _ in curve.problem(lo).roots()] + \
             [(t, hi, False) for t, _ in curve.problem(hi).roots()]
    found: list[list[Point]] = []
    reached: list[Point] = []
    for t, value, upward in starts:
        if any(_same(curve, t, value, end) for end in reached):
            continue
        points = tracer.follow(t, value, upward)
        found.append(points)
        reached.append(points[-1])
    return found


def _same(curve: Curve, t: float, value: float, end: Point) -> bool:
    """Whether a branch's last point is the state (t, value) at an end of the range: the same
    end, t within a millionth of t's span."""
    return end.value == value and abs(end.t - t) <= 1e-6 * curve.t_scale
