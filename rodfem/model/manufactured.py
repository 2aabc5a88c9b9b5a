"""Manufactured solutions of the coupled heat–momentum system without contact.

The built-in scene ``manufactured`` (``rodfem/scene/builtin/manufactured.toml``) holds the body
sources that keep

    u(x, t) = (cos t + sin t) sin(πx/2),    θ(x, t) = e^{−t} x (1 − x)²

an exact solution of (1.1)–(1.2) with every boundary condition, the obstacle far away. The scene
``manufactured-gap`` keeps the same u with

    θ(x, t) = θ_A (1 − x) + γ(t) x (1 − x),    γ(t) = −θ_A − θ_O h(t),

under the gap law of heat exchange h = k + k₁ exp((u(1, t) − g)/ℓ) across the gap to an obstacle
at θ_O (k₁ = 2, ℓ = 0.2, g = 1.5, θ_O = 2): θ(1) = 0 and −θ_x(1) = θ_A + γ = h (θ(1) − θ_O), so
the exchange, which depends on the end's displacement, is what the boundary condition asks.

Only these scenes pay for sources. Each exact solution is written once, as expressions of the
same whitelisted grammar as the scene's (``SOLUTIONS``), and ``tests/test_manufactured.py`` checks
the scenes' sources and initial data against them by finite differences, so that neither can drift
from the other.
"""

from __future__ import annotations

import numpy as np

from rodfem.model.robin import temperature
from rodfem.scene.expressions import Expression
from rodfem.scene.loading import SOURCE_NAMES, Scene, load

# The exact solution of each built-in manufactured scene, by the scene's name.
SOLUTIONS = {
    "manufactured": {
        "u": "(cos(t) + sin(t))*sin(pi*x/2)",
        "theta": "exp(-t)*x*(1 - x)**2",
    },
    "manufactured-gap": {
        "u": "(cos(t) + sin(t))*sin(pi*x/2)",
        "theta": "theta_A*(1 - x) - (theta_A + 2*k + 4*exp(5*(cos(t) + sin(t)) - 7.5))*x*(1 - x)",
    },
}
EXACT = SOLUTIONS["manufactured"]
# Gauss–Legendre points and weights on (0, 1), 6 points: exact for polynomials of degree 11, so the
# L2 error of a P1 function against a smooth one is integrated far below its own size.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)
_GAUSS_X, _GAUSS_W = 0.5 * (_GAUSS_X + 1.0), 0.5 * _GAUSS_W


def exact(name: str, x: np.ndarray, t: float, scene: Scene) -> np.ndarray:
    """The exact ``u`` or ``theta`` of a manufactured scene (built in, by its name) at the points
    x and time t."""
    if scene.source not in SOLUTIONS:
        raise ValueError(f"scene '{scene.source}': not a manufactured scene "
                         f"({', '.join(SOLUTIONS)})")
    return Expression(SOLUTIONS[scene.source][name], SOURCE_NAMES)(
        x, {**scene.parameters, "t": t})


def scene(cells: int, dt: float, end: float = 1.0, overrides=(),
          name: str = "manufactured") -> Scene:
    """The manufactured scene ``name`` on ``cells`` cells with time step ``dt`` up to ``end``."""
    return load(name, [f"mesh.cells={cells}", f"time.dt={dt!r}", f"time.end={end!r}",
                       *overrides])


def l2_error(x: np.ndarray, values: np.ndarray, f) -> float:
    """‖v_h − f‖ over (0, 1) for the P1 function v_h with ``values`` at the sorted nodes x and a
    function f of points, by 6-point Gauss quadrature on every cell."""
    h = np.diff(x)
    points = x[:-1, None] + h[:, None] * _GAUSS_X[None, :]
    v_h = values[:-1, None] + (values[1:] - values[:-1])[:, None] * _GAUSS_X[None, :]
    difference = v_h - f(points.ravel()).reshape(points.shape)
    return float(np.sqrt(np.sum(h[:, None] * _GAUSS_W[None, :] * difference**2)))


def errors(result, scene: Scene) -> dict[str, float]:
    """L2 errors at the end time of a run of the manufactured scene (a
    :class:`rodfem.run.RunResult`): of U against u and of the temperature θ = Θ + L against
    θ."""
    t = scene["time.end"]
    theta = temperature(result.theta, result.x, scene)
    return {
        "u": l2_error(result.x, result.u, lambda p: exact("u", p, t, scene)),
        "theta": l2_error(result.x, theta, lambda p: exact("theta", p, t, scene)),
    }
