"""Sweeps: the designs of a sweep file, its rows against single runs (serially and under
mpirun), the same table for any number of ranks, failing scenes as rows, a killed or interrupted
sweep resumed to the same table, histories, and bad sweep files refused with one line."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
from conftest import COMM, representative, serial_only
from rodfem.cli import main
from rodfem.output import journal
from rodfem.output import results as table
from rodfem.output.measures import NAMES as MEASURES
from rodfem.output.measures import TIMINGS
from rodfem.run import SetUps
from rodfem.run import simulate as run_scene
from rodfem.studies.sweep import design
from rodfem.studies.sweep.run import load_sweep, run_sweep

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
       "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}
SMALL = {"mesh.cells": 30, "time.end": 1.0, "solver.method": "direct"}
GRID = {"scene": "paper1", "set": SMALL,
        "grid": {"model.k": [0.1, 1, 10], "model.zeta": {"linspace": [0.2, 1.0, 3]}}}


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def reproducible(result) -> dict:
    """The columns of a table that do not depend on timing."""
    return {k: v for k, v in result.columns.items() if k not in TIMINGS}


def assert_same_table(a, b) -> None:
    ca, cb = reproducible(a), reproducible(b)
    assert ca.keys() == cb.keys()
    for name in ca:
        if ca[name].dtype == object:
            assert list(ca[name]) == list(cb[name]), name
        else:
            np.testing.assert_array_equal(ca[name], cb[name], err_msg=name)


# --- designs ---------------------------------------------------------------------------------

def test_grid_is_the_product_in_file_order_last_fastest():
    sweep = design.parse(GRID, "g")
    assert sweep.axes == ("model.k", "model.zeta")
    assert [tuple(p.values()) for p in sweep.points] == [
        (k, z) for k in (0.1, 1, 10) for z in np.linspace(0.2, 1.0, 3)]


def test_logspace_ends_are_values_and_integer_keys_are_rounded():
    sweep = design.parse({"scene": "paper1", "grid": {
        "obstacle.epsilon": {"logspace": [1e-4, 1e-2, 3]},
        "mesh.cells": {"linspace": [10, 20, 3]}}}, "g")
    eps = sorted({p["obstacle.epsilon"] for p in sweep.points})
    np.testing.assert_allclose(eps, [1e-4, 1e-3, 1e-2], rtol=1e-14)
    assert sorted({p["mesh.cells"] for p in sweep.points}) == [10, 15, 20]
    assert all(isinstance(p["mesh.cells"], int) for p in sweep.points)


def test_zip_takes_lists_together_after_the_grid():
    sweep = design.parse({"scene": "paper1", "grid": {"model.k": [1, 2]},
                          "zip": {"obstacle.gap": [0.1, 0.2, 0.3], "model.a": [0, 0.01, 0.02]}},
                         "z")
    assert len(sweep) == 6
    assert sweep.points[4] == {"model.k": 2, "obstacle.gap": 0.2, "model.a": 0.01}


@pytest.mark.parametrize("method", ["random", "latin-hypercube"])
def test_samples_are_seeded_within_their_ranges(method):
    spec = {"scene": "paper1", "sample": {"method": method, "count": 40, "seed": 7, "ranges": {
        "model.k": {"log": [0.1, 100]}, "model.zeta": [0.2, 1.0]}}}
    a, b = design.parse(spec, "s"), design.parse(spec, "s")
    assert a.points == b.points and len(a) == 40
    k = np.array([p["model.k"] for p in a.points])
    zeta = np.array([p["model.zeta"] for p in a.points])
    assert k.min() >= 0.1 and k.max() <= 100 and zeta.min() >= 0.2 and zeta.max() <= 1.0
    other = design.parse({**spec, "sample": {**spec["sample"], "seed": 8}}, "s")
    assert other.points != a.points
    if method == "latin-hypercube":  # one point in each of the 40 strata of every key
        strata = np.floor((zeta - 0.2) / 0.8 * 40).astype(int)
        assert sorted(strata) == list(range(40))
        strata = np.floor(np.log(k / 0.1) / np.log(1000) * 40).astype(int)
        assert sorted(np.minimum(strata, 39)) == list(range(40))


BAD = {
    "unknown key": ('[grid]\n"model.kk" = [1]\n', "unknown key 'model.kk'"),
    "unknown section": ('[grid]\n"modle.k" = [1]\n', "unknown section 'modle'"),
    "empty axis": ('[grid]\n"model.k" = []\n', "grid model.k: empty"),
    "not a list": ('[grid]\n"model.k" = 3\n', "grid model.k: must be a list"),
    "zip lengths": ('[zip]\n"model.k" = [1, 2]\n"model.a" = [0, 0.1, 0.2]\n', "one length"),
    "sample count": ('[sample]\ncount = 0\n[sample.ranges]\n"model.k" = [1, 2]\n',
                     "sample.count must be an integer from 1 to 1000000"),
    "huge axis": ('[grid]\n"model.k" = {linspace = [0, 1, 1000000000]}\n',
                  "count must be an integer from 1 to 1000000"),
    "huge sample": ('[sample]\ncount = 1000000000\n[sample.ranges]\n"model.k" = [1, 2]\n',
                    "sample.count must be an integer from 1 to 1000000"),
    "overflowing axis": ('[grid]\n"model.k" = {linspace = [1e308, -1e308, 3]}\n', "overflows"),
    "fixed and swept": ('[set]\n"model.k" = 1\n[grid]\n"model.k" = [1, 2]\n',
                        "model.k is both set"),
    "swept twice": ('[grid]\n"model.k" = [1, 2]\n[zip]\n"model.k" = [1, 2]\n', "swept twice"),
    "bad value": ('[grid]\n"model.k" = [1, -2]\n', "scene 2 of 2 (model.k = -2): model.k: must"),
    "unknown entry": ('grdi = 1\n', "unknown entry 'grdi'"),
    "linspace shape": ('[grid]\n"model.k" = {linspace = [1, 2]}\n', "linspace must be"),
    "sampled choice": ('[sample]\ncount = 2\n[sample.ranges]\n"solver.method" = [1, 2]\n',
                       "only numbers can be sampled"),
}


@serial_only
@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_sweep_files_are_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    body, expected = BAD[case]
    sweep = write(tmp_path / "bad.toml", f'scene = "paper1"\n{body}')
    out = tmp_path / "out"
    assert main(["sweep", str(sweep), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expected in err and "Traceback" not in err, err
    assert not out.exists()


# --- rows against single runs ----------------------------------------------------------------

def test_set_ups_reused_across_structures_give_the_fresh_runs_bit_for_bit():
    """Scenes of one mesh that switch method, time scheme, coupling, inertia and obstacle share
    a discretisation; each history equals its fresh run's exactly."""
    base = ["mesh.cells=24", "time.end=0.3"]
    variants = [["solver.method=direct"], ["solver.method=picard", "model.k=3"],
                ["solver.method=newton", "model.zeta=0.7"], ["model.a=0"],
                ["model.b=0", "model.zeta=1"], ["time.scheme=crank-nicolson", "model.a=0.05"],
                ["obstacle.kind=rigid", "solver.method=direct"], ["time.dt=0.002"],
                ["obstacle.temperature=25"],
                ["heat_exchange.law=pressure", "heat_exchange.k1=40", "obstacle.temperature=25"],
                ["heat_exchange.law=gap", "heat_exchange.length=0.05", "model.theta_A=-5"],
                ["solver.method=direct"]]
    setups = SetUps()
    for extra in variants:
        scene = rodfem.scene.load("paper1", base + extra)
        shared = run_scene(scene, None, MPI.COMM_SELF, progress=False, setups=setups)
        fresh = run_scene(scene, None, MPI.COMM_SELF, progress=False)
        np.testing.assert_array_equal(shared.history, fresh.history, err_msg=str(extra))


def test_rows_equal_single_runs_serially_and_under_mpirun():
    """Under mpirun the ranks deal the scenes; every row equals the scene run alone."""
    result = run_sweep(GRID)
    sweep = design.parse(GRID, "g")
    assert len(result) == len(sweep) and list(result["index"]) == list(range(len(sweep)))
    for i in range(len(sweep)):
        alone = run_scene(sweep.scene(i), None, MPI.COMM_SELF, progress=False).history
        assert result["u_1_final"][i] == alone[-1, 1]  # bit for bit (the issue asks 1e-13)
        assert result["sigma_1_final"][i] == alone[-1, 4]
        assert result["status"][i] == "complete"
    if COMM.size > 1:  # the same table as one rank alone
        assert_same_table(result, run_sweep(GRID, comm=MPI.COMM_SELF))


def test_rows_equal_rodfem_run_files(shared_dir):
    """A row's measures are those of `rodfem run` of the same scene, read back by the API."""
    out = shared_dir / "sweep"
    result = run_sweep(GRID, out)
    sweep = design.parse(GRID, "g")
    i = 4
    single = rodfem.simulate(sweep.scene(i), out=shared_dir / "single")
    for name in MEASURES:
        if name not in TIMINGS:
            a, b = result[name][i], single.measures[name]
            assert a == b or (np.isnan(a) and np.isnan(b)), name
    assert load_sweep(out).status == "complete"
    assert_same_table(load_sweep(out), result)


def test_failing_scene_is_a_row_not_the_end(shared_dir):
    spec = {"scene": "paper1", "set": {**SMALL, "solver.method": "picard", "time.end": 0.5},
            "grid": {"obstacle.epsilon": [0.01, 1e-7, 0.02]}}
    result = run_sweep(spec, shared_dir / "out")
    assert list(result["status"]) == ["complete", "failed", "complete"]
    assert "did not converge" in result["error"][1] and result["error"][0] == ""
    assert result["t_final"][1] < 0.5 and result["t_final"][2] == 0.5


def test_histories_are_kept_and_read_per_scene(shared_dir):
    out = shared_dir / "h"
    result = run_sweep(GRID, out, histories=True)
    sweep = design.parse(GRID, "g")
    for i in (0, 8):
        alone = rodfem.simulate(sweep.scene(i), comm=MPI.COMM_SELF)
        np.testing.assert_array_equal(result.history(i), alone.history)
        assert result.history(i)["u_1"][-1] == result["u_1_final"][i]
    memory = run_sweep(GRID, histories=True)
    np.testing.assert_array_equal(memory.history(3), result.history(3))
    with pytest.raises(KeyError, match="histories"):
        run_sweep(GRID, shared_dir / "none").history(0)


# --- stopped and resumed ---------------------------------------------------------------------

SLOW = ('scene = "paper1"\n[set]\n"mesh.cells" = 60\n"time.end" = 3.0\n'
        '"solver.method" = "direct"\n[grid]\n"model.k" = {logspace = [0.1, 10, 6]}\n'
        '"model.zeta" = {linspace = [0.2, 1.0, 6]}\n')


def rodfem_command(*args, ranks=1):
    command = [RODFEM, *map(str, args)]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    return command


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    sweep = write(root / "slow.toml", SLOW)
    if COMM.size == 1:
        done = subprocess.run(rodfem_command("sweep", sweep, "--out", root / "whole"), env=ENV,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
    return sweep, root / "whole"


def wait_for_records(out: Path, count: int, process) -> None:
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None:
        if len(journal.read(out)) >= count:
            return
        time.sleep(0.02)
    raise AssertionError(f"the sweep did not record {count} scenes in time")


@serial_only
@pytest.mark.parametrize("how, ranks", representative(
    [("SIGKILL", 1), ("SIGINT", 1), ("SIGTERM", 1), ("SIGUSR1", 2), ("SIGKILL", 2)],
    [("SIGINT", 1), ("SIGUSR1", 2), ("SIGKILL", 2)]))
def test_stopped_sweep_resumes_to_the_same_table(how, ranks, uninterrupted, tmp_path):
    sweep, whole = uninterrupted
    out = tmp_path / "out"
    process = subprocess.Popen(rodfem_command("sweep", sweep, "--out", out, ranks=ranks),
                               env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    wait_for_records(out, 5, process)
    if how == "SIGKILL":  # every process at once (a node lost)
        subprocess.run(["pkill", "-KILL", "-f", f"rodfem sweep .*{out}"], check=False)
    else:  # the command, or mpirun, which forwards SIGUSR1 to the ranks
        process.send_signal(getattr(signal, how))
    _, err = process.communicate(timeout=120)
    deadline = time.monotonic() + 30  # every rank gone (and its lock with it)
    while subprocess.run(["pgrep", "-f", f"rodfem sweep .*{out}"],
                         capture_output=True).returncode == 0:
        assert time.monotonic() < deadline
        time.sleep(0.1)
    if how == "SIGKILL":
        assert process.returncode != 0
    else:
        if ranks == 1:
            assert process.returncode == 128 + getattr(signal, how), err
        assert "rodfem resume" in err and "Traceback" not in err, err
        assert load_sweep(out).status in ("interrupted", "gone")
    if how == "SIGINT":
        (out / journal.DIRECTORY / "notes.txt").write_text("mine")
    before = {i for i, r in journal.read(out).items()
              if table.status(r.line, ("model.k", "model.zeta")) in ("complete", "failed")}
    assert 5 <= len(before) < 36
    if how == "SIGKILL" and ranks == 1:  # the figures of the rows so far
        from rodfem.post.sweep import plot_sweep

        drawn = plot_sweep(out)
        assert (out / "figures" / "sweep_u_1_final.png") in drawn
    done = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    summary = load_sweep(out)
    assert summary.status == "complete"
    assert_same_table(summary, load_sweep(whole))
    import json

    ran = json.loads((out / "summary.json").read_text())["ran_this_time"]
    assert ran == 36 - len(before)  # no scene run twice
    assert not (out / journal.DIRECTORY).exists() or how == "SIGINT"
    if how == "SIGINT":  # a user's file in journal/ stays, and so does journal/
        assert (out / journal.DIRECTORY / "notes.txt").read_text() == "mine"
    again = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True,
                           text=True, timeout=600)
    assert again.returncode == 0 and "complete sweep" in again.stdout


@serial_only
def test_resume_of_a_sweep_refuses_set(uninterrupted, tmp_path, capsys):
    sweep, _ = uninterrupted
    out = tmp_path / "s"
    process = subprocess.Popen(rodfem_command("sweep", sweep, "--out", out), env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_records(out, 2, process)
    process.kill()
    process.communicate()
    assert main(["resume", str(out), "--set", "time.end=5"]) == 2
    assert "a sweep resumes as it was written" in capsys.readouterr().err


def test_cut_journal_record_is_run_again(shared_dir):
    """A record cut short (a power cut) ends its file for the reader: that scene runs again."""
    out = shared_dir / "cut"
    log = journal.Journal(out, 0, COMM.rank, b"sweep-01") if COMM.rank == 0 else None
    if COMM.rank == 0:
        out.mkdir()
        log.append(3, "3,x", np.ones((2, 7)))
        log.append(5, "5,y")
        log.close()
        data = log.path.read_bytes()
        assert {i: r.line for i, r in journal.read(out).items()} == {3: "3,x", 5: "5,y"}
        np.testing.assert_array_equal(journal.read(out)[3].history(), np.ones((2, 7)))
        log.path.write_bytes(data[:-1])
        assert list(journal.read(out)) == [3]
        log.path.write_bytes(data[:20] + b"\xff" + data[21:])
        assert list(journal.read(out)) == []


def test_every_measure_is_documented_with_its_meaning():
    from rodfem.output.measures import MEASURES as TABLE

    text = (Path(__file__).resolve().parents[1] / "docs" / "sweeps.md").read_text()
    for measure in TABLE:
        assert f"| `{measure.name}` | {measure.meaning} |" in text, measure.name
    for name, meaning in table.RUN_MEANINGS.items():  # the run's columns, after the measures
        assert f"| `{name}` | {meaning} |" in text, name


@serial_only
def test_a_full_disk_stops_the_sweep_with_exit_4_and_resume_completes_it(small_disk):
    spec = ('scene = "paper1"\n[set]\n"mesh.cells" = 30\n"time.end" = 2.0\n'
            '"solver.method" = "direct"\n[grid]\n"model.k" = [0.1, 1, 10]\n'
            '"model.zeta" = [0.2, 0.6, 1.0]\n')
    sweep = write(small_disk.parent / "full.toml", spec)
    out = small_disk / "sweep"
    done = subprocess.run(rodfem_command("sweep", sweep, "--out", out, "--histories"), env=ENV,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 4, done.stderr
    assert done.stderr.count("\n") == 1 and "No space left on device" in done.stderr
    assert "rodfem resume" in done.stderr and "Traceback" not in done.stderr
    subprocess.run(["mount", "-o", "remount,size=64m", str(small_disk)], check=True)
    again = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True,
                           text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert_same_table(load_sweep(out), run_sweep(sweep, comm=MPI.COMM_SELF))
    np.testing.assert_array_equal(load_sweep(out).history(8)["u_1"][-1],
                                  load_sweep(out)["u_1_final"][8])


@serial_only
def test_resume_refuses_an_edited_sweep_json_with_one_line(uninterrupted, tmp_path, capsys):
    import json

    sweep, _ = uninterrupted
    out = tmp_path / "edited"
    process = subprocess.Popen(rodfem_command("sweep", sweep, "--out", out), env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_records(out, 8, process)
    process.kill()
    process.communicate()
    meta = json.loads((out / "sweep.json").read_text())
    shorter = {**meta, "sweep": {**meta["sweep"], "grid": {
        **meta["sweep"]["grid"], "model.k": {"logspace": [0.1, 10, 2]}}}}
    (out / "sweep.json").write_text(json.dumps(shorter))
    assert main(["resume", str(out)]) == 2
    err = capsys.readouterr().err
    assert "is not the sweep this directory was run with" in err and err.count("\n") == 1, err
    (out / "sweep.json").write_text(json.dumps({k: v for k, v in meta.items() if k != "base"}))
    assert main(["resume", str(out)]) == 2
    err = capsys.readouterr().err
    assert "'base' is missing" in err and err.count("\n") == 1, err


@pytest.mark.parametrize("spec", [5, [1, 2]])
def test_sweep_of_what_is_not_a_sweep_is_a_scene_error(spec):
    with pytest.raises(rodfem.SceneError, match="must be a sweep file's path"):
        rodfem.sweep(spec)


def test_python_values_for_axes_and_overrides():
    sweep = design.parse({"scene": "paper1", "grid": {"model.k": (1.0, np.float64(2.0)),
                                                      "mesh.cells": np.array([10, 20])}}, "p")
    assert [p["mesh.cells"] for p in sweep.points][:2] == [10, 20]
    assert type(sweep.points[0]["mesh.cells"]) is int
    scene = rodfem.api.scene_of("paper1", {"mesh.cells": np.int64(20)})
    assert scene["mesh.cells"] == 20
    with pytest.raises(rodfem.SceneError, match="a list holds"):
        rodfem.api.scene_of("paper1", [5])


# --- adaptive steps --------------------------------------------------------------------------

ADAPTIVE = {"scene": "paper1", "set": {"mesh.cells": 40, "time.end": 20.0,
                                       "time.adaptive": True},
            "grid": {"time.tolerance": [1e-2, 1e-3, 1e-4], "model.zeta": [0.2, 1.0]}}


def test_an_adaptive_sweep_measures_non_uniform_steps(shared_dir):
    """A sweep of time.tolerance: each row is the run of its scene, and its measures of contact
    are those of its times tⁿ (not n times the first step), each step weighed by its length."""
    result = run_sweep(ADAPTIVE, shared_dir / "a", histories=True)
    sweep = design.parse(ADAPTIVE, "a")
    steps = []
    for i in range(len(sweep)):
        alone = rodfem.simulate(sweep.scene(i), comm=MPI.COMM_SELF)
        h = result.history(i)
        np.testing.assert_array_equal(h, alone.history)
        for name in MEASURES:
            if name not in TIMINGS:
                assert result[name][i] == alone.measures[name], name
        t, touching = h["t"], h["sigma_1"][1:] < 0.0
        changes = np.flatnonzero(np.diff(touching.astype(int), prepend=0))
        assert result["last_contact_change"][i] == t[1:][changes[-1]]
        assert result["contact_intervals"][i] == np.count_nonzero(
            np.diff(touching.astype(int), prepend=0) == 1)
        # a step ending at a contact event (just after the change) is in the state it began in
        event = h["event"][1:] != 0
        state = np.where(event, np.concatenate([[False], touching[:-1]]), touching)
        fraction = np.sum(np.diff(t)[state]) / t[-1]
        assert abs(result["contact_fraction"][i] - fraction) <= 1e-14 * len(t)
        assert result["t_final"][i] == 20.0 and result["status"][i] == "complete"
        steps.append(len(t) - 1)
    # the tolerance is the grid's first axis: 1e-4 takes more steps than 1e-3, for each ζ
    assert steps[2] < steps[4] and steps[3] < steps[5], steps


@serial_only
def test_a_killed_adaptive_sweep_resumes_to_the_same_table(tmp_path):
    import json

    spec = tmp_path / "adaptive.toml"
    spec.write_text('scene = "paper1"\n[set]\n"mesh.cells" = 60\n"time.end" = 30.0\n'
                    '"time.adaptive" = true\n[grid]\n"time.tolerance" = [1e-2, 1e-3, 1e-4]\n'
                    '"model.zeta" = {linspace = [0.2, 1.0, 4]}\n')
    whole, out = tmp_path / "whole", tmp_path / "out"
    subprocess.run(rodfem_command("sweep", spec, "--out", whole), env=ENV, check=True,
                   capture_output=True, timeout=600)
    process = subprocess.Popen(rodfem_command("sweep", spec, "--out", out), env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_records(out, 2, process)
    process.kill()
    process.communicate(timeout=120)
    done = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert 0 < json.loads((out / "summary.json").read_text())["ran_this_time"] < 12
    assert_same_table(load_sweep(out), load_sweep(whole))
