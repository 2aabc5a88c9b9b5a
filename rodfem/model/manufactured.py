"""A manufactured solution of the coupled heat–momentum system without contact.

The built-in scene ``manufactured`` (``rodfem/scene/builtin/manufactured.toml``) holds the body
sources that keep

    u(x, t) = (cos t + sin t) sin(πx/2),    θ(x, t) = e^{−t} x (1 − x)²

an exact solution of (1.1)–(1.2) with every boundary condition, the obstacle far away. Only this
scene pays for sources. The exact solution is written once, as expressions of the same whitelisted
grammar as the scene's (``EXACT``), and ``tests/test_manufactured.py`` checks the scene's sources
and initial data against it by finite differences, so that neither can drift from the other.
"""

from __future__ import annotations

import numpy as np

from rodfem.model.robin import temperature
from rodfem.scene.expressions import Expression
from rodfem.scene.loading import SOURCE_NAMES, Scene, load

EXACT = {
    "u": "(cos(t) + sin(t))*sin(pi*x/2)",
    "theta": "exp(-t)*x*(1 - x)**2",
}
# Gauss–Legendre points and weights on (0, 1), 6 points: exact for polynomials of degree 11, so the
# L2 error of a P1 function against a smooth one is integrated far below its own size.
_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(6)
_GAUSS_X, _GAUSS_W = 0.5 * (_GAUSS_X + 1.0), 0.5 * _GAUSS_W


def exact(name: str, x: np.ndarray, t: float, scene: Scene) -> np.ndarray:
    """The exact ``u`` or ``theta`` at the points x and time t."""
    return Expression(EXACT[name], SOURCE_NAMES)(x, {**scene.parameters, "t": t})


def scene(cells: int, dt: float, end: float = 1.0, overrides=()) -> Scene:
    """The manufactured scene on ``cells`` cells with time step ``dt`` up to ``end``."""
    return load("manufactured", [f"mesh.cells={cells}", f"time.dt={dt!r}", f"time.end={end!r}",
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
    :class:`rodfem.run.RunResult`): of U against u and of the temperature θ = Θ − θ_A r against
    θ."""
    t = scene["time.end"]
    theta = temperature(result.theta, result.x, scene)
    return {
        "u": l2_error(result.x, result.u, lambda p: exact("u", p, t, scene)),
        "theta": l2_error(result.x, theta, lambda p: exact("theta", p, t, scene)),
    }
