"""The discrete energy Êⁿ of Remark 4.4: non-increasing for n ≥ 2, and the history's value is the
UFL form of forms.copetti.energy."""

import numpy as np
import pytest
from dolfinx import fem

import forms.copetti as copetti
import rodfem.scene
from conftest import history_rows
from rodfem.discrete import compat
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.history import History
from rodfem.solver.methods.picard import PicardMethod

EPS = np.finfo(float).eps


@pytest.mark.parametrize("scene", rodfem.scene.BUILTIN)
def test_energy_non_increasing_on_paper_scenes(simulate, scene):
    result, out = simulate(scene, "output.every=100000")
    history = history_rows(out)
    energy = history[:, 5]
    increase = np.diff(energy)[1:]  # Êⁿ − Êⁿ⁻¹ for n ≥ 2
    assert increase.max() <= 64 * EPS * np.abs(energy).max()
    assert result.summary["energy_non_increasing"]
    # On these scenes the dissipation of every step exceeds round-off: strictly decreasing.
    assert increase.max() < 0
    assert history.shape[0] == 8001


@pytest.mark.parametrize("scene", ["paper1", "paper5"])
def test_energy_non_increasing_with_consistent_mass(simulate, scene):
    result, _ = simulate(scene, "discretisation.mass=consistent", "time.end=4",
                         "output.every=100000")
    assert result.summary["energy_non_increasing"]
    assert result.summary["energy_max_increase"] < 0


@pytest.mark.parametrize("mass", ["lumped", "consistent"])
def test_history_energy_is_the_remark_4_4_form(mass):
    """Advance paper1 into a contact interval and assemble ``copetti.energy`` there."""
    scene = rodfem.scene.load("paper1", [f"discretisation.mass={mass}", "time.end=0.25"])
    disc = Discretisation(scene)
    scheme = PicardMethod(disc)
    history = History(disc)
    for _ in range(scene.steps):
        scheme.advance()
    history.record(scheme)
    row = history.take()[-1]
    assert row[4] < 0, "the check wants the contact term active"

    Θ, U, U_prev = disc.function("Θ"), disc.function("U"), disc.function("U_prev")
    for f, v in ((Θ, scheme.theta), (U, scheme.u), (U_prev, scheme.u_prev)):
        compat.petsc_vector(f).array[:] = disc.nodes.owned_values(v)
        f.x.scatter_forward()
    E = copetti.energy(Θ, U, U_prev, scene["time.dt"], scene["model.b"], scene["model.a"],
                       scene["model.theta_A"], disc.r, scene["obstacle.epsilon"],
                       scene["obstacle.gap"], disc.dx_m, disc.dx, disc.ds_1)
    value = disc.comm.allreduce(fem.assemble_scalar(fem.form(E)))
    # The same cell contributions (250 cells, a few terms each) summed in another order: round-off
    # of at most about (number of terms) ulps of the energy.
    assert abs(row[5] - value) <= 1e3 * EPS * abs(value)
