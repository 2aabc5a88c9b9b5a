"""What a notebook sees: short reprs of Scene, Result, Fields and SweepResult; a Scene as a
read-only mapping of its dotted keys; the bridges to pandas and xarray, whose values are the
arrays they came from, unchanged; and the quick figures of Result.plot and SweepResult.plot."""

import dataclasses
import subprocess
import sys
import tomllib
import warnings

import matplotlib
import numpy as np
import pytest

import rodfem
import rodfem.api
import rodfem.output.readers
from conftest import COMM, serial_only
from rodfem.scene import SCHEMA
from rodfem.scene import load as load_scene

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SHORT = {"time.end": 0.5, "mesh.cells": 40, "model.k": 10}
SWEEP = {"scene": "paper1", "set": {"time.end": 0.2, "mesh.cells": 20},
         "grid": {"obstacle.epsilon": {"logspace": [1e-3, 1e-1, 3]}, "model.zeta": [0.2, 1.0]}}


@pytest.fixture(scope="module")
def run():
    return rodfem.simulate("paper1", SHORT)


def quiet_sweep(spec, **options):
    """rodfem.sweep without the warning of its coarse steps (it is a test of the table)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
        return rodfem.sweep(spec, **options)


@pytest.fixture(scope="module")
def table():
    return quiet_sweep(SWEEP)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --- Scene as a mapping -------------------------------------------------------------------------

def test_a_scene_is_the_mapping_of_the_keys_that_apply():
    scene = load_scene("paper1")
    flat = {f"{section}.{key}": value for section, keys in scene.data().items()
            for key, value in keys.items() if section in SCHEMA}
    assert dict(scene) == flat and list(scene.keys()) == list(flat) and len(scene) == len(flat)
    assert dict(scene.items()) == flat and list(scene.values()) == list(flat.values())
    assert "model.k" in scene and scene["model.k"] == 1.0 and scene.get("model.k") == 1.0
    # a key that applies only to adaptive steps: not among a fixed-step scene's keys
    assert "time.tolerance" not in scene and "time.tolerance" not in scene.keys()
    assert scene.get("time.tolerance") is None
    assert scene["time.tolerance"] == SCHEMA["time"]["tolerance"].default  # read all the same
    adaptive = rodfem.api.scene_of("paper1", {"time.adaptive": True})
    assert "time.tolerance" in adaptive and "time.tolerance" in dict(adaptive)
    for missing in ("model", "model.kk", "nope.k", "model.k.x", 3, None):
        assert missing not in scene
        assert scene.get(missing) is None
    with pytest.raises(KeyError):
        scene["model.kk"]


def test_a_scene_is_read_only_and_compares_as_before():
    scene = load_scene("paper1")
    with pytest.raises(TypeError):
        scene["model.k"] = 2.0
    with pytest.raises(TypeError):
        del scene["model.k"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.description = "changed"
    again = rodfem.api.scene_of(scene)
    assert again == scene and again is not scene
    assert rodfem.api.scene_of(scene, {"model.k": 2.0}) != scene
    assert dataclasses.replace(scene, source="elsewhere") != scene  # every field counts
    assert scene != dict(scene)  # equality is the dataclass's, not a mapping's
    with pytest.raises(TypeError, match="unhashable"):  # as before: it holds dicts
        hash(scene)
    # a scene given as overrides sets its keys
    assert rodfem.api.scene_of("paper2", dict(scene))["model.zeta"] == scene["model.zeta"]


@pytest.mark.parametrize("name", ["paper1", "paper2", "paper3", "paper4", "paper5", "barber",
                                  "impact", "manufactured", "stiff"])
def test_a_scene_s_repr_is_short_and_names_what_differs(name):
    scene = load_scene(name)
    text = repr(scene)
    assert len(text) < 500 and text.startswith(f"<rodfem.Scene {name}: ")
    assert all(len(line) <= 100 for line in text.splitlines())
    assert scene.description[:40] in text


def test_a_scene_s_repr_shows_the_keys_set():
    scene = rodfem.api.scene_of("paper1", {"model.k": 10, "time.end": 0.5})
    text = repr(scene)
    assert "3 not the default" in text  # model.k, time.end and paper1's solver.method
    for line in ("model.k = 10.0", "time.end = 0.5", 'solver.method = "picard"'):
        assert line in text
    assert "model.zeta" not in text  # at its default
    many = rodfem.api.scene_of({
        "description": "A scene that sets many keys " * 10,
        "model": {"a": 0.5, "zeta": 0.5, "k": 0.5, "theta_A": 0.5},
        "initial": {"theta0": "theta_A + " + "+".join(["x"] * 60), "u0": "x*(x - 1)/1000",
                    "u1": "x*(x - 1)/100"},
        "obstacle": {"gap": 0.5, "epsilon": 0.5}, "mesh": {"cells": 50},
        "time": {"dt": 0.002, "end": 0.5, "scheme": "crank-nicolson"},
        "discretisation": {"mass": "consistent"}, "solver": {"method": "newton"},
        "output": {"probes": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6], "history": ["theta_1"]}})
    text = repr(many)
    assert len(text) < 500 and all(len(line) <= 100 for line in text.splitlines())
    assert "17 not the default" in text and text.endswith(" more") and "+x+…" in text
    assert "A scene that sets many keys A scene" in text and "…\n" in text  # shortened


# --- Result -------------------------------------------------------------------------------------

def test_a_result_s_repr_is_a_few_lines(run):
    text = repr(run)
    assert len(text) < 500 and len(text.splitlines()) <= 5
    assert text.splitlines()[0] == ("<rodfem.Result complete: paper1, 500 steps, t = 0.5 of 0.5; "
                                    "history of 501 rows × 7 columns>")
    assert all(len(line) <= 100 for line in text.splitlines())
    measures = run.measures
    assert f"u_1_final = {measures['u_1_final']:.4g}" in text
    assert f"contact_fraction = {measures['contact_fraction']:.4g}" in text
    assert "[" not in text  # no array


def test_a_failed_result_s_repr_says_why(shared_dir):
    r = rodfem.simulate("paper1", {**SHORT, "obstacle.epsilon": 1e-7}, out=shared_dir / "f")
    text = repr(r)
    assert text.startswith("<rodfem.Result failed: ") and "error: " in text
    assert f"path: {shared_dir / 'f'}" in text and len(text) < 600


def test_a_result_s_repr_says_where_its_measures_are_cut(tmp_path):
    """More measures than the repr shows: the list ends in "…", never cut silently."""
    declared = "".join(f'm{i} = {{ column = "u_1", reduce = "max" }}\n' for i in range(6))
    scene = tmp_path / "many.toml"
    scene.write_text(f'scene = "paper1"\n[measures]\n{declared}', encoding="utf-8")
    text = repr(rodfem.simulate(scene, {"time.end": 0.02, "mesh.cells": 10}))
    assert "m3 = " in text and "m4 = " not in text
    assert text.rstrip().endswith(", …")


def test_a_result_without_steps_says_so():
    """A run killed before its first checkpoint (load gives it): no step, no measures."""
    scene = load_scene("paper1")
    empty = rodfem.api.Result(scene, {"status": "gone"},
                              rodfem.api.named_history(np.zeros((0, 7))))
    assert repr(empty) == ("<rodfem.Result gone: paper1, no step recorded; history of 0 rows × "
                           "7 columns>")
    assert len(empty.to_pandas()) == 0 and list(empty.to_pandas().columns)[0] == "u_1"


def test_to_pandas_is_the_history_indexed_by_t(run):
    frame = run.to_pandas()
    assert frame.index.name == "t" and list(frame.columns) == list(run.history.dtype.names[1:])
    np.testing.assert_array_equal(frame.index.to_numpy(), run.history["t"])
    for name in frame.columns:
        assert frame[name].dtype == run.history[name].dtype
        np.testing.assert_array_equal(frame[name].to_numpy(), run.history[name])
    assert frame.attrs["scene"] == "paper1"
    assert rodfem.api.scene_of(tomllib.loads(frame.attrs["scene_toml"])).sections \
        == run.scene.sections  # the attributes give the scene again
    assert frame.reset_index()["t"].to_numpy().tobytes() == run.history["t"].tobytes()


def test_fields_repr_and_to_xarray_are_the_saved_arrays(run):
    if COMM.rank != 0:
        assert run.fields is None  # the fields are gathered on rank 0
        return
    fields = run.fields
    text = repr(fields)
    assert text == ("<rodfem.Fields of paper1: 11 saves, t = 0 … 0.5; 41 nodes on [0, 1]>\n"
                    "    theta, u: (11, 41) on the nodes\n    sigma: (11, 40) on the cells")
    data = fields.to_xarray()
    assert set(data.data_vars) == {"theta", "u", "sigma"}
    assert data["theta"].dims == ("t", "x") and data["sigma"].dims == ("t", "x_cells")
    for name in ("t", "x", "x_cells"):
        assert data[name].values.tobytes() == getattr(fields, name).tobytes()
    for name in ("theta", "u", "sigma"):
        assert data[name].values.tobytes() == getattr(fields, name).tobytes()
    assert data.attrs["scene"] == "paper1" and "k = 10.0" in data.attrs["scene_toml"]
    assert "temperature" in data["theta"].attrs["long_name"]
    alone = rodfem.output.readers.Fields(fields.x, fields.t, fields.x_cells, u=fields.u)
    assert repr(alone).startswith("<rodfem.Fields: 11 saves") and alone.to_xarray().attrs == {}


def test_plot_draws_the_history(run):
    axes = run.plot()
    assert len(axes) == 3 and [a.get_ylabel() for a in axes] == [
        "$u(1, t)$ [$L$]", r"$\sigma(1, t)$ [$E$]", r"$\hat{E}$ [$EL$]"]  # rodfem.output.names
    assert axes[-1].get_xlabel() == "$t$ [$t_0$]"
    u_1, gap = axes[0].lines
    np.testing.assert_array_equal(u_1.get_xdata(), run.history["t"])
    np.testing.assert_array_equal(u_1.get_ydata(), run.history["u_1"])
    np.testing.assert_array_equal(gap.get_ydata(), [0.1, 0.1])  # g
    np.testing.assert_array_equal(axes[2].lines[0].get_ydata(), run.history["energy"])
    assert axes[1].get_title(loc="left") == "contact stress σ(1, tⁿ)"
    _, ax = plt.subplots()
    assert run.plot(["u_half", "ut_1"], ax=ax) is ax
    assert [line.get_label() for line in ax.lines] == ["u_half", "ut_1"]
    np.testing.assert_array_equal(ax.lines[1].get_ydata(), run.history["ut_1"])
    with pytest.raises(KeyError, match="no column 'theta_1'"):
        run.plot(["theta_1"])


@serial_only
def test_the_quick_figures_and_bridges_load_neither_vtk_nor_dolfinx():
    code = ("import sys, numpy as np, matplotlib; matplotlib.use('Agg'); import rodfem.api as a; "
            "r = a.Result(a.scene_of('paper1'), {'status': 'gone'}, "
            "a.named_history(np.zeros((3, 7)))); r.plot(); r.to_pandas(); "
            "assert not {'vtkmodules', 'pyvista', 'dolfinx'} & set(sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_a_missing_library_is_named():
    from rodfem.output.frames import require

    with pytest.raises(ImportError, match="needs nonesuch.*apt-get install python3-nonesuch"):
        require("nonesuch", "to_pandas()")


# --- SweepResult --------------------------------------------------------------------------------

def test_a_sweep_s_repr_is_short(table):
    text = repr(table)
    assert len(text) < 500 and "[" not in text
    assert text.splitlines()[:3] == ["<rodfem.SweepResult complete: 6 scenes (6 complete)>",
                                     "    obstacle.epsilon: 3 values, 0.001 … 0.1",
                                     "    model.zeta: 2 values, 0.2 … 1"]


def test_sweep_to_pandas_is_the_table(table, shared_dir):
    frame = table.to_pandas()
    assert frame.index.name == "index" and frame.attrs["axes"] == list(table.axes)
    assert list(frame.columns) == [c for c in table.columns if c != "index"]
    np.testing.assert_array_equal(frame.index.to_numpy(), table["index"])
    for name in frame.columns:
        np.testing.assert_array_equal(frame[name].to_numpy(), table[name])
    assert frame.loc[5, "model.zeta"] == 1.0 and frame.loc[5, "obstacle.epsilon"] == 0.1
    written = quiet_sweep(SWEEP, out=shared_dir / "s")
    again = rodfem.load_sweep(shared_dir / "s").to_pandas()
    assert f"path: {shared_dir / 's'}" in repr(written)
    measured = [c for c in frame.columns if c != "loop_seconds"]
    assert again[measured].equals(frame[measured])


def test_sweep_to_pandas_gives_a_boolean_key_as_booleans():
    """results.csv writes a swept boolean as true and false: the frame has the booleans."""
    from rodfem.output import results
    from rodfem.output.frames import results_frame
    from rodfem.output.measures import NAMES

    header = ["index", "time.adaptive", "solver.method", "status", *NAMES, "error"]
    rows = [[str(i), adaptive, "direct", "complete", *["0"] * len(NAMES), ""]
            for i, adaptive in enumerate(("true", "false"))]
    axes, columns = results.parse("\n".join(",".join(r) for r in [header, *rows]) + "\n")
    frame = results_frame(columns, axes)
    assert frame["time.adaptive"].tolist() == [True, False]
    assert frame["time.adaptive"].dtype == bool
    assert frame["solver.method"].tolist() == ["direct", "direct"]
    assert frame["status"].tolist() == ["complete", "complete"]


def test_sweep_plot_draws_a_measure_against_a_key(table):
    ax = table.plot("max_penetration")
    assert ax.get_xscale() == "log" and ax.get_xlabel() == r"$\varepsilon$ (obstacle.epsilon)"
    assert ax.get_ylabel() == "max penetration $[u(1) - g]_+$ [$L$]"
    assert [line.get_label() for line in ax.lines] == [r"$\zeta$ = 0.2", r"$\zeta$ = 1"]
    rows = table["model.zeta"] == 1.0
    np.testing.assert_array_equal(ax.lines[1].get_xdata(), table["obstacle.epsilon"][rows])
    np.testing.assert_array_equal(ax.lines[1].get_ydata(), table["max_penetration"][rows])
    by_zeta = table.plot("u_1_final", x="model.zeta")
    assert by_zeta.get_xscale() == "linear" and len(by_zeta.lines) == 3
    with pytest.raises(KeyError, match="no measure 'model.zeta'"):
        table.plot("model.zeta")
    with pytest.raises(KeyError, match="not a swept key"):
        table.plot("u_1_final", x="model.k")
