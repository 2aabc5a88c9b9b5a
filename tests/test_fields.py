"""fields.xdmf holds θ, u and σ at the saved steps, consistent with history.h5 and with the
definitions θ = Θ − θ_A r and σ = u_x + ζ u_xt − aθ."""

import numpy as np

from conftest import COMM, history_rows
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
    history = history_rows(out)
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


def test_vtk_reads_the_fields_at_full_precision(simulate):
    """ParaView's reader (VTK's XDMF 3 reader, through pyvista) reads θ, u and σ as float64: u(1)
    at every saved time equals history.h5's u_1 to 1e-12 (a float32 read is off by ~1e-8)."""
    pyvista = __import__("pytest").importorskip("pyvista")
    every = 5
    result, out = simulate("paper1", "mesh.cells=20", "time.end=0.2", f"output.every={every}")
    if COMM.rank != 0:
        return
    history = history_rows(out)
    reader = pyvista.get_reader(str(out / "fields.xdmf"))
    times = np.asarray(reader.time_values)
    np.testing.assert_allclose(times, history[::every, 0], rtol=0, atol=1e-12)
    for step, t in zip(range(0, history.shape[0], every), times, strict=True):
        reader.set_active_time_value(t)
        blocks = reader.read()
        grids = {blocks.get_block_name(i): blocks[i] for i in range(blocks.n_blocks)}
        for name, data in (("theta", "point_data"), ("u", "point_data"), ("sigma", "cell_data")):
            assert getattr(grids[name], data)[name].dtype == np.float64, name
        u = grids["u"]
        right = np.argmax(u.points[:, 0])
        assert u.points[right, 0] == 1.0
        assert abs(u.point_data["u"][right] - history[step, 1]) <= 1e-12


def test_a_save_is_the_forms_expressions():
    """A save computes θ, σ and the heat flux from coefficients read off the forms' expressions
    once: for any state they are what interpolating the expressions gives, to the round-off of
    σ's terms (ζ/Δt times the strain) and of the flux's (θ_x)."""
    import rodfem.scene
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.output.pointwise import Pointwise, Probe

    scene = rodfem.scene.load("paper2", ["mesh.cells=37", "model.a=0.3", "model.k=3"])
    disc = Discretisation(scene, COMM)
    pointwise = Pointwise(disc)
    n = disc.nodes.size
    rng = np.random.default_rng(7)
    parts = [rng.normal(size=n) for _ in range(3)]  # Θ, D, U
    for part in parts:
        part[disc.nodes.x == 0.0] = 0.0
    s = np.concatenate(parts)
    θ_expected, cells = Probe(disc).evaluate(parts)
    np.testing.assert_array_equal(pointwise.field("theta", s), θ_expected)
    σ = pointwise.field("sigma", s)
    # σ's largest term: (1 + ζ/Δt) |ΔU|/h, summed over six terms
    scale = (1 + 1.0 / 0.001) * 37 * 4 * np.max(np.abs(s))
    assert np.max(np.abs(σ - cells["sigma"])) <= 16 * np.finfo(float).eps * scale
    assert np.max(np.abs(σ)) > 1e3  # a state that tests the coefficients
    q = pointwise.field("heat_flux", s)
    scale = 37 * 4 * (np.max(np.abs(θ_expected)) + 10)
    assert np.max(np.abs(q - cells["heat_flux"])) <= 16 * np.finfo(float).eps * scale
    h = np.diff(disc.nodes.x)
    np.testing.assert_allclose(q, -np.diff(θ_expected) / h, rtol=0, atol=1e-12 * scale)
    np.testing.assert_array_equal(pointwise.field("velocity", s), parts[1] / 0.001)
    np.testing.assert_array_equal(pointwise.field("u", s), parts[2])


def test_stock_meshio_cannot_read_them_and_rodfems_reader_can(simulate):
    """What docs/outputs.md says of meshio 5: ``meshio.read`` gives up on a file of several
    grids (with SystemExit), and its time-series reader does not know the topology "PolyLine";
    ``rodfem.read_fields`` reads the same file."""
    import pytest

    import rodfem

    meshio = pytest.importorskip("meshio")
    _, out = simulate("paper1", "mesh.cells=8", "time.end=0.1")
    if COMM.rank != 0:
        return
    with pytest.raises(SystemExit):
        meshio.read(out / "fields.xdmf")
    with pytest.raises(KeyError, match="PolyLine"):
        with meshio.xdmf.TimeSeriesReader(out / "fields.xdmf") as reader:
            reader.read_points_cells()
    f = rodfem.read_fields(str(out / "fields.xdmf"))  # a path as a string too
    assert f.names == ("theta", "u", "sigma") and f.u.shape == (3, 9)
