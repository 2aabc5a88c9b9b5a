"""Fits: parameters recovered from noisy synthetic data within their standard errors, the same
fit.json serially and under mpirun, a killed or interrupted fit resumed to the same fit.json
without running a point twice, the statistics against their formulas, and bad fit files and
data refused with one line."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
import types
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
from conftest import COMM, representative, serial_only
from rodfem.cli import main
from rodfem.output import journal
from rodfem.output.directories import state
from rodfem.studies.fit.data import OWN
from rodfem.studies.fit.optimiser import H, Problem, statistics
from rodfem.studies.sweep import parameters

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
       "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}
SET = {"mesh.cells": 16, "time.dt": 0.002, "time.end": 1.0, "solver.method": "direct"}
TRUTH = {"model.zeta": 0.25, "obstacle.epsilon": 0.012}
SIGMA, TIMES = 1e-4, 40
FIT = ('scene = "paper1"\ndata = "data.csv"\n[set]\n"mesh.cells" = 16\n"time.dt" = 0.002\n'
       '"time.end" = 1.0\n"solver.method" = "direct"\n[parameters]\n"model.zeta" = [0.1, 1.0]\n'
       '"obstacle.epsilon" = [1e-3, 1e-1]\n')


def synthetic() -> tuple[np.ndarray, np.ndarray]:
    """u(1, t) of the truth at 40 times, plus Gaussian noise of SIGMA (a fixed seed)."""
    history = rodfem.simulate("paper1", {**SET, **TRUTH}, comm=MPI.COMM_SELF).history
    t = np.linspace(1.0 / TIMES, 1.0, TIMES)
    u = np.interp(t, history["t"], history["u_1"])
    return t, u + np.random.default_rng(24).normal(0.0, SIGMA, TIMES)


def write_fit(directory: Path, fit: str = FIT, data: str | None = None) -> Path:
    """The fit file and its data.csv in ``directory`` (rank 0 writes; every rank waits). The
    data are made on every rank: the first run of a process starts PETSc, on every rank."""
    if data is None:
        t, u = synthetic()
        data = "t,u_1\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, u, strict=True))
    if COMM.rank == 0:
        directory.mkdir(parents=True, exist_ok=True)
        (directory / "data.csv").write_text(data)
        (directory / "fit.toml").write_text(fit)
    COMM.barrier()
    return directory / "fit.toml"


def rodfem_command(*args, ranks=1):
    command = [RODFEM, *map(str, args)]
    return ["mpirun", "-n", str(ranks), *command] if ranks > 1 else command


def test_known_parameters_are_recovered_within_their_standard_errors(shared_dir):
    """Synthetic data from known ζ and ε plus noise: each recovered within 3 standard errors
    and 1 %, the residual that of the noise, the fitted run's history the model fitted."""
    out = shared_dir / "out"
    result = rodfem.fit(write_fit(shared_dir / "in"), out)
    for key, truth in TRUTH.items():
        value, stderr = result.parameters[key]
        assert abs(value - truth) < 3 * stderr and abs(value - truth) < 0.01 * truth, key
    m, n = TIMES, len(TRUTH)
    assert 0.7 < result.residual_norm / (SIGMA * np.sqrt(m - n)) < 1.3  # χ of m - n: ±2.6 sd
    assert result.correlation.shape == (n, n)
    np.testing.assert_allclose(np.diag(result.correlation), 1.0, rtol=1e-12)
    assert result.status == "converged" and result.numbers["runs"] > 3
    fitted = result.fitted
    assert fitted.status == "complete" and fitted.path == out / "fitted"
    for key, value in result.values.items():
        assert fitted.scene[key] == value
    model = np.interp(result.t, fitted.history["t"], fitted.history["u_1"])
    np.testing.assert_allclose(result.model["u_1"], model, rtol=0, atol=1e-15)
    loaded = rodfem.load_fit(out)
    assert loaded.numbers == result.numbers and loaded.values == result.values
    assert (out / "fit.png").stat().st_size > 0
    assert "model.zeta" in repr(loaded) and "<table>" in loaded._repr_html_()
    # in memory, from the file's data, on one rank: the same fit (under mpirun every rank ran
    # the optimiser on the same numbers, and took the same steps)
    spec = tomllib.loads(FIT)
    alone = rodfem.fit({**spec, "data": str(shared_dir / "in" / "data.csv")}, comm=MPI.COMM_SELF)
    assert alone.numbers == result.numbers and alone.path is None
    np.testing.assert_array_equal(alone.fitted.history["u_1"], fitted.history["u_1"])


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    """A fit by the command, serially: its directory."""
    root = tmp_path_factory.mktemp("fit")
    fit = write_fit(root) if COMM.size == 1 else root / "fit.toml"
    if COMM.size == 1:
        done = subprocess.run(rodfem_command("fit", fit, "--out", root / "whole"), env=ENV,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert "model.zeta = " in done.stdout and "Traceback" not in done.stderr
    return fit, root / "whole"


@serial_only
def test_the_same_fit_json_under_mpirun(serial, tmp_path):
    fit, whole = serial
    done = subprocess.run(rodfem_command("fit", fit, "--out", tmp_path / "mpi", ranks=2),
                          env=ENV, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "mpi" / "fit.json").read_bytes() == (whole / "fit.json").read_bytes()


def wait_for_records(out: Path, count: int, process) -> None:
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None:
        if (out / journal.DIRECTORY).is_dir() and len(journal.read(out)) >= count:
            return
        time.sleep(0.02)
    raise AssertionError(f"the fit did not record {count} points in time")


def processes_of(out: Path) -> list[int]:
    """The processes whose command line names ``out`` (this test's own directory)."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            words = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if entry.name.isdigit() and str(out).encode() in words:
            found.append(int(entry.name))
    return found


@serial_only
@pytest.mark.parametrize("how, ranks", representative(
    [("SIGKILL", 1), ("SIGTERM", 1), ("SIGUSR1", 2), ("SIGKILL", 2)],
    [("SIGKILL", 1), ("SIGUSR1", 2)]))
def test_a_stopped_fit_resumes_to_the_same_fit_json(how, ranks, serial, tmp_path):
    fit, whole = serial
    out = tmp_path / "out"
    process = subprocess.Popen(rodfem_command("fit", fit, "--out", out, ranks=ranks), env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    wait_for_records(out, 4, process)
    if how == "SIGKILL":  # every process of it at once, mpirun's ranks too (a node lost)
        for pid in processes_of(out):
            os.kill(pid, signal.SIGKILL)
    else:  # the command, or mpirun, which forwards SIGUSR1 to the ranks
        process.send_signal(getattr(signal, how))
    _, err = process.communicate(timeout=120)
    deadline = time.monotonic() + 60  # every rank gone (mpirun's ranks after it), its lock too
    while state(out) == "running":
        assert time.monotonic() < deadline
        time.sleep(0.1)
    if how == "SIGKILL":
        assert process.returncode != 0
    else:
        assert "rodfem resume" in err and "Traceback" not in err, err
        if ranks == 1:
            assert process.returncode == 128 + getattr(signal, how), err
    before = len(journal.read(out))
    runs = json.loads((whole / "fit.json").read_text())["runs"]
    assert 4 <= before < runs and not (out / "fit.json").exists()
    done = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (out / "fit.json").read_bytes() == (whole / "fit.json").read_bytes()
    assert len(journal.read(out)) == runs  # no point run twice
    again = subprocess.run(rodfem_command("resume", out), env=ENV, capture_output=True,
                           text=True, timeout=600)
    assert again.returncode == 0 and "complete fit" in again.stdout


@serial_only
def test_resume_refuses_edited_data_with_one_line(serial, tmp_path, capsys):
    _, whole = serial
    copy = tmp_path / "copy"
    shutil.copytree(whole, copy)
    (copy / "data.csv").write_text((copy / "data.csv").read_text().replace("1", "2", 1))
    assert main(["resume", str(copy)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "data.csv is not the data this fit was run with" in err


@serial_only
def test_a_run_that_fails_stops_the_fit_with_exit_3_naming_its_point(tmp_path, capsys):
    """Picard's iteration cannot converge with so stiff an obstacle: the first run fails."""
    fit = FIT.replace('"direct"', '"picard"').replace("[1e-3, 1e-1]", "[1e-7, 1e-6]")
    out = tmp_path / "out"
    assert main(["fit", str(write_fit(tmp_path, fit, GOOD_DATA)), "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the run at model.zeta = " in err, err
    assert "did not converge" in err and json.loads((out / "rodfem.json").read_text())[
        "status"] == "failed"


@serial_only
def test_force_never_replaces_the_directory_that_holds_the_data(serial, tmp_path, capsys):
    _, whole = serial
    out = tmp_path / "out"
    shutil.copytree(whole, out)
    fit = write_fit(tmp_path / "in", FIT.replace('"data.csv"', f'"{out / "data.csv"}"'), "")
    before = sorted(p.name for p in out.iterdir())
    assert main(["fit", str(fit), "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is inside the output directory" in err, err
    assert sorted(p.name for p in out.iterdir()) == before


# --- statistics -------------------------------------------------------------------------------

def test_standard_errors_and_correlations_are_those_of_the_formula():
    """For residuals linear in u, r = A u - y: cov = s² (AᵀA)⁻¹ with s² = |r|²/(m - n),
    scaled by dv/du (the delta method)."""
    rng = np.random.default_rng(3)
    A, y = rng.normal(size=(30, 3)), rng.normal(size=30)
    u = np.linalg.lstsq(A, y, rcond=None)[0]
    r = A @ u - y
    d = np.array([2.0, 0.5, 3.0])
    stderr, correlation, why = statistics(types.SimpleNamespace(derivatives=lambda _: d), u, r, A)
    covariance = (r @ r) / 27 * np.linalg.inv(A.T @ A) * np.outer(d, d)
    expected = np.sqrt(np.diag(covariance))
    np.testing.assert_allclose(stderr, expected, rtol=1e-12)
    np.testing.assert_allclose(correlation, covariance / np.outer(expected, expected), rtol=1e-11)
    assert why is None


def test_no_standard_errors_where_the_data_cannot_give_them():
    flat = types.SimpleNamespace(derivatives=lambda _: np.ones(2))
    J = np.column_stack([np.arange(5.0), np.zeros(5)])  # the second parameter does nothing
    assert statistics(flat, np.zeros(2), np.ones(5), J)[:2] == (None, None)
    assert "rank" in statistics(flat, np.zeros(2), np.ones(5), J)[2]
    assert statistics(flat, np.zeros(2), np.ones(2), np.eye(2))[:2] == (None, None)


def test_the_delta_method_derivatives_are_those_of_the_values():
    study = parameters.parse({"scene": "paper1", "data": "d.csv", "set": SET, "parameters": {
        "model.zeta": [0.1, 1.0], "model.k": {"linear": [1.0, 5.0]}}}, "f", None, OWN)
    problem = Problem(study, None, {}, 1, 1e-8, ({}, ""))
    u = np.array([0.3, 0.6])
    for i in range(2):
        step = np.eye(2)[i] * H
        slope = (problem.values(u + step)[i] - problem.values(u - step)[i]) / (2 * H)
        assert problem.derivatives(u)[i] == pytest.approx(slope, rel=1e-8)
    assert problem.values(problem.scaled({"model.zeta": 0.25, "model.k": 2.0})) \
        == pytest.approx([0.25, 2.0], rel=1e-15)


# --- bad input --------------------------------------------------------------------------------

GOOD_DATA = "t,u_1\n0.1,0.03\n0.5,0.12\n0.9,0.1\n"
BAD = {
    "no data file": (FIT.replace("data.csv", "missing.csv"), GOOD_DATA, "no such file"),
    "no data key": (FIT.replace('data = "data.csv"\n', ""), GOOD_DATA, "data must name"),
    "empty data": (FIT, "", "empty"),
    "no t column": (FIT, "time,u_1\n0.1,0.03\n", "the header has no column t"),
    "not a number": (FIT, "t,u_1\n0.1,abc\n", "row 2, column u_1: 'abc' is not a number"),
    "not a finite number": (FIT, "t,u_1\n0.1,nan\n", "is not a finite number"),
    "times not increasing": (FIT, "t,u_1\n0.1,0.03\n0.1,0.04\n", "increase strictly"),
    "short row": (FIT, "t,u_1\n0.1\n", "row 2 has 1 cells"),
    "unknown column": (FIT, "t,u_2\n0.1,0.03\n", "column u_2 is not a history column the "
                       "scene records; those that can be fitted: u_1, u_half"),
    "column not in the data": (FIT.replace("[set]", 'columns = ["sigma_1"]\n[set]'), GOOD_DATA,
                               "sigma_1 is not a column of data.csv"),
    "after the end": (FIT, "t,u_1\n0.1,0.03\n3.2,0.1\n",
                      "data.csv: t = 3.2 lies after the scene's end time.end = 1"),
    "before the start": (FIT, "t,u_1\n-0.5,0.03\n", "lies before the scene's start"),
    "start outside": (FIT.replace("[set]", '[start]\n"model.zeta" = 2.0\n[set]'), GOOD_DATA,
                      "start model.zeta = 2.0 lies outside its range [0.1, 1]"),
    "low above high": (FIT.replace("[0.1, 1.0]", "[1.0, 0.1]"), GOOD_DATA,
                       "low 1 must be < high 0.1"),
    "bad weight": (FIT.replace("[set]", "[weights]\nu_1 = -1\n[set]"), GOOD_DATA,
                   "weights u_1: must be a number > 0"),
    "no evaluations": (FIT.replace("[set]", "max_evaluations = 0\n[set]"), GOOD_DATA,
                       "max_evaluations must be an integer from 1"),
    "unknown entry": (FIT.replace("[set]", "tolerence = 1e-6\n[set]"), GOOD_DATA,
                      "unknown entry 'tolerence'"),
    "end time fitted": (FIT.replace('"time.end" = 1.0\n', "") + '"time.end" = [1.0, 2.0]\n',
                        GOOD_DATA, "the end time cannot be fitted"),
}


@serial_only
@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_fits_are_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    fit, data, expected = BAD[case]
    out = tmp_path / "out"
    assert main(["fit", str(write_fit(tmp_path, fit, data)), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expected in err and "Traceback" not in err, err
    assert err.startswith("rodfem: error: ") and not out.exists()
