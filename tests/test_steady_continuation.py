"""Branches of steady states followed by pseudo-arclength continuation: their folds and grazing
points against closed forms, and every state of the root search on them.

The closed forms: at rest θ(1) = (θ_A + h θ_O)/(1 + h) and u(1) + p = a (θ_A + θ(1))/2, so that
with θ_A = 0 and the end's excess t = u(1) + p − g a branch over θ_O is the explicit curve

    θ_O(t) = 2 (t + g) (1 + h(t)) / (a h(t)),

h(t) the exchange at the end of excess t (the contact laws give its force p(t)). A fold is where
dθ_O/dt = 0, a grazing point θ_O(0); over k₁ at fixed θ_O the curve is
k₁(t) = (y/(1 − y) − k)/q₁(t), y = 2 (t + g)/(a θ_O), q₁ the exchange per unit k₁. Each is solved
here in 40-digit arithmetic (mpmath), independently of rodfem's laws.
"""

import mpmath
import numpy as np
import pytest

import rodfem.scene
from rodfem.model import steady
from rodfem.studies.steady import continuation as ct

mpmath.mp.dps = 40
RELATIVE = 1e-10  # the located points' agreement with the closed forms


def barber(*overrides):
    return rodfem.scene.load("barber", list(overrides))


def located(scene, key, lo, hi, kind):
    return [p for branch in ct.branches(scene, key, lo, hi) for p in branch if p.kind == kind]


def force(scene):
    """p(t) of the obstacle of ``scene`` for t > 0, in mpmath."""
    eps = mpmath.mpf(scene["obstacle.epsilon"])
    if scene["obstacle.kind"] == "rigid":
        return lambda t: t
    if scene["obstacle.law"] == "linear":
        return lambda t: t / (1 + eps)
    m = mpmath.mpf(scene["obstacle.exponent"])
    # e + e^m/ε = t for the penetration e, p = e^m/ε
    return lambda t: t - mpmath.findroot(lambda e: e + e**m / eps - t, t * eps / (1 + eps))


def exchange(scene):
    """h(t) of ``scene``'s exchange law, in mpmath."""
    k, k1 = mpmath.mpf(scene["model.k"]), mpmath.mpf(scene["heat_exchange.k1"])
    law = scene["heat_exchange.law"]
    if law == "pressure":
        m, p = mpmath.mpf(scene["heat_exchange.exponent"]), force(scene)
        return lambda t: k + (k1 * p(t) ** m if t > 0 else 0)
    length = mpmath.mpf(scene["heat_exchange.length"])
    return lambda t: k + k1 * mpmath.exp(min(t, 0) / length)


def over_temperature(scene):
    a, g, h = mpmath.mpf(scene["model.a"]), mpmath.mpf(scene["obstacle.gap"]), exchange(scene)
    return lambda t: 2 * (t + g) * (1 + h(t)) / (a * h(t))


def fold_of(curve, guess):
    t = mpmath.findroot(lambda t: mpmath.diff(curve, t), mpmath.mpf(guess))
    return float(curve(t)), float(t)


CASES = {  # scene overrides, the range of θ_O, how many folds, whether it turns at grazing
    "pressure m = 1": ((), 0.0, 30.0, 1, True),
    # h's slope in p vanishes at p = 0: the branch crosses t = 0 smoothly, then folds twice
    "pressure m = 2": (("heat_exchange.exponent=2", "heat_exchange.k1=1e5"), 0.0, 40.0, 2, False),
    "rigid": (("obstacle.kind=rigid",), 0.0, 30.0, 1, True),
    # the power law's stiffness vanishes at first contact: smoothly across, then a fold at once
    "power-law obstacle": (("obstacle.law=power", "obstacle.exponent=1.5"), 0.0, 30.0, 2, False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_fold_and_grazing_over_the_obstacle_temperature(case):
    overrides, lo, hi, count, turns = CASES[case]
    scene = barber(*overrides)
    curve = over_temperature(scene)
    grazing = located(scene, "obstacle.temperature", lo, hi, "grazing")
    folds = located(scene, "obstacle.temperature", lo, hi, "fold")
    assert len(grazing) == 1 and len(folds) == count
    assert grazing[0].value == pytest.approx(float(curve(mpmath.mpf(0))), rel=RELATIVE)
    # where it turns, the free branch ends there and the pressed one turns back
    assert grazing[0].turns == turns
    for fold in folds:
        value, t = fold_of(curve, fold.t)
        assert fold.value == pytest.approx(value, rel=RELATIVE)
        assert fold.t == pytest.approx(t, rel=1e-5)  # λ is flat in t at a fold: t to √ε


def test_a_fold_of_free_states_under_the_gap_law():
    """The gap law's exchange grows as the free end nears the obstacle: the branch folds before
    it touches, and crosses t = 0 without turning."""
    scene = barber("heat_exchange.law=gap", "heat_exchange.k1=50", "heat_exchange.length=0.002")
    curve = over_temperature(scene)
    folds = located(scene, "obstacle.temperature", 0.0, 40.0, "fold")
    assert len(folds) == 2 and all(f.t < 0.0 for f in folds)
    for fold in folds:
        assert fold.value == pytest.approx(fold_of(curve, fold.t)[0], rel=RELATIVE)
    (grazing,) = located(scene, "obstacle.temperature", 0.0, 40.0, "grazing")
    assert not grazing.turns
    assert grazing.value == pytest.approx(float(curve(mpmath.mpf(0))), rel=RELATIVE)


def test_a_fold_over_the_exchange_coefficient():
    scene = barber("obstacle.temperature=10")
    a, g, k = (mpmath.mpf(scene[n]) for n in ("model.a", "obstacle.gap", "model.k"))
    theta_O, p = mpmath.mpf(10), force(scene)

    def k1(t):
        y = 2 * (t + g) / (a * theta_O)
        return (y / (1 - y) - k) / p(t)

    (fold,) = located(scene, "heat_exchange.k1", 10.0, 3000.0, "fold")
    assert fold.value == pytest.approx(fold_of(k1, fold.t)[0], rel=RELATIVE)


@pytest.mark.parametrize("case", list(CASES))
def test_the_branches_hold_every_state(case):
    """At every value the branches cross, the root search finds as many states, each between
    the two points of a branch on either side of that value."""
    overrides, lo, hi, _, _ = CASES[case]
    scene = barber(*overrides)
    found = ct.branches(scene, "obstacle.temperature", lo, hi)
    for value in np.linspace(lo, hi, 23)[1:-1]:
        crossings = []
        for branch in found:
            for a, b in zip(branch, branch[1:]):
                if (a.value - value) * (b.value - value) < 0.0:
                    crossings.append((min(a.t, b.t), max(a.t, b.t)))
        roots = [t for t, _ in steady.of_scene(ct.at(scene, "obstacle.temperature",
                                                     value)).roots()]
        assert len(crossings) == len(roots), value
        for (t0, t1), root in zip(sorted(crossings), roots):
            assert t0 <= root <= t1


def test_a_value_that_changes_no_state_gives_vertical_branches():
    scene = barber()
    found = ct.branches(scene, "model.zeta", 0.1, 1.0)
    assert len(found) == 3  # the three states, each followed across the range
    for branch, (t, _) in zip(found, steady.of_scene(scene).roots()):
        assert all(abs(p.t - t) <= 4 * abs(np.spacing(t)) for p in branch)
        assert branch[0].value == 0.1 and branch[-1].value == 1.0
