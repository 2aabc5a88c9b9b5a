"""``mpirun -n 2 rodfem run`` writes the serial history (to 1e-12; in fact bit for bit, since the
time loop does the same arithmetic on every rank whatever the partition)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import history_rows, representative, serial_only

RODFEM = Path(sys.executable).with_name("rodfem")
MPI_ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           # oversubscription, as Open MPI 4 (Debian 12) and 5 (Debian 13) spell it
           "OMPI_MCA_rmaps_base_oversubscribe": "1",
           "PRTE_MCA_rmaps_default_mapping_policy": ":oversubscribe"}


def rodfem_run(tmp_path, ranks, *args):
    out = tmp_path / f"n{ranks}"
    command = [str(RODFEM), "run", *args, "--out", str(out), "--quiet"]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    subprocess.run(command, check=True, env=MPI_ENV, capture_output=True, timeout=600)
    return history_rows(out)


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("mass, method, obstacle", representative([
    ("lumped", "picard", "elastic"), ("consistent", "picard", "elastic"),
    ("lumped", "direct", "elastic"), ("lumped", "direct", "rigid"), ("lumped", "newton", "rigid"),
], [("lumped", "picard", "elastic"), ("consistent", "picard", "elastic"),
    ("lumped", "direct", "elastic"), ("lumped", "direct", "rigid")]))
def test_two_ranks_write_the_serial_history(tmp_path, mass, method, obstacle):
    args = ["paper1", "--set", f"discretisation.mass={mass}", "--set", "output.every=1000",
            "--set", f"solver.method={method}", "--set", f"obstacle.kind={obstacle}"]
    serial = rodfem_run(tmp_path, 1, *args)
    parallel = rodfem_run(tmp_path, 2, *args)
    assert serial.shape == parallel.shape == (8001, 7)
    scale = np.abs(serial).max(axis=0)
    assert (np.abs(parallel - serial) <= 1e-12 * scale).all()
    np.testing.assert_array_equal(parallel[:, 6], serial[:, 6])  # iterations


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("scene, method", [("paper1", "direct"), ("paper5", "newton"),
                                           ("manufactured", "picard")])
def test_two_ranks_write_the_serial_crank_nicolson_history(tmp_path, scene, method):
    """Crank–Nicolson, and the manufactured scene's sources, under mpirun -n 2: the same bits."""
    args = [scene, "--set", "time.scheme=crank-nicolson", "--set", f"solver.method={method}",
            "--set", "time.end=2"]
    serial = rodfem_run(tmp_path, 1, *args)
    parallel = rodfem_run(tmp_path, 2, *args)
    assert serial.shape == parallel.shape and serial.shape[0] > 100
    np.testing.assert_array_equal(parallel, serial)


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_demo_runs_under_mpirun():
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_paper1.py"
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)],
                          env={**MPI_ENV, "CI": "1"}, capture_output=True, text=True, timeout=600,
                          check=True)
    assert "intervals of contact; first at t = 0.186" in done.stdout
    assert done.stdout.count("energy") == 1  # rank 0 reports, once


@pytest.mark.slow  # demo_paper1's, the API's and the redistributed demos' run by default
@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_contact_methods_demo_runs_under_mpirun():
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_contact_methods.py"
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)],
                          env={**MPI_ENV, "CI": "1"}, capture_output=True, text=True, timeout=600,
                          check=True)
    out = done.stdout
    assert out.count("picard  failed: Picard iteration did not converge at step 19") == 1
    assert out.count("energy non-increasing: True") == 2  # direct and newton, rank 0 only
    rate = float(out.split("rate for ε <= 1e-5: ")[1].split()[0])
    assert abs(rate - 1.0) < 0.05, out  # ε/(ε + w) → the rate tends to 1 as ε/w → 0


@pytest.mark.slow  # demo_paper1's, the API's and the redistributed demos' run by default
@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_time_schemes_demo_runs_under_mpirun():
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_time_schemes.py"
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)],
                          env={**MPI_ENV, "CI": "1"}, capture_output=True, text=True, timeout=600,
                          check=True)
    out = done.stdout
    orders = [float(line.split("order ")[1]) for line in out.splitlines() if "; order " in line]
    assert len(orders) == 2 and orders[1] > orders[0] + 0.8, out  # rank 0 only: paper, then CN
    assert out.count("energy non-increasing: True") == 2, out


ADAPTIVE = {
    "paper1": ["paper1", "--set", "time.end=20", "--set", "mesh.cells=100"],
    "paper1-cn": ["paper1", "--set", "time.scheme=crank-nicolson", "--set", "solver.method=direct",
                  "--set", "time.end=2"],
    "paper5-newton": ["paper5", "--set", "solver.method=newton", "--set", "time.end=2"],
    "impact": ["impact", "--set", "mesh.cells=100", "--set", "time.dt=1e-2", "--set",
               "time.end=6"],
}


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("scene, ranks", representative(
    [("paper1", 2), ("paper1-cn", 2), ("paper5-newton", 2), ("impact", 2), ("impact", 3)],
    [("paper1", 2), ("impact", 3)]))
def test_ranks_take_the_serial_adaptive_steps(tmp_path, scene, ranks):
    """Adaptive steps: every rank takes the same decisions (accepted, rejected, located events)
    as the serial run, so the history (its times and steps included) is the same, bit for bit."""
    args = [*ADAPTIVE[scene], "--set", "time.adaptive=true"]
    serial = rodfem_run(tmp_path, 1, *args)
    parallel = rodfem_run(tmp_path, ranks, *args)
    assert serial.shape[1] == 9 and serial.shape[0] > 100
    assert serial[:, 8].sum() >= 2  # contact events located
    assert np.unique(np.diff(serial[:, 0])).size > 10  # the steps did adapt
    np.testing.assert_array_equal(parallel, serial)


@pytest.mark.slow  # demo_paper1's, the API's and the redistributed demos' run by default
@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_calibration_demo_runs_under_mpirun(tmp_path):
    """The calibration demo on two ranks: the fit recovers the values the measurement was made
    with, within three of its standard errors and 1 %; its residual is the noise's; the Sobol
    indices are shares of a variance, within their intervals."""
    demo = Path(__file__).resolve().parents[1] / "demos" / "demo_calibration.py"
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(demo)], cwd=tmp_path,
                          env={**MPI_ENV, "CI": "1"}, capture_output=True, text=True,
                          timeout=600, check=True)
    out = done.stdout
    for key, true in (("model.zeta", 0.4), ("obstacle.epsilon", 0.004)):
        lines = [line for line in out.splitlines() if line.startswith(f"{key} = ")]
        assert len(lines) == 1, out  # rank 0 reports, once
        value, stderr = (float(word) for word in lines[0].split()[2:5:2])
        assert abs(value - true) <= 3 * stderr and abs(value / true - 1) < 0.01, lines[0]
    # |r|² / (m - n) is χ² over m - n = 298 degrees of freedom divided by them: its root is 1
    # within 1/sqrt(2·298) = 0.04 (one standard deviation); 0.2 is five of them
    ratio = float(out.split("|r| / sqrt(m - n) = ")[1].split()[0])
    assert abs(ratio - 1) < 0.2, out
    results = tmp_path / "results" / "demo_calibration"
    assert (results / "fit" / "fit.png").is_file()
    assert (results / "sensitivity" / "sensitivity.png").is_file()
    import pandas as pd

    table = pd.read_csv(results / "sensitivity" / "sensitivity.csv")
    assert sorted(zip(table["measure"], table["parameter"], strict=True)) == [
        (m, p) for m in ("contact_time", "peak_stress")
        for p in ("model.zeta", "obstacle.epsilon")]
    assert (table["ST"] + table["ST_conf"] >= table["S1"] - table["S1_conf"]).all()
    for column in ("S1", "ST"):
        assert (table[column] + table[f"{column}_conf"] >= 0).all()
        assert (table[column] - table[f"{column}_conf"] <= 1).all()
