"""The manufactured solution (rodfem.model.manufactured): its sources are right, and every method
with each time scheme converges to it at the scheme's order: 2 in space (L2, P1), 1 in time for the
paper's scheme and 2 for Crank–Nicolson's. Rates are least-squares slopes, within ±0.1, with an
absolute cap on the finest error."""

import numpy as np
import pytest

import rodfem.scene
from rodfem.model import manufactured
from rodfem.run import simulate

SCENE = rodfem.scene.load("manufactured")
PARAMETERS = SCENE.parameters


def field(name, x, t):
    return manufactured.exact(name, np.asarray(x, dtype=float), t, SCENE)


def test_sources_leave_the_exact_solution_exact():
    """θ_t − θ_xx + a u_xt − f_θ and b u_tt − σ_x − f_u vanish at the exact solution, by central
    differences of step 1e-3: their error, h² × (fourth derivatives ≈ (π/2)⁴), is below 1e-5."""
    a, b, zeta = (PARAMETERS[p] for p in ("a", "b", "zeta"))
    x = np.linspace(0.05, 0.95, 19)
    d = 1e-3
    for t in (0.0, 0.37, 1.0):
        def u(dx=0.0, dt=0.0, t=t):
            return field("u", x + dx, t + dt)

        def theta(dx=0.0, dt=0.0, t=t):
            return field("theta", x + dx, t + dt)

        theta_t = (theta(dt=d) - theta(dt=-d)) / (2 * d)
        theta_x = (theta(dx=d) - theta(dx=-d)) / (2 * d)
        theta_xx = (theta(dx=d) - 2 * theta() + theta(dx=-d)) / d**2
        u_tt = (u(dt=d) - 2 * u() + u(dt=-d)) / d**2
        u_xt = (u(d, d) - u(d, -d) - u(-d, d) + u(-d, -d)) / (4 * d * d)
        u_xx = (u(dx=d) - 2 * u() + u(dx=-d)) / d**2
        u_xxt = ((u(d, d) - 2 * u(0, d) + u(-d, d)) - (u(d, -d) - 2 * u(0, -d) + u(-d, -d))) / (
            2 * d**3)
        at = {**PARAMETERS, "t": t}
        f_heat = SCENE.source_term("heat")(x, at)
        f_momentum = SCENE.source_term("momentum")(x, at)
        sigma_x = u_xx + zeta * u_xxt - a * theta_x
        np.testing.assert_allclose(theta_t - theta_xx + a * u_xt, f_heat, rtol=0, atol=1e-5)
        np.testing.assert_allclose(b * u_tt - sigma_x, f_momentum, rtol=0, atol=1e-5)


def test_initial_and_boundary_data_are_the_exact_solution():
    x = np.linspace(0.0, 1.0, 101)
    d = 1e-6
    np.testing.assert_allclose(SCENE.initial("u0")(x, PARAMETERS), field("u", x, 0.0), atol=1e-15)
    np.testing.assert_allclose(SCENE.initial("theta0")(x, PARAMETERS), field("theta", x, 0.0),
                               atol=1e-15)
    u_t = (field("u", x, d) - field("u", x, -d)) / (2 * d)
    np.testing.assert_allclose(SCENE.initial("u1")(x, PARAMETERS), u_t, atol=1e-9)
    for t in (0.0, 0.5, 1.0):
        # u(0) = 0 and θ(0) = θ_A; at x = 1, θ = θ_x = 0 and u_x = 0, so that the Robin condition
        # holds and σ(1) = 0: no contact force, the obstacle (gap 10) is never reached.
        assert field("u", [0.0], t)[0] == 0.0 and field("theta", [0.0], t)[0] == 0.0
        assert abs(field("theta", [1.0], t)[0]) < 1e-15
        for name in ("u", "theta"):
            slope = (field(name, [1.0 + d], t)[0] - field(name, [1.0 - d], t)[0]) / (2 * d)
            assert abs(slope) < 1e-9
        assert abs(field("u", [1.0], t)[0]) < SCENE["obstacle.gap"]


def _rate(steps, errors):
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


def _errors(cells, dt, *overrides):
    scene = manufactured.scene(cells, dt, 1.0, overrides)
    result = simulate(scene, None, progress=False)
    assert result.status == "complete"
    return manufactured.errors(result, scene)


# Time ladders: fine enough in space (h² ≪ the time error) and in the asymptotic range.
TIME = {
    "paper": (1, 2000, [0.01, 0.005, 0.0025, 0.00125]),
    "crank-nicolson": (2, 1000, [0.1, 0.05, 0.025, 0.0125]),
}


@pytest.mark.parametrize("method", ["direct", "newton", "picard"])
@pytest.mark.parametrize("scheme", list(TIME))
def test_order_in_time(scheme, method):
    order, cells, dts = TIME[scheme]
    errors = [_errors(cells, dt, f"time.scheme={scheme}", f"solver.method={method}")
              for dt in dts]
    for name in ("u", "theta"):
        e = [err[name] for err in errors]
        assert abs(_rate(dts, e) - order) <= 0.1, (name, e)
        assert e[-1] <= dts[-1] ** order  # the error constant is below 1


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
@pytest.mark.parametrize("scheme", list(TIME))
def test_order_in_space(scheme, mass):
    """L2 errors at T = 1 against h = 1/8 … 1/64, with Δt small enough that the time error is
    below a twentieth of the finest space error (measured: 1/29 for the paper's scheme at
    Δt = 1e-4, 1/1400 for Crank–Nicolson's at 1e-3)."""
    dt = 1e-4 if scheme == "paper" else 1e-3
    cells = [8, 16, 32, 64]
    errors = [_errors(n, dt, f"time.scheme={scheme}", f"discretisation.mass={mass}")
              for n in cells]
    h = [1.0 / n for n in cells]
    for name in ("u", "theta"):
        e = [err[name] for err in errors]
        assert abs(_rate(h, e) - 2.0) <= 0.1, (name, e)
        assert e[-1] <= h[-1] ** 2
