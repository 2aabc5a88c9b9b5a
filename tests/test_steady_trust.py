"""The cases where ``rodfem steady`` once printed states that were not states and verdicts it
had not earned, each against an answer derived here.

* A pressure law q = k₁ p^m with m = 0.2 or 0.1 puts barber's middle state at a contact
  pressure of 3.9e-19 or 1.5e-37, closer to g than the doubles near g = 0.02 resolve: found in
  the penetration, p solves (1 + ε) p + g = a (θ_A + θ(1))/2, here by brentq in log p.
* m = 0.01 or 0.001 needs a p below the smallest double: no state can be given, and the row
  says so (trust = residual), with no verdict.
* The gap law with ℓ = 1e-300 puts the middle state e = ℓ ln((h − k)/k₁) short of g, h the
  coefficient that makes u(1) = g a steady state.
* ε = 1e-12 (the schema's minimum) makes the pencil badly scaled: the middle state is unstable,
  its growth rate that of the rigid obstacle within its error bound.
* The impact scene is an undamped bar: its spectrum is neutral, not unstable.
"""

import csv
import math

import numpy as np
import pytest
import scipy.optimize

import rodfem
import rodfem.scene
from conftest import COMM, assert_refused
from rodfem.cli import main
from rodfem.model import steady
from rodfem.post.steady import read_branches
from rodfem.solver.spectrum import Spectra
from rodfem.studies.steady.states import analyse

EPS = np.finfo(float).eps
SPECTRA = Spectra()


def rows_of(*overrides, name="barber"):
    scene = rodfem.scene.load(name, list(overrides))
    return scene, steady.of_scene(scene).states(), analyse(scene, SPECTRA)


def h_at_rest(scene, u):
    """The exchange coefficient that makes the end rest at u(1) = u with p ≈ 0."""
    a, theta_A, theta_O = scene["model.a"], scene["model.theta_A"], scene["obstacle.temperature"]
    theta_1 = 2.0 * u / a - theta_A
    return (theta_A - theta_1) / (theta_1 - theta_O)


@pytest.mark.parametrize("m, p_order", [(0.2, 3.9e-19), (0.1, 1.5e-37)])
def test_touching_state_of_a_small_exponent(m, p_order):
    scene, states, rows = rows_of(f"heat_exchange.exponent={m}")
    a, k, k1, g, eps = (scene[key] for key in ("model.a", "model.k", "heat_exchange.k1",
                                                 "obstacle.gap", "obstacle.epsilon"))
    theta_O = scene["obstacle.temperature"]

    def G(log_p):
        p = math.exp(log_p)
        h = k + k1 * p**m
        return (1.0 + eps) * p + g - 0.5 * a * (h * theta_O / (1.0 + h))

    p = math.exp(scipy.optimize.brentq(G, math.log(1e-300), math.log(1e-3), xtol=1e-15))
    assert len(states) == 3 and all(s.resolved for s in states)
    middle = states[1]
    assert middle.p == pytest.approx(p, rel=1e-12) and middle.p == pytest.approx(p_order, rel=0.1)
    assert middle.u_1 == g and middle.offset == pytest.approx(eps * p, rel=1e-12)
    assert abs(middle.residual) <= 4 * EPS * g
    # the middle state of three is a saddle: unstable, and earned
    assert [r["trust"] for r in rows] == ["ok"] * 3
    assert [r["stable"] for r in rows] == [True, False, True]


@pytest.mark.parametrize("m", [0.01, 0.001])
def test_a_pressure_below_the_doubles_is_no_state(m, shared_dir, capsys):
    scene, states, rows = rows_of(f"heat_exchange.exponent={m}")
    assert [s.resolved for s in states] == [True, False, True]
    # the jump at p = 0: from h = k to h ≥ k + k₁ (5e-324)^m, the residual is not round-off
    assert abs(states[1].residual) > 1e-3
    assert rows[1]["trust"] == "residual" and rows[1]["stable"] is None
    assert math.isnan(rows[1]["growth_rate"])
    out = shared_dir / f"below-{m}"
    assert main(["steady", "barber", "--out", str(out), "--set", "mesh.cells=20",
                 "--set", f"heat_exchange.exponent={m}"]) == 0
    printed = capsys.readouterr()
    with open(out / "steady.csv", encoding="utf-8", newline="") as f:
        written = list(csv.DictReader(f))
    assert [r["trust"] for r in written] == ["ok", "residual", "ok"]
    assert [r["stable"] for r in written] == ["true", "", "true"]
    if COMM.rank == 0:
        table = printed.out.splitlines()
        assert table[2].split()[4] == "?"  # never a bare yes or NO
        warnings = [line for line in printed.err.splitlines() if "warning" in line]
        assert len(warnings) == 1 and "does not satisfy the steady equation" in warnings[0]


def test_gap_law_of_a_vanishing_length():
    scene, states, rows = rows_of("heat_exchange.law=gap", "heat_exchange.length=1e-300")
    k, k1, g = scene["model.k"], scene["heat_exchange.k1"], scene["obstacle.gap"]
    e = 1e-300 * math.log((h_at_rest(scene, g) - k) / k1)
    middle = states[1]
    assert middle.resolved and middle.p == 0.0 and middle.u_1 == g
    assert middle.offset == pytest.approx(e, rel=1e-12)
    assert [r["trust"] for r in rows] == ["ok"] * 3
    assert [r["stable"] for r in rows] == [True, False, True]


@pytest.mark.parametrize("epsilon", [1e-10, 1e-11, 1e-12])
def test_stiff_obstacle_has_the_rigid_growth_rate(epsilon):
    """The rigid obstacle is the limit ε → 0; the growth rates approach it as O(ε), far below
    their error bounds here."""
    *_, rigid = rows_of("obstacle.kind=rigid")
    *_, stiff = rows_of(f"obstacle.epsilon={epsilon!r}")
    assert rigid[1]["trust"] == stiff[1]["trust"] == "ok"
    assert rigid[1]["stable"] is stiff[1]["stable"] is False
    assert rigid[1]["growth_rate"] > 4000.0
    assert abs(stiff[1]["growth_rate"] - rigid[1]["growth_rate"]) <= stiff[1]["growth_error"]
    # the pressed state: stable, or honestly unresolved, never unstable
    assert stiff[2]["stable"] in (True, None) and stiff[2]["trust"] in ("ok", "unresolved")


def test_undamped_bar_is_neutral(shared_dir, capsys):
    *_, rows = rows_of("mesh.cells=40", name="impact")
    [row] = rows
    assert row["trust"] == "neutral" and row["stable"] is None
    assert abs(row["growth_rate"]) <= row["growth_error"]
    out = shared_dir / "impact"
    assert main(["steady", "impact", "--out", str(out), "--set", "mesh.cells=40"]) == 0
    printed = capsys.readouterr()
    if COMM.rank == 0:
        assert printed.out.splitlines()[1].split()[4] == "neutral"
        assert "is neutral" in printed.err and "NO" not in printed.out


def test_continue_names_its_key_and_reads_back(shared_dir, capsys):
    out = shared_dir / "keyed"
    assert main(["steady", "barber", "--out", str(out), "--set", "mesh.cells=10",
                 "--set", "heat_exchange.exponent=0.001",
                 "--continue", "heat_exchange.k1=500:1000:2"]) == 0
    capsys.readouterr()
    rows = read_branches(out / "branches.csv")
    assert {r["key"] for r in rows} == {"heat_exchange.k1"}
    assert [r["trust"] for r in rows] == ["ok", "residual", "ok"] * 2
    assert [r["stable"] for r in rows] == [True, None, True] * 2
    assert (out / "figures" / "branches.png").stat().st_size > 10_000


@pytest.mark.parametrize("args, message", [
    (["--continue", "model.zeta=1:2:3", "--continue", "model.zeta=1:2:4"],
     "--continue is given 2 times; give it once"),
    (["--continue", "time.end=1:2:3"], "time.end cannot change a steady state"),
    (["--continue", "time.dt=0.001:0.002:3"], "time.dt cannot change a steady state"),
    (["--continue", "solver.tol=1e-10:1e-9:3"], "solver.tol cannot change a steady state"),
    (["--continue", "output.checkpoint=1:2:3"], "output.checkpoint cannot change"),
    (["--continue", "initial.theta0=1:2:3"], "initial.theta0 cannot change"),
])
def test_continue_refused(args, message, shared_dir, capsys):
    out = shared_dir / "refused"
    assert_refused(["steady", "barber", "--out", str(out), *args], out, message, capsys)


def test_time_step_continues_the_dispersion_free_mass(shared_dir, capsys):
    """Δt sets the dispersion-free mass, hence the discrete spectrum: continued there."""
    out = shared_dir / "dt"
    assert main(["steady", "barber", "--out", str(out), "--set", "mesh.cells=10",
                 "--set", "discretisation.mass=dispersion-free",
                 "--set", "time.scheme=crank-nicolson", "--set", "time.dt=0.02",
                 "--continue", "time.dt=0.02:0.1:2"]) == 0
    capsys.readouterr()
    rows = read_branches(out / "branches.csv")
    rates = [r["growth_rate"] for r in rows if r["branch"] == 0]
    assert len(rates) == 2 and rates[0] != rates[1]


def test_python_api_refuses_a_key_that_changes_no_state():
    with pytest.raises(rodfem.SceneError, match="time.end cannot change a steady state"):
        rodfem.steady("barber", {"mesh.cells": 10}, over=("time.end", [1.0, 2.0]))
