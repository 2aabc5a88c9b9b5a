"""Every steady state (rodfem.model.steady) against closed forms derived here.

At rest θ is linear, θ(1) = (θ_A + h θ_O)/(1 + h), σ = −p is constant and
u(1) = −p + a (θ_A + θ(1))/2.

* The linear contact law (or the rigid obstacle, ε = 0) with the pressure law q = k₁ p, in
  contact u(1) = g + ε p and h = k + k₁ p: with α = 2(1 + ε)/a and β = 2g/a − θ_A,
  (β + α p)(1 + k + k₁ p) = θ_A + (k + k₁ p) θ_O, the quadratic
  α k₁ p² + (α(1 + k) + β k₁ − k₁ θ_O) p + β(1 + k) − θ_A − k θ_O = 0, whose positive roots are
  the contact states; the separated state (p = 0, h = k) exists where a (θ_A + θ(1))/2 ≤ g.
* The gap law, separated: u = a (θ_A + θ(1)(k + k₁ e^{(u−g)/ℓ}))/2, a scalar equation solved here
  by SciPy's brentq on brackets found independently; in contact h = k + k₁ is constant.
* The constant law with θ_O = 0 and the linear law: the paper's stationary state in closed form.
"""

import math

import numpy as np
import pytest
import scipy.optimize

import rodfem.scene
from rodfem.model import steady
from rodfem.model.contact import LinearLaw, PowerLaw, RigidObstacle
from rodfem.model.exchange import ConstantLaw, GapLaw, PressureLaw

EPS = np.finfo(float).eps


def quadratic_contact(a, theta_A, k, k1, theta_O, gap, epsilon):
    """The contact forces p > 0 of the linear law with q = k₁ p, increasing."""
    alpha, beta = 2.0 * (1.0 + epsilon) / a, 2.0 * gap / a - theta_A
    A = alpha * k1
    B = alpha * (1.0 + k) + beta * k1 - k1 * theta_O
    C = beta * (1.0 + k) - theta_A - k * theta_O
    disc = B * B - 4.0 * A * C
    if disc < 0.0:
        return []
    root = math.sqrt(disc)
    q = -0.5 * (B + math.copysign(root, B))  # without cancellation
    roots = sorted({q / A, C / q} if q != 0.0 else {0.0})
    return [p for p in roots if p > 0.0]


def separated(a, theta_A, k, theta_O, gap):
    """u(1) of the separated state with h = k, if it is one."""
    u = 0.5 * a * (theta_A + (theta_A + k * theta_O) / (1.0 + k))
    return [u] if u <= gap else []


def pressure_problem(a, theta_A, k, k1, theta_O, gap, epsilon, rigid=False):
    obstacle = RigidObstacle(gap) if rigid else LinearLaw(gap, epsilon)
    return steady.Steady(a, theta_A, obstacle, PressureLaw(k, theta_O, k1, 1.0))


def check_pressure_states(params, rigid=False):
    a, theta_A, k, k1, theta_O, gap, epsilon = params
    epsilon = 0.0 if rigid else epsilon
    problem = pressure_problem(a, theta_A, k, k1, theta_O, gap, epsilon, rigid)
    states = problem.states()
    free = separated(a, theta_A, k, theta_O, gap)
    pressed = quadratic_contact(a, theta_A, k, k1, theta_O, gap, epsilon)
    assert len(states) == len(free) + len(pressed), (params, states)
    scale = max(abs(s.s) for s in states)
    for state, u in zip(states, free):
        assert not state.contact and state.p == 0.0
        assert abs(state.u_1 - u) <= 4 * EPS * scale
    for state, p in zip(states[len(free):], pressed):
        assert state.contact
        # s is found to round-off; p = (s − g)/(1 + ε) carries it
        assert abs(state.p - p) <= 64 * EPS * scale, (state.p, p)
        assert abs(state.u_1 - (gap + epsilon * p)) <= 64 * EPS * scale
        assert state.sigma_1 == -state.p
    return states


def test_barber_three_states_closed_form():
    states = check_pressure_states((0.017, 0.0, 0.1, 1000.0, 10.0, 0.02, 0.01))
    assert [s.contact for s in states] == [False, True, True]
    assert 2e-4 < states[1].p < 3e-4 and 0.06 < states[2].p < 0.07


def test_barber_scene_is_the_closed_form():
    scene = rodfem.scene.load("barber", [])
    states = steady.of_scene(scene).states()
    params = (scene["model.a"], scene["model.theta_A"], scene["model.k"],
              scene["heat_exchange.k1"], scene["obstacle.temperature"], scene["obstacle.gap"],
              scene["obstacle.epsilon"])
    assert len(states) == 3
    check_pressure_states(params)


def test_rigid_obstacle_closed_form():
    states = check_pressure_states((0.017, 0.0, 0.1, 1000.0, 10.0, 0.02, 0.0), rigid=True)
    assert [s.u_1 for s in states[1:]] == [0.02, 0.02]


def test_search_never_misses_a_root():
    """Random scenes where the closed form has three states: the search finds all three (and as
    many as the closed form in every other draw)."""
    rng = np.random.default_rng(7)
    three = 0
    for _ in range(300):
        params = (10 ** rng.uniform(-3, -1), rng.uniform(-5, 5), 10 ** rng.uniform(-2, 1),
                  10 ** rng.uniform(0, 4), rng.uniform(-20, 40), 10 ** rng.uniform(-3, -1),
                  10 ** rng.uniform(-4, 0))
        three += len(check_pressure_states(params)) == 3
    assert three >= 20


def test_tangential_root_at_a_fold():
    """Where the quadratic's two roots meet (its discriminant vanishes, solved for θ_O) the
    search reports one tangential contact state."""
    a, theta_A, k, k1, gap, epsilon = 0.017, 0.0, 0.1, 1000.0, 0.02, 0.01

    def disc(theta_O):
        alpha, beta = 2.0 * (1.0 + epsilon) / a, 2.0 * gap / a - theta_A
        B = alpha * (1.0 + k) + beta * k1 - k1 * theta_O
        return B * B - 4.0 * alpha * k1 * (beta * (1.0 + k) - theta_A - k * theta_O)

    fold = scipy.optimize.brentq(disc, 3.0, 5.0, xtol=1e-15, rtol=4 * EPS)
    states = pressure_problem(a, theta_A, k, k1, fold, gap, epsilon).states()
    assert [s.contact for s in states] == [False, True]
    assert states[1].tangential and not states[0].tangential
    p = quadratic_contact(a, theta_A, k, k1, fold * (1 + 1e-9), gap, epsilon)
    assert abs(states[1].p - np.mean(p)) < 1e-6 * np.mean(p)
    # a little away from the fold: no contact state below it, two apart above it
    below = pressure_problem(a, theta_A, k, k1, fold * (1 - 1e-6), gap, epsilon).states()
    above = pressure_problem(a, theta_A, k, k1, fold * (1 + 1e-6), gap, epsilon).states()
    assert [s.contact for s in below] == [False]
    assert [(s.contact, s.tangential) for s in above] == [(False, False), (True, False),
                                                          (True, False)]


def gap_separated_roots(a, theta_A, k, k1, theta_O, gap, length):
    """The separated states of the gap law, by brentq on the sign changes of u − F(u) over a
    fine grid of [min, g]."""
    def G(u):
        h = k + k1 * math.exp((u - gap) / length)
        return u - 0.5 * a * (theta_A + (theta_A + h * theta_O) / (1.0 + h))

    grid = np.concatenate([np.linspace(-1.0, gap - 50 * length, 200),
                           np.linspace(gap - 50 * length, gap, 20001)[1:]])
    values = [G(u) for u in grid]
    roots = []
    for u0, u1, g0, g1 in zip(grid[:-1], grid[1:], values[:-1], values[1:]):
        if g0 == 0.0:
            roots.append(u0)
        elif g0 * g1 < 0.0:
            roots.append(scipy.optimize.brentq(G, u0, u1, xtol=1e-300, rtol=4 * EPS))
    return roots


@pytest.mark.parametrize("theta_O, count", [(10.0, 3), (1.0, 1), (-10.0, 1)])
def test_gap_law_against_its_scalar_equation(theta_O, count):
    a, theta_A, k, k1, gap, length, epsilon = 0.017, 0.0, 0.1, 100.0, 0.02, 0.001, 0.01
    problem = steady.Steady(a, theta_A, LinearLaw(gap, epsilon),
                            GapLaw(k, theta_O, k1, gap, length))
    states = problem.states()
    assert len(states) == count
    free = gap_separated_roots(a, theta_A, k, k1, theta_O, gap, length)
    h = k + k1
    s = 0.5 * a * (theta_A + (theta_A + h * theta_O) / (1.0 + h))  # in contact: h = k + k₁
    pressed = [(s - gap) / (1.0 + epsilon)] if s > gap else []
    assert len(free) + len(pressed) == count
    for state, u in zip(states, free):
        assert not state.contact and abs(state.u_1 - u) <= 8 * EPS * abs(u) + 1e-300
    for state, p in zip(states[len(free):], pressed):
        assert state.contact and abs(state.p - p) <= 8 * EPS * s


@pytest.mark.parametrize("k, gap, theta_A", [(1.0, 0.1, 10.0), (100.0, 0.1, 10.0),
                                             (1.0, 0.0, -3.0), (0.0, 0.05, 10.0)])
def test_constant_law_is_the_stationary_state(k, gap, theta_A):
    """The paper's case: one state, the old closed form to round-off."""
    a, epsilon = 0.017, 0.01
    states = steady.Steady(a, theta_A, LinearLaw(gap, epsilon), ConstantLaw(k)).states()
    assert len(states) == 1
    x = np.linspace(0.0, 1.0, 11)
    u, sigma = steady.stationary(x, a, theta_A, k, epsilon, gap)
    scale = abs(a * theta_A)
    assert abs(states[0].sigma_1 - sigma) <= 4 * EPS * scale
    assert np.max(np.abs(states[0].displacement(x) - u)) <= 8 * EPS * scale
    assert np.max(np.abs(states[0].temperature(x) - theta_A * (1 - k / (k + 1) * x))) \
        <= 4 * EPS * abs(theta_A)


def test_power_law_contact_state():
    """m = 3, the constant law: p = ((u − g)/ε)³... with u + p = F solved here by brentq."""
    a, theta_A, k, gap, epsilon, m = 0.017, 10.0, 1.0, 0.05, 0.01, 3.0
    problem = steady.Steady(a, theta_A, PowerLaw(gap, epsilon, m), ConstantLaw(k))
    [state] = problem.states()
    F = 0.5 * a * (theta_A + theta_A / (1.0 + k))
    d = scipy.optimize.brentq(lambda d: gap + d + d**m / epsilon - F, 0.0, F,
                              xtol=1e-300, rtol=4 * EPS)
    assert abs(state.u_1 - (gap + d)) <= 8 * EPS * F
    assert abs(state.p - d**m / epsilon) <= 8 * EPS * F
