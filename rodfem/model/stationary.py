r"""The stationary solution of the model (1.1)–(1.5), which every run tends to.

At rest, θ_t = u_t = 0. The heat equation gives θ_xx = 0 with θ(0) = θ_A and −θ_x(1) = kθ(1), so
θ* = θ_A (1 − c x), c = k/(k+1): the shifted temperature θ̂* = θ* + θ_A r vanishes. The momentum
equation gives σ_x = 0, so σ = u_x − aθ* is a constant and

    u*(x) = σ x + a θ_A (x − c x²/2),   u*(1) = σ + U*,   U* = a θ_A (1 − c/2).

Without contact (U* ≤ g) σ = 0. With contact, σ = −(u*(1) − g)/ε gives σ = (g − U*)/(1 + ε).
P1 Galerkin for this 1D problem is exact at the nodes (the H¹_E projection interpolates), so the
scheme's stationary state is u* at the nodes and Θ = 0.
"""

from __future__ import annotations

import numpy as np


def stationary(x: np.ndarray, a: float, theta_A: float, k: float, epsilon: float, gap: float):
    """u*(x) and the constant stress σ* of the stationary state."""
    c = k / (k + 1.0)
    free = a * theta_A * (1.0 - c / 2.0)
    sigma = (gap - free) / (1.0 + epsilon) if free > gap else 0.0
    return sigma * x + a * theta_A * (x - c * x**2 / 2.0), sigma
