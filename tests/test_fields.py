"""fields.xdmf holds θ, u and σ at the saved steps, consistent with history.csv and with the
definitions θ = Θ − θ_A r and σ = u_x + ζ u_xt − aθ."""

import numpy as np

from conftest import COMM
from rodfem.post.fields import read_fields


def read(out):
    f = read_fields(out / "fields.xdmf")
    cells = np.stack([np.arange(f.x.size - 1), np.arange(1, f.x.size)], axis=1)
    return f.x, cells, {"theta": f.theta, "u": f.u, "sigma": f.sigma}


def test_fields_match_history_and_definitions(simulate):
    every = 7
    result, out = simulate("paper1", "mesh.cells=20", "time.end=0.35", f"output.every={every}")
    if COMM.rank != 0:
        return
    x, cells, fields = read(out)
    history = np.loadtxt(out / "history.csv", delimiter=",", skiprows=1)
    saved = np.arange(0, result.summary["steps"] + 1, every)
    assert fields["u"].shape[0] == saved.size
    right = np.flatnonzero(x == 1.0)[0]
    np.testing.assert_allclose(fields["u"][:, right], history[saved, 1], rtol=0, atol=1e-12)
    assert (history[saved, 4] < 0).any(), "the run should reach the obstacle"

    theta_A, a, zeta, k = 10.0, 0.017, 0.2, 1.0
    theta0 = theta_A * (np.cos(2 * np.pi * x) - np.sin(np.pi * x / 2))
    np.testing.assert_allclose(fields["theta"][0], theta0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fields["theta"][:, x == 0.0], theta_A, rtol=0, atol=1e-12)
    # θ = Θ − θ_A r with Θ the scheme's unknown at the last step (the run's final state).
    r = k / (k + 1) * result.x - 1
    last = np.interp(result.x, x[np.argsort(x)], fields["theta"][-1][np.argsort(x)])
    np.testing.assert_allclose(last, result.theta - theta_A * r, rtol=0, atol=1e-12)

    # σ per cell at t = 0: u₀ = 0 and u_t = u₁, so σ = ζ (u₁)_x − a θ̄ with θ̄ the cell mean.
    xa, xb = x[cells[:, 0]], x[cells[:, 1]]
    u1 = lambda s: 20 * s * (s - 1) ** 2  # noqa: E731
    theta_mean = 0.5 * (fields["theta"][0][cells[:, 0]] + fields["theta"][0][cells[:, 1]])
    sigma0 = zeta * (u1(xb) - u1(xa)) / (xb - xa) - a * theta_mean
    np.testing.assert_allclose(fields["sigma"][0], sigma0, rtol=1e-12, atol=1e-12)
    assert np.isfinite(fields["sigma"]).all() and np.abs(fields["sigma"][-1]).max() > 0
