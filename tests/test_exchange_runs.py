"""Runs of the direct method with a heat exchange that depends on the contact: the time schemes'
orders, a hot obstacle's run settling to its steady state, two ranks writing the serial history,
a step whose root is not unique, adaptive steps. The steps themselves: test_exchange_direct.py.
Serial and under ``mpirun -n 2``."""

import shutil

import numpy as np
import pytest

import rodfem.scene
from conftest import serial_only
from test_exchange_direct import HOT, LAWS, SCHEMES

# Smooth enough in time for the schemes' orders: the gap law's q' jumps at u(1) = g, a kink that
# a short length ℓ puts in the solution's derivative
SMOOTH = {"pressure": LAWS["pressure"],
          "gap": ("heat_exchange.law=gap", "heat_exchange.k1=5", "heat_exchange.length=0.1")}


@pytest.mark.parametrize("law", SMOOTH)
@pytest.mark.parametrize("scheme,order", [("paper", 1), ("crank-nicolson", 2)])
def test_time_schemes_keep_their_orders(law, scheme, order):
    """Self-convergence in Δt over a run with contact and heat entering from a hot obstacle:
    u(1), u(0.5), σ(1) and θ(1) at t = 0.4 differ between Δt and Δt/2 by O(Δt^order)."""
    values = []
    for j in range(5):
        overrides = ["solver.method=direct", f"time.scheme={scheme}", f"time.dt={2e-3 / 2**j}",
                     "time.end=0.4", "mesh.cells=50", *SMOOTH[law], *HOT,
                     'output.history=["theta_1"]']
        rows = rodfem.simulate(rodfem.scene.load("paper1", overrides)).history
        assert rows["sigma_1"].min() < 0.0  # the run touches the obstacle
        last = rows[-1]
        values.append(np.array([last[name] for name in ("u_1", "u_half", "sigma_1", "theta_1")]))
    differences = [np.abs(a - b).max() for a, b in zip(values, values[1:])]
    rates = np.log2(np.array(differences[:-1]) / differences[1:])
    assert abs(rates[-1] - order) < 0.1, rates


def steady_state(scene) -> tuple[float, float, float]:
    """(u(1), σ(1), θ(1)) at rest, u_t = θ_t = 0, for θ_A = 0 and the linear contact law: θ = θ(1) x
    with −θ_x(1) = h (θ(1) − θ_O), so θ(1) = h θ_O/(1 + h); σ = u_x − aθ constant, so
    u(1) = σ + a θ(1)/2 with σ = −p = −[u(1) − g]₊/ε; and h = k + q(u(1), p). One scalar
    equation in u(1), solved to round-off by bisection."""
    from rodfem.model import exchange

    law = exchange.of_scene(scene)
    a, g, epsilon = scene["model.a"], scene["obstacle.gap"], scene["obstacle.epsilon"]
    theta_O = scene["obstacle.temperature"]

    def state(u_1):
        p = max(u_1 - g, 0.0) / epsilon
        h = law.coefficient(u_1, p)
        theta_1 = h * theta_O / (1.0 + h)
        return u_1 + p - 0.5 * a * theta_1, -p, theta_1

    lo, hi = -1.0, 1.0  # F(lo) < 0 < F(hi) for these data
    assert state(lo)[0] < 0.0 < state(hi)[0]
    while True:
        mid = 0.5 * (lo + hi)
        if not lo < mid < hi:
            break
        lo, hi = (mid, hi) if state(mid)[0] < 0.0 else (lo, mid)
    return lo, *state(lo)[1:]


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("law", LAWS)
def test_hot_obstacle_run_settles_to_the_steady_state(law, scheme):
    """θ_A = 0, θ_O = 10, the rod pressed against the obstacle by its own heating: the run ends at
    the steady state of the closed form (which the P1 discretisation holds exactly: θ linear, σ
    constant, σ − u_x the cell means of −aθ)."""
    overrides = ["solver.method=direct", f"time.scheme={scheme}", "model.theta_A=0",
                 "obstacle.gap=0.02", "mesh.cells=50", "time.dt=0.002", "time.end=30",
                 *LAWS[law], *HOT, 'output.history=["theta_1", "heat_flux_1"]',
                 ]
    scene = rodfem.scene.load("paper2", overrides)
    rows = rodfem.simulate(scene).history
    u_1, sigma_1, theta_1 = steady_state(scene)
    assert sigma_1 < 0.0  # in contact
    last = rows[-1]
    assert abs(last["u_1"] - u_1) <= 1e-12
    assert abs(last["sigma_1"] - sigma_1) <= 1e-10 * abs(sigma_1)
    assert abs(last["theta_1"] - theta_1) <= 1e-10 * abs(theta_1)
    # θ(1) = (θ_A + h θ_O)/(1 + h): the flux through the contact is h (θ(1) − θ_O) = −θ(1)
    assert abs(last["heat_flux_1"] + theta_1) <= 1e-10 * abs(theta_1)


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("law,scheme", [("pressure", "paper"), ("gap", "crank-nicolson")])
def test_two_ranks_write_the_serial_history(tmp_path, law, scheme):
    """``mpirun -n 2 rodfem run`` with the exchange: the serial history bit for bit."""
    from test_parallel import rodfem_run

    sets = ["solver.method=direct", "time.end=1", f"time.scheme={scheme}", *LAWS[law], *HOT,
            'output.history=["theta_1", "heat_flux_1"]']
    args = ["paper1", *(part for key in sets for part in ("--set", key))]
    serial = rodfem_run(tmp_path, 1, *args)
    parallel = rodfem_run(tmp_path, 2, *args)
    assert serial.shape[0] == 1001
    np.testing.assert_array_equal(parallel, serial)


# Heat from a hot obstacle that the contact conducts the better the harder it is pressed, and a
# rod that expands much with it (a = 0.1): at Δt = 1e-3 the step's equation decreases in u(1)
# once in contact (w + α N k₁ < 0 against 1 + w/ε), and a root is not unique
UNSTABLE = ("obstacle.temperature=100", "heat_exchange.law=pressure", "heat_exchange.k1=1000",
            "model.a=0.1", "solver.method=direct", "time.end=0.3")


@pytest.mark.parametrize("kernel", ["1", "0"], ids=["compiled", "petsc"])
def test_a_step_without_a_unique_root_fails_clearly(monkeypatch, kernel):
    """The run stops at that step with a message that says why and what helps, both loops at the
    same step; a quarter of the step takes it, and adaptive steps retry it smaller."""
    monkeypatch.setenv("RODFEM_KERNEL", kernel)
    failed = rodfem.simulate(rodfem.scene.load("paper1", list(UNSTABLE)))
    assert failed.status == "failed"
    error = failed.summary["error"]
    assert error.startswith("step 127 (t = 0.127) cannot be taken")
    assert "may have several roots" in error and "smaller time.dt" in error
    assert len(failed.history) == 127  # steps 0 .. 126: the state stays at the last step solved
    smaller = rodfem.simulate(rodfem.scene.load("paper1", [*UNSTABLE, "time.dt=2.5e-4"]))
    assert smaller.status == "complete"
    adaptive = rodfem.simulate(rodfem.scene.load("paper1", [*UNSTABLE, "time.adaptive=true"]))
    assert adaptive.status == "complete"
    assert np.diff(adaptive.history["t"]).min() < 1e-3 / 4


@pytest.mark.parametrize("scheme", SCHEMES)
def test_adaptive_steps_with_the_exchange(scheme):
    """Adaptive steps: k₁ = 0 is the constant law bit for bit (the same steps), and the gap law's
    run ends near a fixed fine step's (the tolerance's accuracy)."""
    common = ["solver.method=direct", "time.adaptive=true", f"time.scheme={scheme}",
              "time.end=1", *HOT, 'output.history=["theta_1", "heat_flux_1"]']
    constant, zero = (rodfem.simulate(rodfem.scene.load("paper1", [*common, *extra])).history
                      for extra in ((), ("heat_exchange.law=gap", "heat_exchange.k1=0")))
    np.testing.assert_array_equal(zero, constant)
    gap = rodfem.simulate(rodfem.scene.load("paper1", [*common, *LAWS["gap"]])).history
    fine = rodfem.simulate(rodfem.scene.load("paper1", [*common[:1], *common[2:], *LAWS["gap"],
                                                        "time.dt=1e-4"])).history
    assert abs(gap["theta_1"][-1] - constant["theta_1"][-1]) > 1e-3  # the exchange heated
    assert abs(gap["theta_1"][-1] - fine["theta_1"][-1]) < 1e-2 * abs(fine["theta_1"][-1])
    assert abs(gap["u_1"][-1] - fine["u_1"][-1]) < 1e-2 * np.abs(fine["u_1"]).max()
