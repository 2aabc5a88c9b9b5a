r"""Convergence to the stationary solution of the model.

At rest, θ_t = u_t = 0. The heat equation gives θ_xx = 0 with θ(0) = θ_A and −θ_x(1) = kθ(1), so
θ* = θ_A (1 − c x), c = k/(k+1): the shifted temperature θ̂* = θ* + θ_A r vanishes. The momentum
equation gives σ_x = 0, so σ = u_x − aθ* is a constant and

    u*(x) = σ x + a θ_A (x − c x²/2),   u*(1) = σ + U*,   U* = a θ_A (1 − c/2).

Without contact (U* ≤ g) σ = 0. With contact, σ = −(u*(1) − g)/ε gives σ = (g − U*)/(1 + ε).
Galerkin P1 for this 1D problem is exact at the nodes (the H¹_E projection interpolates), so the
discrete stationary state is u* at the nodes and Θ = 0, and the scheme must converge to it.
"""

import numpy as np
import pytest


def stationary(x, a, theta_A, k, epsilon, gap):
    c = k / (k + 1.0)
    free = a * theta_A * (1.0 - c / 2.0)
    sigma = (gap - free) / (1.0 + epsilon) if free > gap else 0.0
    return sigma * x + a * theta_A * (x - c * x**2 / 2.0), sigma


@pytest.mark.parametrize("k, in_contact", [(1.0, True), (100.0, False)])
def test_converges_to_stationary_solution(simulate, k, in_contact):
    result, _ = simulate(
        "paper2",  # ζ = 1
        f"model.k={k}", "mesh.cells=50", "time.dt=0.005", "time.end=25", "output.every=5000",
    )
    assert result.status == "complete"
    u_star, sigma = stationary(result.x, 0.017, 10.0, k, 0.01, 0.1)
    assert (sigma < 0) == in_contact
    assert np.max(np.abs(result.u - u_star)) < 1e-6
    assert np.max(np.abs(result.theta)) < 1e-6
