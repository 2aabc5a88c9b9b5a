"""Where a step changes contact: the size of the step that ends there, found from the step's own
results (:class:`.stepper.AdaptiveStepper`'s steps of any size from the same start), to a
bracket EVENT_WIDTH wide in time; the compiled steps' ``ra_locate``
(rodfem/solver/compiled/adaptive.h) decides alike, in the same arithmetic.

Seen as a function of the step's size c, the contact function f(c) (> 0 where the obstacle
pushes) has a corner at its root: free motion on one side, the obstacle's response on the other
(a thousandfold flatter for a stiff one). A secant across the corner, as the Illinois method's,
gains only a constant factor a try; each side is smooth and vanishes at the root, so secants on
one side converge as on a smooth function. So:

* the first try is where the tangent at the start meets zero, its slope the end's velocity (not
  at an end without mass, whose D(1) is no velocity, nor for a rigid obstacle in contact, whose
  contact function is its multiplier's);
* each next one is the secant through the last two tries on the side of the latest, inside the
  bracket, tried PAST beyond its root where the bracket's changed end is the farther (the step
  ends just past the change), else a quarter bracket short of it (which closes the bracket);
* where there is no such guess, the Illinois method's point, a quarter bracket inside the
  bracket's ends, and bisection after 60 tries.
"""

from __future__ import annotations

EVENT_WIDTH = 1e-10  # the located event's bracket in time
# A guess at the root is tried this far past it, on the changed side (where the step ends): the
# event's state as close to the root as its contact function's round-off lets the side be told,
# and the same side told whatever the round-off of the method (tests/test_adaptive.py).
PAST = 1e-3 * EVENT_WIDTH


def locate(stepper, h: float, start: dict, fa: float, before: bool) -> float:
    """The step's size where contact changes, from the step h tried (the stepper's home at its
    end) and ``start``, the step's start, where the contact function is fa (> 0 where
    ``before``); the stepper's home is left at the far end of the bracket, contact changed."""
    a, b, fb = 0.0, h, stepper.contact()
    side, at_b, tries, made_b = 0, True, 0, None
    near, far = [0.0, fa], [h, fb]  # each side's last two tries, (c, f) pairs flattened
    while b - a > EVENT_WIDTH:
        tries += 1
        if tries == 1:
            c = tangent(stepper, start, fa, before)
        else:
            c = secant(far if side == -1 else near) if tries < 60 else None
        if c is not None and a < c < b:  # just past the root, or a quarter bracket short
            c = min(max(c + PAST if b - c > c - a else c - 0.25 * EVENT_WIDTH, a + PAST),
                    b - 0.25 * EVENT_WIDTH)
        else:
            c = b - fb * (b - a) / (fb - fa) if fb != fa and tries < 60 else 0.5 * (a + b)
            c = min(max(c, a + 0.25 * EVENT_WIDTH), b - 0.25 * EVENT_WIDTH)
        made = stepper._take(c, start)
        fc = stepper.contact()
        if (fc > 0.0) != before:
            b, fb, at_b, made_b = c, fc, True, made
            far[:] = far[-2:] + [c, fc]
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a, fa, at_b = c, fc, False
            near[:] = near[-2:] + [c, fc]
            if side == 1:
                fb *= 0.5
            side = 1
    if not at_b:
        stepper._take(b, start, made_b)
    return b


def tangent(stepper, start: dict, f: float, before: bool) -> float | None:
    """Where the contact function's tangent at the step's start meets zero, or None (the
    module's docstring)."""
    if stepper.norm.massless_end or (stepper.rigid and before):
        return None
    slope = float(start["state"][2 * stepper.nodes - 1]) / stepper.dt0
    return -f / slope if f * slope < 0.0 else None


def secant(pairs: list[float]) -> float | None:
    """Where the line through the last two (c, f) of a side meets zero, or None."""
    if len(pairs) < 4 or pairs[-1] == pairs[-3]:
        return None
    c1, f1, c2, f2 = pairs[-4:]
    return c2 - f2 * (c2 - c1) / (f2 - f1)
