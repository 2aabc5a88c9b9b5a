"""Crank–Nicolson (time.scheme = "crank-nicolson") with contact: its contact force, its exact
energy identity, the three methods' agreement, the rigid obstacle, and stability where the paper's
scheme is stable."""

import numpy as np
import pytest
import ufl

import forms.copetti as copetti
import rodfem.scene
from rodfem.discrete.discretisation import Discretisation
from rodfem.model.contact import LinearLaw, RigidObstacle
from rodfem.output.history import History
from rodfem.run import simulate
from rodfem.solver.methods import make_method
from rodfem.solver.time_schemes import CRANK_NICOLSON, PAPER

EPS = np.finfo(float).eps
CN = "time.scheme=crank-nicolson"


def _phi(y, gap, epsilon):
    return max(y - gap, 0.0) ** 2 / (2 * epsilon)


def test_discrete_gradient_makes_the_work_the_energy_change():
    """p (y − c) = φ(y) − φ(c) in every case (in, out, entering, leaving), and the slope is its
    derivative (checked by a central difference away from the kinks)."""
    rng = np.random.default_rng(1)
    for _ in range(2000):
        gap, epsilon = rng.normal(scale=0.1), 10 ** rng.uniform(-4, 0)
        y, c = gap + rng.normal(scale=0.01, size=2)
        law = LinearLaw(gap, epsilon)
        p = law.gradient(y, c)
        work, change = p * (y - c), _phi(y, gap, epsilon) - _phi(c, gap, epsilon)
        scale = (abs(y - gap) + abs(c - gap)) ** 2 / epsilon
        assert p >= 0.0 and abs(work - change) <= 8 * EPS * scale
        d = 1e-7 * abs(y - c)
        if min(abs(y - gap), abs(c - gap)) > 10 * d:
            numeric = (law.gradient(y + d, c) - law.gradient(y - d, c)) / (2 * d)
            slope = law.gradient_slope(y, c)
            assert abs(numeric - slope) <= 1e-4 * (abs(slope) + 1 / epsilon)


@pytest.mark.parametrize("rule", ["penalty", "gradient", "rigid"])
def test_closed_form_contact_force_solves_the_step(rule):
    """y + w p(y) = s with y = s − w p, for every rule, to the round-off of p(y): p is known to
    ε_mach, y to ε_mach (|s| + w p), and p(y) moves by at most that over ε."""
    rng = np.random.default_rng(2)
    for _ in range(5000):
        gap, epsilon, w = rng.normal(scale=0.1), 10 ** rng.uniform(-6, 0), 10 ** rng.uniform(-6, 0)
        s, c = gap + rng.normal(scale=0.01, size=2)
        if rule != "gradient":
            c = gap - abs(c - gap)  # the previous step obeys the obstacle
        law = RigidObstacle(gap) if rule == "rigid" else LinearLaw(gap, epsilon)
        p = (CRANK_NICOLSON if rule == "gradient" else PAPER).contact_solve(law, s, w, c)
        y = s - w * p
        assert p >= 0.0
        tol = 8 * EPS * (p + (abs(s) + abs(gap) + w * p) / epsilon)
        if rule == "penalty":
            assert abs(p - law.force(y)) <= tol
        elif rule == "gradient":
            assert abs(p - law.gradient(y, c)) <= tol
        else:  # Signorini: y ≤ g, p ≥ 0, p (y − g) = 0
            assert y <= gap + 8 * EPS * (abs(s) + abs(gap)) and (p == 0.0 or abs(y - gap) <= 8 *
                                                                 EPS * (abs(s) + abs(gap)))


@pytest.mark.parametrize("overrides", [[], ["discretisation.mass=consistent"],
                                        ["obstacle.epsilon=1", "model.zeta=0"],
                                        ["model.k=100", "obstacle.epsilon=1e-4"]])
def test_energy_identity_is_exact(overrides):
    """Tested with Θ^{n−½} and δⁿ, Crank–Nicolson gives

        Ẽⁿ − Ẽⁿ⁻¹ = −Δt (‖Θ^{n−½}_x‖² + k Θ^{n−½}(1)² + ζ ‖δⁿ_x‖²)

    with Ẽⁿ = ½ (‖Θⁿ‖² + b‖Vⁿ‖² + ‖Uⁿ_x‖² + (1/ε)[Uⁿ(1) − g]_+²) + a θ_A (r, Uⁿ_x), the energy the
    history records. Checked step by step over the first contact (t ≤ 0.4), to round-off."""
    scene = rodfem.scene.load("paper1", [CN, "time.end=0.4", "solver.method=direct", *overrides])
    disc = Discretisation(scene)
    scheme, history = make_method(disc), History(disc)
    u, v = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
    K = disc.matrix(copetti.stiffness(u, v, disc.dx))
    dt, k, zeta = scene["time.dt"], scene["model.k"], scene["model.zeta"]
    history.record(scheme)
    worst, touched = 0.0, 0
    for _ in range(scene.steps):
        theta_prev, u_prev = scheme.theta.array.copy(), scheme.u.array.copy()
        scheme.advance()
        history.record(scheme)
        theta_mid = K.createVecRight()
        theta_mid.array[:] = 0.5 * (scheme.theta.array + theta_prev)
        delta = K.createVecRight()
        delta.array[:] = (scheme.u.array - u_prev) / dt
        dissipation = dt * (K(theta_mid).dot(theta_mid) + k * theta_mid.array[-1] ** 2
                            + zeta * K(delta).dot(delta))
        touched += scheme.pressure > 0.0
        rows = history.take()
        change = rows[-1, 5] - rows[0, 5]
        history.record(scheme)  # the next step's "previous" row
        worst = max(worst, abs(change + dissipation) / abs(rows[-1, 5]))
    assert touched > 0  # the identity was checked in contact too
    assert worst <= 1e3 * EPS  # a sum of O(n) products of O(1) terms, n = 251 nodes


@pytest.mark.parametrize("name", rodfem.scene.BUILTIN)
def test_methods_agree_and_energy_decreases(name):
    """direct, newton and picard solve the same Crank–Nicolson steps: every history column to
    1e-9 of its largest value (picard stops at tol = 1e-10)."""
    runs = {m: simulate(rodfem.scene.load(name, [CN, "time.end=2", f"solver.method={m}"]), None,
                        progress=False) for m in ("direct", "newton", "picard")}
    reference = runs["direct"].history
    assert (reference[:, 1] > rodfem.scene.load(name)["obstacle.gap"]).any()  # in contact
    for method, run in runs.items():
        assert run.status == "complete" and run.summary["energy_non_increasing"], method
        for j in range(1, 6):
            scale = np.abs(reference[:, j]).max()
            assert np.abs(run.history[:, j] - reference[:, j]).max() <= 1e-9 * scale, (method, j)


@pytest.mark.parametrize("overrides", [["time.dt=0.01"], ["time.dt=0.05"], ["time.dt=0.1"],
                                        ["time.dt=0.01", "model.zeta=0"],
                                        ["time.dt=0.01", "obstacle.epsilon=1e-6"],
                                        ["time.dt=0.01", "model.b=0"]])
def test_stable_where_the_paper_is(overrides):
    """Large steps, no viscosity, a stiff obstacle, no inertia: where the paper's scheme runs with
    non-increasing energy (direct), so does Crank–Nicolson, from its first step on: Ẽⁿ ≤ Ẽ⁰."""
    for scheme in ("paper", "crank-nicolson"):
        scene = rodfem.scene.load("paper1", [f"time.scheme={scheme}", "time.end=8",
                                             "solver.method=direct", *overrides])
        run = simulate(scene, None, progress=False)
        energy = run.history[:, 5]
        assert run.status == "complete" and np.isfinite(run.history).all(), scheme
        assert run.summary["energy_non_increasing"], scheme
        if scheme == "crank-nicolson":
            assert energy.max() <= energy[0] + 64 * EPS * abs(energy[0])


def test_stiff_obstacle_chatters_but_its_energy_decreases():
    """With an obstacle much stiffer than the rod over a step (ε = 1e-9 ≪ w), sustained contact
    holds ΔUⁿ(1) ≈ 0, so the midpoint rule makes Vⁿ(1) ≈ −Vⁿ⁻¹(1): the velocity at x = 1 flips
    sign from step to step (docs/time-schemes.md; the reason the rigid obstacle is refused). The
    energy identity still holds: Ẽⁿ is non-increasing and bounded by Ẽ⁰."""
    run = simulate(rodfem.scene.load("paper1", [CN, "time.end=2", "solver.method=direct",
                                                "obstacle.epsilon=1e-9"]), None, progress=False)
    ut_1, energy = run.history[:, 3], run.history[:, 5]
    touching = run.history[:, 1] > 0.1 - 1e-6
    flips = np.sum(ut_1[1:] * ut_1[:-1] < 0)
    assert touching.sum() > 100 and flips > touching.sum() / 2
    assert run.summary["energy_non_increasing"] and energy.max() <= energy[0] * (1 + 64 * EPS)
