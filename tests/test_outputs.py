"""What a scene chooses to record: probes (``output.probes``), the quantities of
``output.history`` and the saved fields (``output.fields``); in every loop, serially and under
MPI, equal to what the default columns and the field files say."""

import os
import shutil
import subprocess

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM, serial_only
from rodfem.output.columns import NAMES
from rodfem.post.fields import read_fields

QUANTITIES = ('output.history=["theta_1", "heat_flux_1", "contact_force", "contact", '
              '"penetration"]')
ALL_FIELDS = 'output.fields=["theta", "u", "sigma", "velocity", "heat_flux"]'
DEFAULT_HEADER = "t,u_1,u_half,ut_1,sigma_1,energy,iterations"


def history(out):
    from rodfem.output.readers import read_history

    read = read_history(out / "history.h5")
    return {name: read[name] for name in read.names}, list(read.names)


# the three loops: compiled direct, compiled Picard, PETSc's (newton); both time schemes
LOOPS = [
    ("paper1", ["solver.method=direct"]),
    ("paper1", ["solver.method=picard"]),
    ("paper1", ["solver.method=newton"]),
    ("paper1", ["solver.method=direct", "time.scheme=crank-nicolson"]),
    ("paper1", ["solver.method=picard", "time.scheme=crank-nicolson"]),
    ("paper1", ["solver.method=direct", "obstacle.kind=rigid"]),
    ("paper3", ["solver.method=newton", "discretisation.mass=consistent"]),
]


@pytest.mark.parametrize("scene, overrides", LOOPS, ids=[" ".join(o) for _, o in LOOPS])
def test_probes_equal_the_default_columns(simulate, scene, overrides):
    """u@1 = u_1, u@0.5 = u_half, sigma@1 = sigma_1 and theta@1 = theta_1 bit for bit; theta@0
    = θ_A; the quantities are what they are defined as; and recording them changes no default
    column."""
    base = [*overrides, "mesh.cells=40", "time.end=0.6"]
    _, plain = simulate(scene, *base)
    result, out = simulate(scene, *base, "output.probes=[0, 0.5, 1, 0.3]", QUANTITIES)
    if COMM.rank != 0:
        return
    h, header = history(out)
    reference, reference_header = history(plain)
    assert ",".join(reference_header) == DEFAULT_HEADER
    assert header == [*NAMES, "theta_1", "heat_flux_1", "contact_force", "contact", "penetration",
                      "u@0", "theta@0", "sigma@0", "u@0.5", "theta@0.5", "sigma@0.5",
                      "u@1", "theta@1", "sigma@1", "u@0.3", "theta@0.3", "sigma@0.3"]
    for name in NAMES:
        np.testing.assert_array_equal(h[name], reference[name], err_msg=name)
    np.testing.assert_array_equal(h["u@1"], h["u_1"])
    np.testing.assert_array_equal(h["u@0.5"], h["u_half"])
    np.testing.assert_array_equal(h["sigma@1"], h["sigma_1"])
    np.testing.assert_array_equal(h["theta@1"], h["theta_1"])
    np.testing.assert_array_equal(h["u@0"], 0.0)
    np.testing.assert_allclose(h["theta@0"], 10.0, rtol=0, atol=1e-14)
    k = 100.0 if scene == "paper3" else 1.0
    np.testing.assert_array_equal(h["heat_flux_1"], k * h["theta_1"])
    np.testing.assert_array_equal(h["contact_force"], -h["sigma_1"])
    np.testing.assert_array_equal(h["contact"], (h["contact_force"] > 0).astype(float))
    assert h["contact"].any() and not h["contact"].all(), "the run should touch and leave"
    assert np.all(h["contact_force"] >= 0)
    gap = rodfem.scene.load(scene, base)["obstacle.gap"]
    np.testing.assert_array_equal(h["penetration"], h["u_1"] - gap)


def test_probes_match_the_saved_fields(simulate):
    """At the saved steps, probes are the fields read back from fields.xdmf at their points: θ
    and u interpolated, σ on the cell holding x (at a node, the mean of its two cells); theta_1
    is θ(1), the velocity at x = 1 is ut_1, the heat flux is −θ_x per cell."""
    every = 10
    # nodes (0, 0.5, 1; 0.3 is the node at 0.30000000000000004) and inside a cell (0.71)
    probes = [0.0, 0.3, 0.5, 0.71, 1.0]
    result, out = simulate("paper2", "mesh.cells=20", "time.end=0.5", f"output.every={every}",
                           f"output.probes={probes}", QUANTITIES, ALL_FIELDS)
    if COMM.rank != 0:
        return
    h, _ = history(out)
    f = read_fields(out / "fields.xdmf")
    assert f.names == ("theta", "u", "velocity", "sigma", "heat_flux")
    saved = np.arange(0, result.summary["steps"] + 1, every)
    np.testing.assert_array_equal(f.t, h["t"][saved])
    for name in ("theta", "u", "velocity", "sigma", "heat_flux"):
        assert getattr(f, name).dtype == np.float64
    scale = {name: np.abs(getattr(f, name)).max() for name in f.names}
    eps = np.finfo(float).eps
    for x in probes:
        for name in ("theta", "u"):
            at_x = np.array([np.interp(x, f.x, values) for values in getattr(f, name)])
            np.testing.assert_allclose(h[f"{name}@{x:g}"][saved], at_x, rtol=0,
                                       atol=16 * eps * scale[name])
        if x == 1.0:
            continue  # σ(1) is the obstacle's, as sigma_1 (test above)
        j = int(np.argmin(np.abs(f.x - x)))  # the nearest node, and is x that node?
        on_node = abs(f.x[j] - x) <= 1e-10 * (f.x[1] - f.x[0])
        if not on_node:
            j = np.searchsorted(f.x, x, side="right") - 1
        cell = (f.sigma[:, 0] if j == 0 else 0.5 * (f.sigma[:, j - 1] + f.sigma[:, j])
                if on_node else f.sigma[:, j])
        # σ's terms reach ζ/Δt times the strain: its round-off is that times eps
        np.testing.assert_allclose(h[f"sigma@{x:g}"][saved], cell, rtol=0,
                                   atol=64 * eps * scale["sigma"] * (1 + 1 / 0.001))
    np.testing.assert_allclose(h["theta_1"][saved], f.theta[:, -1], rtol=0,
                               atol=16 * eps * scale["theta"])
    np.testing.assert_allclose(h["ut_1"][saved], f.velocity[:, -1], rtol=4 * eps, atol=0)
    h_cells = np.diff(f.x)
    np.testing.assert_allclose(f.heat_flux, -np.diff(f.theta, axis=1) / h_cells, rtol=0,
                               atol=1e-10 * scale["theta"])


def test_chosen_fields_alone(simulate):
    """A run saves the fields its scene names, and only those; the reader and the plots take
    what is there."""
    result, out = simulate("paper1", "mesh.cells=16", "time.end=0.2",
                           'output.fields=["velocity", "heat_flux"]')
    if COMM.rank != 0:
        return
    f = read_fields(out / "fields.xdmf")
    assert f.names == ("velocity", "heat_flux")
    assert f.theta is None and f.u is None and f.sigma is None
    assert f.velocity.shape == (5, 17) and f.heat_flux.shape == (5, 16)
    text = (out / "fields.xdmf").read_text()
    assert 'Name="theta"' not in text and 'Name="velocity"' in text
    # θ(0, t) = θ_A: the heat flux is −θ_x, so its first cell is (θ_A − θ(h))/h
    assert np.all(np.isfinite(f.heat_flux))


def test_plot_draws_what_was_saved(simulate, shared_dir):
    from rodfem.post.plot import plot

    _, out = simulate("paper1", "mesh.cells=16", "time.end=0.2",
                      'output.fields=["u", "heat_flux"]')
    if COMM.rank != 0:
        return
    written = plot([out], shared_dir / "figures")
    names = sorted(p.name for p in written)
    assert names == ["contact.png", "energy.png", "spacetime_heat_flux.png", "spacetime_u.png"]


def test_readings_of_the_compiled_loops_are_pythons():
    """The compiled loops evaluate the readings as History.record does, bit for bit: from the
    state a loop leaves, the readings of its last row."""
    import rodfem.scene
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.output.history import History
    from rodfem.solver.compiled import compiled_loop
    from rodfem.solver.methods import make_method
    from rodfem.solver.record import RAW

    for method in ("direct", "picard"):
        scene = rodfem.scene.load("paper1", [f"solver.method={method}", "mesh.cells=30",
                                             "output.probes=[0.1, 0.5, 0.55, 1]", QUANTITIES])
        disc = Discretisation(scene, COMM)
        m = make_method(disc)
        hist = History(disc)
        m.advance()  # the paper scheme's first step is the PETSc loop's
        kernel = compiled_loop(m, hist)
        assert kernel is not None, method
        rows = hist.reserve(150)
        kernel.advance(150, rows)
        expected = np.empty(hist.readings.count)
        hist.readings(m.values, expected)
        assert hist.readings.count == 11  # u, θ at 4 points (θ(1) for theta_1 too), σ at 3
        np.testing.assert_array_equal(rows[149, len(RAW):], expected)
        assert np.all(rows[:150, len(RAW):] != 0.0)


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_two_ranks_record_and_save_what_one_does(tmp_path):
    from test_parallel import MPI_ENV, RODFEM

    outs = []
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        command = [str(RODFEM), "run", "paper1", "--set", "time.end=1", "--set",
                   "output.probes=[0.2, 0.5, 0.9]", "--set", QUANTITIES, "--set", ALL_FIELDS,
                   "--out", str(out), "--quiet"]
        if ranks > 1:
            command = ["mpirun", "-n", str(ranks), *command]
        subprocess.run(command, check=True, env={**os.environ, **MPI_ENV}, capture_output=True,
                       timeout=600)
        outs.append(out)
    serial, parallel = (history(out)[0] for out in outs)
    assert list(serial) == list(parallel)
    for name in serial:
        np.testing.assert_array_equal(parallel[name], serial[name], err_msg=name)
    one, two = (read_fields(out / "fields.xdmf") for out in outs)
    for name in ("x", "t", "x_cells", *one.names):
        np.testing.assert_array_equal(getattr(two, name), getattr(one, name), err_msg=name)


def test_a_probe_at_a_node_is_at_the_node(simulate):
    """x = 0.3 on 10 cells is the node the mesh places at 0.30000000000000004: its σ is the mean
    of the two cells there, its u the node's value, whichever of the two is written."""
    _, out = simulate("paper1", "mesh.cells=10", "time.end=0.1", "output.every=20",
                      "output.probes=[0.3, 0.30000000000000004, 0.35]")
    if COMM.rank != 0:
        return
    h, _ = history(out)
    f = read_fields(out / "fields.xdmf")
    assert f.x[3] != 0.3 and abs(f.x[3] - 0.3) < 1e-15
    for field in ("u", "theta", "sigma"):
        np.testing.assert_array_equal(h[f"{field}@0.3"], h[f"{field}@0.30000000000000004"])
    saved = np.arange(0, 101, 20)
    mean = 0.5 * (f.sigma[:, 2] + f.sigma[:, 3])
    np.testing.assert_allclose(h["sigma@0.3"][saved], mean, rtol=0,
                               atol=1e-12 * np.abs(f.sigma).max())
    np.testing.assert_array_equal(h["u@0.3"][saved], f.u[:, 3])
    assert np.all(np.abs(h["sigma@0.35"][saved] - f.sigma[:, 3])
                  <= 1e-12 * np.abs(f.sigma).max())


def test_what_a_run_records_counts_in_its_size():
    """The size check counts the columns and fields a scene chooses."""
    import rodfem.scene
    from rodfem.output.sizes import estimate

    base = ["time.end=1", "time.dt=1e-5", "mesh.cells=100"]
    plain = estimate(rodfem.scene.load("paper1", base))
    probes = [f"output.probes={np.linspace(0, 1, 1000).tolist()}"]
    many = estimate(rodfem.scene.load("paper1", [*base, *probes]))
    # 3000 columns more, of 8 bytes (float64), on 100 001 rows
    assert many[0] - plain[0] >= 3000 * 8 * 100_001
    fewer = estimate(rodfem.scene.load("paper1", [*base, *probes, "output.history_every=10"]))
    assert fewer[0] - plain[0] < (many[0] - plain[0]) / 9
    fields = estimate(rodfem.scene.load("paper1", [*base, 'output.fields=["u"]']))
    assert fields[0] < plain[0]


def test_probes_read_minus_zero_as_zero():
    import rodfem.scene
    from rodfem.output.columns import for_scene

    scene = rodfem.scene.load("paper1", ["output.probes=[-0.0, 0.5]"])
    assert [c.name for c in for_scene(scene)][7:10] == ["u@0", "theta@0", "sigma@0"]


def test_a_checkpoint_of_an_earlier_rodfem_resumes():
    """A checkpoint written before the [output] keys it lacks existed: the same scene."""
    import rodfem.scene
    from rodfem.output.resume import _resolved, identity

    scene = rodfem.scene.load("paper1", [])
    old = scene.data()
    for key in ("fields", "history", "probes"):
        del old["output"][key]
    assert identity(_resolved(old)) == identity(scene.data())
    old["model"]["zeta"] = 5.0
    assert identity(_resolved(old)) != identity(scene.data())


@pytest.mark.parametrize("end, expected", [(0.2, 50), (8, 50), (10, 50), (10.001, 100),
                                           (400, 2000), (1000, 5000), (4000, 20000)])
def test_fields_are_saved_at_a_bounded_number_of_frames_by_default(end, expected):
    """output.every = 0 (the default): every 50 steps, or the round stride that keeps a long
    run to about 200 frames; a chosen output.every is kept as it is."""
    import rodfem.scene
    from rodfem.output.sizes import FRAMES, save_every

    scene = rodfem.scene.load("paper1", [f"time.end={end}"])
    assert save_every(scene) == expected
    assert scene.steps // expected <= FRAMES
    assert save_every(rodfem.scene.load("paper1", [f"time.end={end}", "output.every=3"])) == 3


# --- adaptive steps --------------------------------------------------------------------------

ADAPTIVE = ["time.adaptive=true", "mesh.cells=40", "time.end=3"]


def saved_steps(t: np.ndarray, interval: float) -> np.ndarray:
    """The rows whose fields an adaptive run saves: the first step of each save interval (the
    step whose ⌊t/interval⌋ exceeds the step before's), and the last."""
    frames = np.floor(t / interval)
    first = np.flatnonzero(np.diff(frames, prepend=-1.0) > 0)
    return np.union1d(first, [len(t) - 1])


@pytest.mark.parametrize("method", ["picard", "newton", "direct"])
def test_adaptive_runs_record_and_save_what_they_choose(simulate, method):
    """Probes, the quantities of output.history and every field, with steps of all sizes: the
    probes equal the default columns, and the fields are saved by time, at the first step of
    each interval of output.every steps of time.dt, where they equal the probes."""
    every, dt0 = 10, 1e-3
    result, out = simulate("paper1", *ADAPTIVE, f"solver.method={method}",
                           f"output.every={every}", "output.probes=[0, 0.5, 1]", QUANTITIES,
                           ALL_FIELDS)
    if COMM.rank != 0:
        return
    h, header = history(out)
    assert header == [*NAMES, "dt", "event", "theta_1", "heat_flux_1", "contact_force",
                      "contact", "penetration", "u@0", "theta@0", "sigma@0", "u@0.5", "theta@0.5",
                      "sigma@0.5", "u@1", "theta@1", "sigma@1"]
    np.testing.assert_array_equal(h["u@1"], h["u_1"])
    np.testing.assert_array_equal(h["u@0.5"], h["u_half"])
    np.testing.assert_array_equal(h["sigma@1"], h["sigma_1"])
    np.testing.assert_array_equal(h["theta@1"], h["theta_1"])
    np.testing.assert_array_equal(h["contact_force"], -h["sigma_1"])
    assert h["event"].sum() >= 2 and h["contact"].any() and not h["contact"].all()
    f = read_fields(out / "fields.xdmf")
    assert f.names == ("theta", "u", "velocity", "sigma", "heat_flux")
    saved = saved_steps(h["t"], every * dt0)
    assert len(saved) <= 3.0 / (every * dt0) + 2 < len(h["t"])  # fewer frames than steps
    np.testing.assert_array_equal(f.t, h["t"][saved])
    np.testing.assert_array_equal(f.u[:, -1], h["u_1"][saved])
    np.testing.assert_array_equal(f.theta[:, -1], h["theta_1"][saved])
    np.testing.assert_array_equal(f.velocity[:, -1], h["ut_1"][saved])


@serial_only
def test_an_adaptive_history_of_every_nth_step_keeps_the_measures_of_every_step():
    """output.history_every = 3 keeps the rows of the steps 0, 3, 6, … (by count, whatever
    their times), and the measures of contact are those of every step."""
    import rodfem

    scene = {"time.adaptive": True, "mesh.cells": 40, "time.end": 3.0}
    every = rodfem.simulate("paper1", {**scene, "output.history_every": 3})
    full = rodfem.simulate("paper1", scene)
    assert every.history.tobytes() == full.history[::3].tobytes()
    assert every.summary["contact"] == full.summary["contact"]
    assert every.measures["last_contact_change"] == full.measures["last_contact_change"]
    assert len(every.history) == (len(full.history) + 2) // 3 < len(full.history)


@serial_only
def test_the_frames_of_an_adaptive_run_are_bounded_by_time():
    """Many more steps than T/Δt₀ (a tight tolerance): as many frames as a run of fixed steps
    Δt₀ saves, at most, and the size check's estimate counts them."""
    import rodfem
    from rodfem.output.sizes import estimate, save_interval

    overrides = {"time.adaptive": True, "time.dt": 1e-2, "time.tolerance": 1e-5,
                 "mesh.cells": 40, "time.end": 3.0}
    result = rodfem.simulate("paper1", overrides)
    scene, steps = result.scene, result.summary["steps"]
    assert steps > 3 * scene.steps
    assert save_interval(scene) == 50 * 1e-2  # the default: every 50 steps of Δt₀
    assert result.fields.t.size <= 3.0 / 0.5 + 2
    fixed = estimate(rodfem.scene.load("paper1", [f"{k}={v}" for k, v in overrides.items()
                                                  if k in ("time.dt", "mesh.cells",
                                                           "time.end")]))
    # T/Δt₀ rows (the steps are not known before the run), with two columns more (dt, event)
    rows = scene.steps + 2
    assert estimate(scene)[0] - fixed[0] == rows * 2 * 8
