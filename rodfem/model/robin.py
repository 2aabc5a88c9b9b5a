"""The Robin shift of the temperature (Remark 2.2): r(x) = c x − 1, c = k/(k + 1), and with the
obstacle at θ_O the whole lifting L = −θ_A r + θ_O s, s(x) = c x.

The scheme's unknown is Θ = θ − L (θ + θ_A r for θ_O = 0), which vanishes at x = 0 and satisfies
the homogeneous Robin condition −Θ_x(1) = k Θ(1) where the exchange is k (the constant law).
``forms.copetti.robin_shift``, ``obstacle_shift`` and ``lifting`` are the same in UFL.
"""

from __future__ import annotations

import numpy as np


def robin_shift(x: np.ndarray, k: float) -> np.ndarray:
    """r(x) = k/(k + 1) x − 1."""
    return k / (k + 1.0) * np.asarray(x) - 1.0


def lifting(x: np.ndarray, k: float, theta_A: float, theta_O: float = 0.0) -> np.ndarray:
    """L(x) = −θ_A r(x) + θ_O c x = θ_A (1 − c x) + θ_O c x: the constant law's steady
    temperature, from θ_A at x = 0 towards the obstacle's θ_O."""
    return theta_O * (k / (k + 1.0) * np.asarray(x)) - theta_A * robin_shift(x, k)


def temperature(Theta: np.ndarray, x: np.ndarray, scene) -> np.ndarray:
    """The physical temperature θ = Θ + L(x) of the shifted one, for a scene's k, θ_A, θ_O."""
    return Theta + lifting(x, scene["model.k"], scene["model.theta_A"],
                           scene["obstacle.temperature"])


def shifted(theta: np.ndarray, x: np.ndarray, scene) -> np.ndarray:
    """Θ = θ − L(x)."""
    return theta - lifting(x, scene["model.k"], scene["model.theta_A"],
                           scene["obstacle.temperature"])
