"""Convergence to the stationary solution of the model, derived in rodfem/model/steady.py: at rest
the shifted temperature vanishes and u*(x) = σ x + a θ_A (x − c x²/2), with σ = 0 without contact
and σ = (g − U*)/(1 + ε) with it; P1 is exact at the nodes, so the scheme must converge to it."""

import numpy as np
import pytest

from rodfem.model.steady import stationary


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
