"""The energy of the model with the obstacle at a temperature θ_O and heat exchanged through the
contact (docs/model.md, "The energy with a warm obstacle and heat exchanged through the
contact"), and where the constant law settles.

With the lifting L = −θ_A r + θ_O s, Ê = ½(‖Θ‖² + b‖δ‖² + ‖U_x‖²) + φ(U(1)) − a (L, U_x) obeys,
step by step (n ≥ 2 in the paper's scheme, n ≥ 1 in Crank–Nicolson's),

    Êⁿ − Êⁿ⁻¹ ≤ Δt qⁿ² offset²/(4 (1 + k + qⁿ)) ≤ Δt qⁿ offset²/4,

offset = (θ_A − θ_O)/(k + 1), qⁿ ≥ 0 the exchange the contact adds to k at the step: so Ê never
rises under the constant law (q = 0), whatever θ_O, and under the others only where θ(1) lies
between L(1) and θ_O, with heat entering the rod or leaving it.

Round-off: the history's Êⁿ is one dot product of 3n ≈ 750 terms (rodfem.output.history.Energy),
each at most the size of the largest part of Ê; rounding errors of such a sum add up like a
random walk, √(3n) ≈ 27 ulps, so the difference of two consecutive values is below 64 ulps of
max |Ê| (the bound tests/test_energy.py takes for the paper's scenes).
"""

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
from rodfem.model import contact, exchange

EPS = np.finfo(float).eps
SCHEMES = ("paper", "crank-nicolson")


def _increments(history, scheme: str) -> np.ndarray:
    """Êⁿ − Êⁿ⁻¹ over the steps where the estimate holds: n ≥ 2 in the paper's scheme (its first
    step is U¹ = U⁰ + Δt P u₁, not (3.2)), every step in Crank–Nicolson's."""
    increase = np.diff(history["energy"])
    return increase[1:] if scheme == "paper" else increase


@pytest.mark.parametrize("theta_O", [25.0, -10.0], ids=["hot", "cold"])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_energy_never_rises_under_the_constant_law_at_any_obstacle_temperature(scheme, theta_O):
    """paper1 (contact and separation) with a hot obstacle, which pushes the rod into contact,
    and a cold one, which pulls it away."""
    result = rodfem.simulate("paper1", {"obstacle.temperature": theta_O, "time.scheme": scheme})
    assert result.status == "complete"
    energy = result.history["energy"]
    increase = _increments(result.history, scheme)
    assert increase.max() <= 64 * EPS * np.abs(energy).max()
    assert result.summary["energy_non_increasing"]
    # The estimate is not met by accident: θ_O changes the energy (its −a θ_O (s, U_x)) and the
    # motion (in contact with the hot obstacle at the end, not with the cold one).
    plain = rodfem.simulate("paper1", {"time.scheme": scheme, "time.end": 0.5})
    assert abs(energy[500] - plain.history["energy"][500]) > 1e-3
    assert (result.history["u_1"][-1] > 0.1) == (theta_O > 0)


def _steady(x, a, theta_A, theta_O, k, epsilon, gap):
    """θ and u at the points x, and σ, of the constant law's steady state.

    At rest θ_xx = 0 with θ(0) = θ_A and −θ_x(1) = k (θ(1) − θ_O): θ is the lifting
    L = θ_A (1 − c x) + θ_O c x, c = k/(k + 1) (Θ = 0), so θ(1) = (θ_A + k θ_O)/(1 + k).
    σ_x = 0: σ = u_x − a θ is a constant, and with u(0) = 0, u = σ x + a ∫₀ˣ L,
    u(1) = σ + U*, U* = a (θ_A (1 − c/2) + θ_O c/2). Apart (U* ≤ g) σ = 0; in contact
    σ = −(u(1) − g)/ε, so σ = (g − U*)/(1 + ε)."""
    c = k / (k + 1.0)
    free = a * (theta_A * (1.0 - c / 2.0) + theta_O * c / 2.0)
    sigma = (gap - free) / (1.0 + epsilon) if free > gap else 0.0
    theta = theta_A * (1.0 - c * x) + theta_O * c * x
    u = sigma * x + a * (theta_A * (x - c * x**2 / 2.0) + theta_O * c * x**2 / 2.0)
    return theta, u, sigma


@pytest.mark.parametrize("theta_O, in_contact", [(25.0, True), (-10.0, False)],
                         ids=["hot", "cold"])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_constant_law_settles_at_its_steady_state(scheme, theta_O, in_contact):
    """paper2 (ζ = 1) settles within 1e-6 by T = 25, as with the obstacle at 0
    (tests/test_stationary.py). P1 is exact at the nodes for this 1D problem, so the scheme's
    steady state is the model's at the nodes."""
    result = rodfem.simulate("paper2", {
        "obstacle.temperature": theta_O, "mesh.cells": 50, "time.dt": 0.005, "time.end": 25,
        "time.scheme": scheme, "time.adaptive": False, "output.every": 5000,
        "output.history": ["theta_1", "heat_flux_1"]})
    assert result.status == "complete"
    theta, u, sigma = _steady(np.linspace(0.0, 1.0, 51), 0.017, 10.0, theta_O, 1.0, 0.01, 0.1)
    assert (sigma < 0) == in_contact
    if MPI.COMM_WORLD.rank == 0:  # the fields kept in memory are rank 0's
        fields = result.fields
        assert fields.t[-1] == 25.0
        np.testing.assert_allclose(fields.x, np.linspace(0.0, 1.0, 51), rtol=0, atol=1e-15)
        assert np.max(np.abs(fields.theta[-1] - theta)) < 1e-6
        assert np.max(np.abs(fields.u[-1] - u)) < 1e-6
    last = result.history[-1]
    assert abs(last["theta_1"] - theta[-1]) < 1e-6
    assert abs(last["u_1"] - u[-1]) < 1e-6
    assert abs(last["sigma_1"] - sigma) < 1e-6
    # the heat the rod gives the obstacle, k (θ(1) − θ_O), is what crosses the rod, θ_A − θ(1)
    assert abs(last["heat_flux_1"] - (10.0 - theta[-1])) < 1e-6


# Two rods at the constant law's steady temperature L, at rest at or near the obstacle, which
# their heat expands them into: there the exchange rises above k, and the end's temperature moves
# from L(1) towards θ_O, into the range where the estimate lets Ê rise (θ(1) between L(1) and
# θ_O). ζ = 1: they settle within T = 4.
AT_REST = {"model.zeta": 1.0, "initial.u0": "0", "initial.u1": "0", "time.end": 4.0,
           "solver.method": "direct", "output.history": ["theta_1", "contact_force"]}
START = {
    # θ_A = 0, an obstacle at θ_O = 10 0.01 away, L = 5x: heat enters through the contact
    "entering": {"model.theta_A": 0.0, "obstacle.temperature": 10.0, "obstacle.gap": 0.01,
                 "initial.theta0": "5*x"},
    # the paper's θ_A = 10 and obstacle at 0, touching, L = 10 (1 − x/2): heat leaves through
    # the contact, and still raises Ê, cooling the end below L(1) = 5
    "leaving": {"obstacle.gap": 0.0, "initial.theta0": "theta_A*(1 - x/2)"},
}
LAWS = {
    # p ≈ 0.06 in contact: q = k₁ p ≈ 6
    "pressure": {"heat_exchange.law": "pressure", "heat_exchange.k1": 100.0},
    # q = 5 in contact, 5/e one length ℓ = 0.01 short of it
    "gap": {"heat_exchange.law": "gap", "heat_exchange.k1": 5.0},
}
# (time scheme, obstacle, adaptive steps, start): the elastic obstacle in both schemes, the rigid
# one in the paper's (Crank–Nicolson's takes it only with the mass moved off the end, which is
# then eliminated), and Crank–Nicolson's adaptive steps, each of its own Δtⁿ, from the start apart
# from the obstacle (from rest on it, the error control asks for a first step below
# time.dt_min, with the constant law as well)
CASES = [(*case, start) for case in (("paper", "elastic", False),
                                     ("crank-nicolson", "elastic", False),
                                     ("paper", "rigid", False)) for start in START]
CASES.append(("crank-nicolson", "elastic", True, "entering"))
IDS = ["-".join([scheme, obstacle, "adaptive" if adaptive else "fixed", start])
       for scheme, obstacle, adaptive, start in CASES]


def _extras(history, scene, scheme: str) -> np.ndarray:
    """qⁿ of every step n ≥ 1 as the step takes it, from the history: the law at Uⁿ(1) (u_1) and
    the step's contact force pⁿ (contact_force: φ'(Uⁿ(1)), the rigid obstacle's multiplier) in
    the paper's scheme; at the midpoint (Uⁿ(1) + Uⁿ⁻¹(1))/2 and the discrete gradient p of φ
    between Uⁿ⁻¹(1) and Uⁿ(1) in Crank–Nicolson's (rodfem.solver.time_schemes)."""
    law, obstacle = exchange.of_scene(scene), contact.of_scene(scene)
    u_1, force = history["u_1"], history["contact_force"]
    if scheme == "paper":
        return np.array([law.extra(y, p) for y, p in zip(u_1[1:], force[1:], strict=True)])
    return np.array([law.extra(0.5 * (y + c), obstacle.gradient(y, c))
                     for y, c in zip(u_1[1:], u_1[:-1], strict=True)])


@pytest.mark.parametrize("law", list(LAWS))
@pytest.mark.parametrize("scheme, obstacle, adaptive, start", CASES, ids=IDS)
def test_heat_through_the_contact_raises_the_energy_at_most_as_the_estimate_allows(
        scheme, obstacle, adaptive, start, law):
    """Êⁿ − Êⁿ⁻¹ ≤ Δt qⁿ² o²/(4 (1 + k + qⁿ)) (≤ Δt qⁿ o²/4) at every step, on scenes where Ê
    rises by far more than round-off: the bound is met, and not by being vacuous. Ê rises only
    where the contact's term −qⁿ Θ(1)(Θ(1) + o) is positive: where θ(1) at the step (θⁿ(1), or
    the midpoint's in Crank–Nicolson's) lies between L(1) and θ_O, whichever way the heat goes."""
    result = rodfem.simulate("paper1", {**AT_REST, **START[start], **LAWS[law],
                                        "time.scheme": scheme, "obstacle.kind": obstacle,
                                        "time.adaptive": adaptive})
    assert result.status == "complete"
    scene, history = result.scene, result.history
    energy = history["energy"]
    k, dt = scene["model.k"], history["dt"][1:] if adaptive else scene["time.dt"]
    o = exchange.of_scene(scene).offset(scene["model.theta_A"])
    q = _extras(history, scene, scheme)
    bound = dt * q**2 * o**2 / (4.0 * (1.0 + k + q))
    theta_1 = history["theta_1"][1:]
    if scheme == "paper":
        bound, theta_1 = bound[1:], theta_1[1:]
    else:
        theta_1 = 0.5 * (theta_1 + history["theta_1"][:-1])
    increase = _increments(history, scheme)
    round_off = 64 * EPS * np.abs(energy).max()
    assert np.all(increase <= bound + round_off)
    assert np.all(bound <= dt * q[-len(bound):] * o**2 / 4.0)
    theta_O = scene["obstacle.temperature"]
    rising = increase > round_off
    between = (theta_1[rising] - theta_O) * o > 0.0  # θ(1) − θ_O and L(1) − θ_O agree in sign
    assert np.all(between & ((theta_1[rising] - (theta_O + o)) * o < 0.0))
    # not vacuous: the rod goes into contact, q rises, and Ê with it, far above round-off, with
    # the heat flowing into the rod or out of it
    assert history["contact_force"].max() > 0.0
    assert q.max() > 2.0
    assert increase.max() > 1e6 * EPS * np.abs(energy).max()
    assert energy[-1] - energy[0] > 0.1
    assert np.all(np.sign(theta_1[rising] - theta_O) == (-1.0 if start == "entering" else 1.0))
