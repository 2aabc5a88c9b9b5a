"""The Robin shift of the temperature (Remark 2.2): r(x) = c x − 1, c = k/(k + 1).

The scheme's unknown is Θ = θ + θ_A r, which vanishes at x = 0 and satisfies the homogeneous
Robin condition −Θ_x(1) = k Θ(1). ``forms.copetti.robin_shift`` is the same r in UFL.
"""

from __future__ import annotations

import numpy as np


def robin_shift(x: np.ndarray, k: float) -> np.ndarray:
    """r(x) = k/(k + 1) x − 1."""
    return k / (k + 1.0) * np.asarray(x) - 1.0


def temperature(Theta: np.ndarray, x: np.ndarray, k: float, theta_A: float) -> np.ndarray:
    """The physical temperature θ = Θ − θ_A r(x) of the shifted one."""
    return Theta - theta_A * robin_shift(x, k)


def shifted(theta: np.ndarray, x: np.ndarray, k: float, theta_A: float) -> np.ndarray:
    """Θ = θ + θ_A r(x)."""
    return theta + theta_A * robin_shift(x, k)
