"""The Python API: rodfem.simulate and rodfem.load give what `rodfem run` writes, the physical
temperature, named columns, and the CLI's one-line errors as SceneError."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
from conftest import COMM, serial_only
from rodfem.cli import main

SHORT = {"time.end": 0.5, "mesh.cells": 40}


def test_history_has_named_columns_and_fields_the_physical_temperature():
    r = rodfem.simulate("paper1", SHORT)
    assert r.status == "complete" and r.history.dtype.names == (
        "t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations")
    assert len(r.history) == 501 and r.history["t"][-1] == 0.5
    assert r.scene["mesh.cells"] == 40 and r.path is None
    if COMM.rank == 0:
        f = r.fields
        np.testing.assert_array_equal(f.t, np.arange(0, 501, 50) * 1e-3)  # n Δt
        assert f.theta.shape == (11, 41) and f.sigma.shape == (11, 40)
        np.testing.assert_array_equal(f.theta[:, 0], 10.0)  # θ(0, t) = θ_A, not Θ = 0
        np.testing.assert_array_equal(f.u[-1, -1], r.history["u_1"][-1])
    else:
        assert r.fields is None


def test_api_returns_what_the_cli_writes(shared_dir):
    out = shared_dir / "cli"
    assert main(["run", "paper1", "--out", str(out), "--quiet", "--set", "time.end=0.5",
                 "--set", "mesh.cells=40"]) == 0
    written = rodfem.load(out)
    memory = rodfem.simulate("paper1", SHORT)
    np.testing.assert_array_equal(written.history, memory.history)
    assert written.status == "complete" and written.summary["steps"] == 500
    assert written.scene == memory.scene
    if COMM.rank == 0:
        for name in ("t", "x", "x_cells", "theta", "u", "sigma"):
            np.testing.assert_allclose(getattr(written.fields, name),
                                       getattr(memory.fields, name), rtol=0, atol=1e-13)
    again = rodfem.simulate("paper1", SHORT, out=shared_dir / "api")
    np.testing.assert_array_equal(again.history, memory.history)
    assert again.path == shared_dir / "api"
    with pytest.raises(rodfem.OutputError, match="exists"):
        rodfem.simulate("paper1", SHORT, out=shared_dir / "api")


def test_scene_forms_all_give_the_same_scene(tmp_path):
    # tmp_path is per process: each rank writes its own
    path = tmp_path / "s.toml"
    path.write_text("[model]\nk = 3.0\n")
    by_dict = rodfem.api.scene_of({"model": {"k": 3.0}})  # the defaults, k = 3
    assert by_dict["model.k"] == 3.0 and by_dict["solver.method"] == "direct"
    assert rodfem.api.scene_of(by_dict).sections == by_dict.sections
    assert rodfem.api.scene_of(path).sections == by_dict.sections
    paper = rodfem.api.scene_of("paper1", {"model.k": 3})
    assert paper["solver.method"] == "picard" and paper["model.k"] == 3.0
    assert rodfem.api.scene_of("paper1", ["model.k=3"]).sections == paper.sections


@pytest.mark.parametrize("scene, overrides, message", [
    ("paper1", "time.end=2", "overrides: must be a dict"),
    ("paper1", {"model.kk": 1}, "unknown key 'model.kk': did you mean 'k'?"),
    ("paper1", {"k": 1}, "must be section.key"),
    ("paper1", {"model.k": "ten"}, 'model.k: must be a number, got "ten"'),
    ("nonesuch", None, "not a built-in scene"),
    (3, None, "scene: must be a built-in name"),
    ({"model": {"k": -1}}, None, "model.k: must be >= 0"),
])
def test_mistakes_raise_scene_error_with_the_cli_line(scene, overrides, message):
    with pytest.raises(rodfem.SceneError, match=message.replace("?", r"\?")) as info:
        rodfem.simulate(scene, overrides)
    assert "\n" not in str(info.value)


def test_load_reads_a_failed_run(shared_dir):
    out = shared_dir / "failed"
    r = rodfem.simulate("paper1", {**SHORT, "obstacle.epsilon": 1e-7}, out=out)
    assert r.status == "failed" and "did not converge" in r.summary["error"]
    assert 0 < len(r.history) < 501 and r.fields is not None
    assert r.measures["t_final"] == r.history["t"][-1]


@serial_only
def test_api_demo_runs_under_mpirun():
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_sweep.py"
    env = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    import os

    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)],
                          env={**os.environ, **env}, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "12 scenes, 12 complete" in done.stdout
    assert done.stdout.count("scene 7 alone: the same") == 1  # rank 0 prints


def test_import_rodfem_is_light():
    code = ("import sys, rodfem; assert rodfem.__version__; "
            "print('dolfinx' in sys.modules, 'petsc4py' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.split() == ["False", "False"]
    assert MPI.COMM_WORLD.size >= 1


def killed(out, overrides, lost=("summary.json",)):
    """A run of paper1 into ``out`` made to look killed: its marker says running (no process
    holds it) and the files ``lost`` were never written."""
    import json

    rodfem.simulate("paper1", overrides, out=out)
    COMM.barrier()
    if COMM.rank == 0:
        marker = json.loads((out / "rodfem.json").read_text())
        (out / "rodfem.json").write_text(json.dumps({**marker, "status": "running"}))
        for name in lost:
            (out / name).unlink()
    COMM.barrier()
    return out


def test_load_reads_a_killed_run_as_gone(shared_dir):
    """A run killed before its end (its marker says running, no process holds it, no
    summary.json): load gives what its files hold."""
    out = killed(shared_dir / "killed", SHORT)
    r = rodfem.load(out)
    assert r.status == "gone" and len(r.history) == 501
    assert r.measures["t_final"] == 0.5


def test_load_refuses_what_is_not_a_run(tmp_path):
    from rodfem.post.runs import RunDirectoryError

    with pytest.raises(RunDirectoryError, match="not a rodfem run directory"):
        rodfem.load(tmp_path)


def test_load_reads_a_run_killed_before_its_first_checkpoint(shared_dir):
    out = killed(shared_dir / "early", SHORT, lost=("summary.json", "history.h5", "fields.xdmf"))
    r = rodfem.load(out)
    assert r.status == "gone" and len(r.history) == 0 and r.fields is None
    assert r.measures == {} and r.scene["mesh.cells"] == 40


def test_load_reads_columns_by_the_names_its_files_hold(shared_dir):
    """A killed run with probes (no summary.json): iterations_max is the largest of its
    `iterations` column, not of its last column; every column is read by the file's own names;
    a scene.toml edited to disagree with the history is refused in one line."""
    out = killed(shared_dir / "probed",
                 {**SHORT, "output.probes": [0.5], "output.history": ["contact"]})
    r = rodfem.load(out)
    assert r.status == "gone" and r.history.dtype.names[-4:] == (
        "contact", "u@0.5", "theta@0.5", "sigma@0.5")
    assert r.measures["iterations_max"] == r.history["iterations"].max() > 1
    np.testing.assert_array_equal(r.history["u@0.5"], r.history["u_half"])
    COMM.barrier()
    if COMM.rank == 0:
        scene = (out / "scene.toml").read_text()
        (out / "scene.toml").write_text(scene.replace("probes = [0.5]", "probes = [0.5, 0.7]"))
    COMM.barrier()
    from rodfem.output.readers import RunDirectoryError

    with pytest.raises(RunDirectoryError, match="does not describe") as refused:
        rodfem.load(out)
    assert "\n" not in str(refused.value) and "history.h5" in str(refused.value)


@serial_only
def test_load_reads_a_history_without_vtk_and_the_fields_when_asked(tmp_path):
    out = tmp_path / "run"
    rodfem.simulate("paper1", SHORT, out=out)
    code = ("import sys, rodfem; r = rodfem.load(sys.argv[1]); "
            "assert len(r.history) == 501; "
            "assert not {'vtkmodules', 'pyvista', 'dolfinx', 'mpi4py.MPI'} & set(sys.modules); "
            "assert 'fields' not in r.__dict__; r.fields.u; assert 'fields' in r.__dict__; "
            "assert not {'vtkmodules', 'pyvista'} & set(sys.modules)")
    done = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr


def test_history_every_keeps_every_nth_row_and_the_checks_see_every_step():
    every = rodfem.simulate("paper1", {**SHORT, "output.history_every": 7})
    full = rodfem.simulate("paper1", SHORT)
    kept = np.arange(0, 501, 7)
    assert every.history.tobytes() == full.history[kept].tobytes()
    for key in ("iterations_total", "iterations_max", "iterations_mean",
                "energy_non_increasing", "energy_max_increase", "steps", "contact"):
        assert every.summary[key] == full.summary[key], key
    # the measures of contact are kept over every step: those of the full history, bit for bit
    from rodfem.output.measures import MEASURES, TIMINGS

    history = {name: full.history[name] for name in full.history.dtype.names}
    without = {k: v for k, v in full.summary.items() if k != "contact"}
    for measure in MEASURES:
        if measure.name in TIMINGS or measure.name.endswith("_final"):
            continue
        kept, rows = every.measures[measure.name], measure.compute(history, full.scene, without)
        assert np.array_equal(kept, rows, equal_nan=True), measure.name
    assert full.measures["contact_intervals"] >= 1


@serial_only
def test_the_documented_csv_export_and_an_earlier_rodfem_s_history_csv_read_back(tmp_path):
    """docs/outputs.md's one-liner writes the history as CSV to round-trip precision; a run
    directory of an earlier rodfem (history.csv, no history.h5) loads to the same history."""
    out = tmp_path / "run"
    written = rodfem.simulate("paper1", {**SHORT, "output.probes": [0.25]}, out=out)
    code = ("import numpy as np, rodfem; h = rodfem.load('.').history; "
            "np.savetxt('history.csv', [list(r) for r in h.tolist()], fmt='%.17g', "
            "delimiter=',', header=','.join(h.dtype.names), comments='')")
    subprocess.run([sys.executable, "-c", code], cwd=out, check=True)
    (out / "history.h5").unlink()
    earlier = rodfem.load(out)
    assert earlier.history.dtype == written.history.dtype
    assert earlier.history.tobytes() == written.history.tobytes()
