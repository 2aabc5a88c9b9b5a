"""Adaptive steps start barber's hot start, and their failures say what failed.

Barber started hot and touching (θ0 = 10x, u0 = 0.02x, docs/thermal-contact.md) is in
contact from its first instant: its end sits at the gap and its heat pushes it on. The paper
scheme's first step, U¹ = U⁰ + Δt P u₁, keeps the initial velocity (here 0) and so never
reaches the obstacle, while the second of the two halves that estimate its error, a step of the
equations, always does. The error of those halves is measured all the same and the first half
kept (rodfem.solver.adaptive.stepper); the next step meets the contact. Every method then
completes and follows a fixed-step run of a hundredth of the scene's step.

A rod at rest at its steady temperature L (Θ = θ − L = 0) and on the obstacle: its heat presses it
into the obstacle, and Θ grows from nothing. Its error is measured against the temperatures the
rod starts at and is held at, not against Θ's own vanishing size (rodfem.solver.adaptive.control,
ErrorNorm.seed), under which the steps fell to 6e-9 and the run crawled.

When the error control needs a step below ``time.dt_min``, the run stops with exit code 3 and a
line saying so, with what to change; a step that the method does not solve says that instead.
"""

import json

import numpy as np
import pytest

import rodfem
from conftest import COMM
from rodfem.cli import main

HOT = {"initial.theta0": "10*x", "initial.u0": "0.02*x", "mesh.cells": 50, "time.end": 0.5}
HOT_SET = [item for key, value in HOT.items()
           for item in ("--set", f"{key}={json.dumps(value)}")]
COMPARED = ("u_1", "sigma_1", "u_half", "energy")
ADVICE = "raise time.tolerance or lower time.dt_min"


@pytest.fixture(scope="module")
def fine():
    """The fixed-step run at Δt = 1e-5, a two-hundredth of barber's 0.002."""
    result = rodfem.simulate("barber", {**HOT, "time.dt": 1e-5})
    assert result.status == "complete", result.summary
    return result.history


@pytest.mark.parametrize("method", ["direct", "newton", "picard"])
def test_the_hot_start_runs_adaptive_and_follows_the_fixed_step_run(fine, method):
    """Completes (it stopped at step 1 before, the error control's step shrinking to
    time.dt_min), meets the contact in its second step, and stays within 1 % of the largest size
    of u(1), σ(1), u(1/2) and the energy over the whole run, the promise of the default
    tolerance on the paper scenes (docs/time-schemes.md). Measured, every method the same:
    2.6e-4 (u(1)), 3.8e-3 (σ(1)), 1.6e-3 (u(1/2)), 1.8e-4 (energy), in 720 steps."""
    result = rodfem.simulate("barber", {**HOT, "time.adaptive": True, "solver.method": method})
    assert result.status == "complete", result.summary.get("error")
    rows = result.history
    assert rows["t"][-1] == fine["t"][-1] == 0.5
    assert rows["event"][2] == 1 and rows["event"].sum() == 1  # contact begins at once, stays
    assert rows["dt"][1] < result.scene["time.dt"]  # the first step's error judged
    for column in COMPARED:
        difference = np.abs(rows[column] - np.interp(rows["t"], fine["t"], fine[column])).max()
        assert difference <= 0.01 * np.abs(fine[column]).max(), (column, difference)


# paper1's rod at rest at L = θ_A (1 − x/2), touching the obstacle (tests/test_exchange_energy.py)
AT_REST = {"model.zeta": 1.0, "initial.u0": "0", "initial.u1": "0", "obstacle.gap": 0.0,
           "initial.theta0": "theta_A*(1 - x/2)", "solver.method": "direct", "mesh.cells": 50,
           "time.end": 1.0}


@pytest.fixture(scope="module")
def at_rest_fine():
    result = rodfem.simulate("paper1", {**AT_REST, "time.dt": 1e-5})
    assert result.status == "complete", result.summary
    return result.history


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
def test_a_rod_at_its_steady_temperature_on_the_obstacle_starts(at_rest_fine, scheme):
    """Completes with steps of at least time.dt_min = 1e-7 (the paper scheme's error control
    asked for 9.8e-8 at step 77 when Θ's error was measured against Θ's own size), and follows the fixed-step
    run at Δt = 1e-5 within 1 % of each quantity's largest size. Measured: the paper scheme
    5.2e-3 (u(1), σ(1)), 4.3e-3 (u(1/2)), 2.2e-3 (energy) in 419 steps; Crank–Nicolson at most
    3.5e-4 in 138."""
    result = rodfem.simulate("paper1", {**AT_REST, "time.scheme": scheme, "time.adaptive": True,
                                        "time.dt_min": 1e-7})
    assert result.status == "complete", result.summary.get("error")
    rows = result.history
    assert rows["t"][-1] == at_rest_fine["t"][-1] == 1.0 and len(rows) < 1000
    for column in COMPARED:
        reference = np.interp(rows["t"], at_rest_fine["t"], at_rest_fine[column])
        difference = np.abs(rows[column] - reference).max()
        assert difference <= 0.01 * np.abs(at_rest_fine[column]).max(), (column, difference)


def _failed_run(out, capsys, *settings):
    code = main(["run", "barber", *HOT_SET, "--set", "time.adaptive=true", *settings,
                 "--out", str(out)])
    err = capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert code == 3 and summary["status"] == "failed"
    return err, summary


@pytest.mark.parametrize("method", ["direct", "picard"])
@pytest.mark.parametrize("setting, asked", [("time.dt_min=1e-4", "7.07e-05"),
                                            ("time.tolerance=1e-12", "3.81e-10")])
def test_a_step_below_dt_min_is_said_to_be_the_error_control(shared_dir, capsys, method,
                                                              setting, asked):
    """The hot start's first step is accepted at 1.6e-6 (3.3e-6 taken, its first half kept):
    with time.dt_min = 1e-4 it cannot be, nor any step at all at tolerance 1e-12 (its error
    falls as the step's 0.6th power). The line says so, not that the method did not
    converge; the initial state is kept."""
    err, summary = _failed_run(shared_dir / "small", capsys, "--set", setting,
                               "--set", f"solver.method={method}")
    assert summary["steps"] == 0
    if COMM.rank == 0:
        dt_min = "0.0001" if "dt_min" in setting else "1e-09"
        assert f"the error control needs a step below time.dt_min = {dt_min} (it asks for " \
               f"{asked}); {ADVICE}" in err, err
        assert "converge" not in err and err.count("\n") == 1 and "Traceback" not in err


def test_a_half_step_the_method_does_not_solve_says_so(shared_dir, capsys):
    """Picard with one iteration allowed solves no step of the equations, at any size: the
    halves that judge the first step fail down to time.dt_min, and the line is Picard's."""
    err, summary = _failed_run(shared_dir / "picard", capsys, "--set", "solver.method=picard",
                               "--set", "solver.max_iterations=1")
    if COMM.rank == 0:
        assert "Picard iteration did not converge at step" in err and "after 1 iterations" in err
        assert "error control" not in err and err.count("\n") == 1 and "Traceback" not in err
