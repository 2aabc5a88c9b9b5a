"""Where a step changes contact, its size is found by secants on each side of the root
(rodfem.solver.adaptive.events; the compiled steps' ra_locate decides the same, tests/
test_adaptive_compiled.py): the contact function of the step's size is smooth on each side and
both sides vanish at the root, where they meet at an angle (free motion on one side, the
obstacle's response on the other). A secant across the angle, as the Illinois method's, gains
only a constant factor a try; secants on one side converge as on a smooth function.
"""

from types import SimpleNamespace

import numpy as np
import pytest

import rodfem.scene
from rodfem.run import simulate
from rodfem.solver.adaptive import compiled, events
from rodfem.solver.adaptive.events import EVENT_WIDTH, PAST
from rodfem.solver.adaptive.stepper import AdaptiveStepper


class Contact:
    """A stepper's contact function of the step's size c, and nothing else: f(c) as given, the
    end's velocity at the start v (the tangent's slope)."""

    rigid = False
    nodes, dt0 = 1, 1.0
    norm = SimpleNamespace(massless_end=False)

    def __init__(self, f, v: float, h: float):
        self.f, self.value, self.tries = f, f(h), []
        self.start = {"state": np.array([0.0, v, 0.0])}  # [Θ; D; U] of one node, D = Δt₀ v

    def _take(self, c: float, start, made=None):
        if made is None:  # a try (the bracket's far end is taken again with its method)
            self.tries.append(c)
        self.value = self.f(c)
        return c

    def contact(self) -> float:
        return self.value

    def locate(self, h: float) -> float:
        fa = self.f(0.0)
        return events.locate(self, h, self.start, fa, fa > 0.0)


ROOT, GAP, SPEED, SLOW = 0.3, 0.25, 1.0, 0.4  # the end meets the obstacle at c = ROOT


def approach(c: float) -> float:
    """An end that slows as it nears the obstacle, then is held by a stiff one: the slope drops
    a thousandfold at the root."""
    free = -GAP + SPEED * c - SLOW * c * c
    if c <= ROOT:
        return free - (-GAP + SPEED * ROOT - SLOW * ROOT * ROOT)
    return 1e-3 * (c - ROOT)


@pytest.mark.parametrize("v", [SPEED, 0.0], ids=["tangent", "no tangent"])
def test_an_event_behind_an_angle_is_bracketed_in_a_few_tries(v):
    """The root to the bracket's width, the step ending just past it (a secant's guess is tried
    PAST beyond its root), in at most 6 tries (measured: 6 from the tangent, 3 from the Illinois
    method's first point, whose next secant runs along the straight side; the Illinois method
    took 72, its last 12 bisections)."""
    stepper = Contact(approach, v, h=1.0)
    b = stepper.locate(1.0)
    assert ROOT < b <= ROOT + 2 * PAST
    assert stepper.value == approach(b) > 0.0  # home is left at the far end
    assert len(stepper.tries) <= 6, stepper.tries


def test_the_tangent_is_not_followed_where_it_leads_away():
    """An end moving away from the obstacle gives no first guess; the root is found all the
    same."""
    stepper = Contact(approach, -1.0, h=1.0)
    assert events.tangent(stepper, stepper.start, approach(0.0), False) is None
    b = stepper.locate(1.0)
    assert ROOT < b <= ROOT + EVENT_WIDTH


CASES = {  # short runs with events; the most tries the Illinois method took for one of them
    "stiff paper": (("stiff", ["time.end=0.3"]), 15),
    "stiff crank-nicolson": (("stiff", ["time.end=0.3", "time.scheme=crank-nicolson"]), 13),
    "stiff rigid": (("stiff", ["time.end=0.3", "obstacle.kind=rigid"]), 34),
    "paper3": (("paper3", ["time.end=4"]), 12),
}
TRIES = 8


@pytest.mark.parametrize("case", CASES)
def test_the_scenes_events_are_located_in_a_few_tries(case):
    """Each event of the run located in at most TRIES steps taken (the Illinois method took up to
    the number in CASES), the steps of the Python stepper counted."""
    (name, overrides), illinois = CASES[case]
    taken, tries = [], []
    locate, take = AdaptiveStepper._locate, AdaptiveStepper._take

    def counted_locate(self, *args):
        first = len(taken)
        b = locate(self, *args)
        tries.append(len(taken) - first)
        return b

    def counted_take(self, c, start, made=None):
        if made is None:  # a try (the bracket's far end is taken again with its method)
            taken.append(c)
        return take(self, c, start, made)

    with pytest.MonkeyPatch.context() as patch:  # every step in Python
        patch.setattr(compiled.CompiledSteps, "ready", lambda self: False)
        patch.setattr(AdaptiveStepper, "_locate", counted_locate)
        patch.setattr(AdaptiveStepper, "_take", counted_take)
        scene = rodfem.scene.load(name, [*overrides, "time.adaptive=true"])
        result = simulate(scene, None, progress=False)
    assert result.summary["adaptive"]["events"] == len(tries) > 0
    assert max(tries) <= TRIES < illinois, tries
