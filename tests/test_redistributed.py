"""Mass redistribution (discretisation.mass = "redistributed", "redistributed-lumped") and the
impact benchmark with its exact solution (rodfem.model.impact): the mass matrix, Crank–Nicolson's
energy identity with the rigid obstacle, the methods' agreement, the accuracy against GetFEM's
figures on the same benchmark, and the limit ε → 0."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import ufl

import forms.copetti as copetti
import rodfem
from conftest import dense, run_history, serial_only
from rodfem.discrete.discretisation import Discretisation
from rodfem.model import impact

EPS = np.finfo(float).eps
CN = {"time.scheme": "crank-nicolson"}
# GetFEM 5.4's demo_dynamic_contact_1D on the same benchmark (Newmark β = 1/4, γ = 1/2 with its
# redistributed mass), L1-in-time error of u(1, ·) at h = Δt, measured with GetFEM: the figures
# to be at least as accurate as.
GETFEM_REDISTRIBUTED = {1e-2: 9.3e-3, 1e-3: 1.7e-3, 5e-4: 1.0e-3}


def columns(history, names=("u_1", "u_half", "ut_1", "sigma_1", "energy")):
    return {name: np.asarray(history[name], dtype=float) for name in names}


@pytest.mark.parametrize("mass", ["redistributed", "redistributed-lumped"])
def test_the_contact_node_has_no_mass_and_the_rod_keeps_its_own(mass):
    """Row and column of x = 1 are zero, the total mass 1ᵀM1 = 1 is kept, and away from the
    last cell the matrix is the base mass's."""
    scene = rodfem.scene.load("paper1", [f"discretisation.mass={mass}", "mesh.cells=8"])
    disc = Discretisation(scene)
    u, v = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
    M = dense(disc.matrix(lambda: copetti.inertia(u, v, disc.dx_b)))
    base = dense(disc.matrix(lambda: copetti.mass(u, v, disc.dx_m)))
    assert np.all(M[-1] == 0.0) and np.all(M[:, -1] == 0.0)
    # the clamped node's row holds the identity's 0 in both; the full rod's mass with node 0
    h = 1.0 / 8
    whole = M[1:, 1:].sum() + (h / 2 if mass.endswith("lumped") else h / 2 - h / 6 + h / 3)
    assert abs(whole - 1.0) <= 16 * EPS
    assert np.array_equal(M[:-2, :-2], base[:-2, :-2])
    # the last cell's matrix, h/2 I (lumped) or h/6 [[2, 1], [1, 2]], is h at its inner node
    last_cell = h / 2 if mass.endswith("lumped") else h / 3
    assert abs(M[-2, -2] - (base[-2, -2] - last_cell + h)) <= 4 * EPS


def test_the_exact_solution_is_one():
    """The model's u(x, t) is the wave equation's solution of the scene: its data at t = 0, the
    end values and stress it states, period 3, energy 1/8 (by differences, off the fronts)."""
    x = np.linspace(0.0, 1.0, 4001)
    assert np.array_equal(impact.displacement(x, 0.0), -x / 2)
    t = np.linspace(0.0, 6.0, 601)
    ends = np.array([impact.displacement(np.array([1.0]), s)[0] for s in t])
    assert np.allclose(ends, impact.end_displacement(t), atol=1e-15)
    assert np.allclose(impact.displacement(x, 1.3), impact.displacement(x, 4.3), atol=1e-15)
    d = 1e-6
    for s in (0.4, 1.3, 1.7, 2.6):
        u_t = (impact.displacement(x, s + d) - impact.displacement(x, s - d)) / (2 * d)
        u_x = np.gradient(impact.displacement(x, s), x)
        smooth = np.abs(np.gradient(u_x, x)) < 1e-9  # away from the fronts' kinks
        energy = 0.5 * np.sum((u_t**2 + u_x**2)[smooth]) * (x[1] - x[0])
        assert abs(energy - impact.ENERGY) < 2e-3, s
        stress = u_x[-1]  # σ(1) = u_x(1): −1/2 in contact, 0 free
        assert abs(stress - impact.end_stress(np.array([s]))[0]) < 1e-9, s


@pytest.mark.parametrize("obstacle", [{}, {"obstacle.kind": "elastic", "obstacle.epsilon": 1e-2}])
@pytest.mark.parametrize("mass", ["redistributed", "redistributed-lumped"])
def test_crank_nicolson_conserves_the_energy_of_an_impact(mass, obstacle):
    """ζ = a = 0: Eⁿ = E⁰ to round-off at every step, through impact, contact and release, with
    the end never past the wall. The energy is a sum of ~3n terms of its size, each rounded: its
    evaluation alone moves it by up to about 3n ε E; the step's own rounding is of that order."""
    cells = 100
    history = run_history("impact", **{"mesh.cells": cells, "time.dt": 1.0 / cells,
                               "discretisation.mass": mass, **obstacle})
    energy = np.asarray(history["energy"])
    assert np.max(np.abs(np.diff(energy))) <= 3 * (3 * cells) * EPS * energy[0]
    assert abs(energy[-1] - energy[0]) <= 3 * (3 * cells) * EPS * energy[0] * 10
    u = np.asarray(history["u_1"])
    if not obstacle:
        assert u.max() <= 0.0  # Signorini's u(1) <= g, exactly
        assert np.min(history["sigma_1"]) < -0.4  # and the wall was pressed


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
@pytest.mark.parametrize("dissipation", [{"model.zeta": 0.2},
                                         {"model.zeta": 0.01, "model.a": 0.5, "model.k": 1.0,
                                          "initial.theta0": "sin(pi*x)"}])
def test_with_viscosity_or_heat_the_energy_never_grows(scheme, dissipation):
    """The rigid impact with viscosity (the end then keeps its time derivative), and with the
    heat equation coupled too: Eⁿ ≤ Eⁿ⁻¹ up to the round-off above, both schemes (the paper's
    from n = 2, Remark 4.4)."""
    cells = 100
    history = run_history("impact", **{"mesh.cells": cells, "time.dt": 1.0 / cells,
                               "time.scheme": scheme, **dissipation})
    energy = np.asarray(history["energy"])
    assert np.max(np.diff(energy[1:])) <= 3 * (3 * cells) * EPS * energy[0]
    assert energy[-1] < energy[1]  # and something was dissipated


@pytest.mark.parametrize("mass", ["redistributed", "redistributed-lumped"])
@pytest.mark.parametrize("scheme", [{}, CN, {**CN, "model.zeta": 0.0, "model.a": 0.0}])
@pytest.mark.parametrize("scene", ["paper1", "paper2"])
def test_the_methods_agree(scene, scheme, mass):
    """direct, newton and picard solve the same steps: their histories agree to 1e-9 of each
    column's size (Picard's tolerance is 1e-10), with both schemes and the end eliminated or
    not."""
    overrides = {"time.end": 2.0, "discretisation.mass": mass, **scheme}
    histories = {m: columns(run_history(scene, **overrides, **{"solver.method": m}))
                 for m in ("direct", "newton", "picard")}
    for method in ("newton", "picard"):
        for name, reference in histories["direct"].items():
            scale = np.max(np.abs(reference))
            assert np.max(np.abs(histories[method][name] - reference)) <= 1e-9 * scale, \
                (method, name)


@pytest.mark.parametrize("obstacle", [{}, {"obstacle.kind": "elastic", "obstacle.epsilon": 1e-2}])
def test_newton_solves_the_eliminated_end(obstacle):
    """The impact with Newton (the rigid obstacle in series with the last cell is an elastic
    law there: no variational inequality) as the direct method does."""
    overrides = {"mesh.cells": 100, "time.dt": 0.01, **obstacle}
    direct = columns(run_history("impact", **overrides))
    newton = columns(run_history("impact", **overrides, **{"solver.method": "newton"}))
    for name, reference in direct.items():
        assert np.max(np.abs(newton[name] - reference)) <= 1e-11 * np.max(np.abs(reference))


def test_impact_beats_getfem_at_h_1e_3():
    """h = Δt = 1e-3, the built-in scene as it is (Crank–Nicolson, redistributed mass, rigid):
    the L1 error of u(1, ·) below GetFEM's redistributed Newmark, the energy within 1e-3 of 1/8,
    the contact stress −1/2 to 1e-3 at every step of the window and without flicker."""
    errors = impact.errors(run_history("impact"))
    assert errors["u1_l1"] < GETFEM_REDISTRIBUTED[1e-3]
    assert errors["energy_T"] < 1e-3
    assert errors["stress"] < 1e-3
    assert errors["flicker"] < 1e-4


def test_impact_order_in_h_equal_dt():
    """The observed order of the L1 error as the least-squares slope over h = Δt: below GetFEM's
    error at every h, and an order above the paper scheme's 0.53 (measured 0.69)."""
    h = np.array([1e-2, 2e-3, 1e-3, 5e-4])
    errors = np.array([impact.errors(run_history(impact.scene(s)))["u1_l1"] for s in h])
    order = np.polyfit(np.log(h), np.log(errors), 1)[0]
    assert 0.6 < order < 1.0
    for s, e in zip(h, errors, strict=True):
        if s in GETFEM_REDISTRIBUTED:
            assert e < GETFEM_REDISTRIBUTED[s], s


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
def test_a_stiff_obstacle_tends_to_the_rigid_one(scheme):
    """ε = 1e-8 with the redistributed mass: within 1e-5 of the rigid obstacle's history (the
    end's place differs by ε σ, the step's force by O(ε))."""
    overrides = {"mesh.cells": 200, "time.dt": 0.005, "time.scheme": scheme}
    rigid = columns(run_history("impact", **overrides), ("u_1", "u_half", "sigma_1", "energy"))
    stiff = columns(run_history("impact", **overrides, **{"obstacle.kind": "elastic",
                                                   "obstacle.epsilon": 1e-8}),
                    ("u_1", "u_half", "sigma_1", "energy"))
    for name, reference in rigid.items():
        assert np.max(np.abs(stiff[name] - reference)) <= 1e-5, name


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_the_demo_runs_under_mpirun():
    """demos/demo_impact.py, shortened (CI set), under mpirun -n 2: rank 0 reports once, with the
    end never past the wall and an order in (0.5, 1)."""
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_impact.py"
    env = {**os.environ, "CI": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)], env=env,
                          capture_output=True, text=True, timeout=600, check=True)
    assert done.stdout.count("observed order:") == 1
    order = float(done.stdout.split("observed order:")[1].split()[0])
    assert 0.5 < order < 1.0
    assert "largest u(1) 0.0" in done.stdout
