"""Sensitivity studies: the indices of functions whose indices are known (through the analysis
a study uses), a measure that cannot depend on a parameter given a total index of 0, the same
indices under mpirun and after a stop and resume, and bad sensitivity files refused with one
line."""

import math
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
from conftest import COMM, assert_refused, serial_only
from rodfem.cli import main
from rodfem.output import journal
from rodfem.studies.sensitivity import indices
from rodfem.studies.sweep.parameters import Parameter

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
       "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}


# --- the analysis, of functions with known indices ---------------------------------------------

def ishigami(x: np.ndarray, a: float = 7.0, b: float = 0.1) -> np.ndarray:
    return np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_indices(a: float = 7.0, b: float = 0.1) -> tuple[list, list]:
    """Ishigami's S1 and ST over [-π, π]³ (Sobol' and Levitan 1999)."""
    v1 = 0.5 * (1 + b * math.pi ** 4 / 5) ** 2
    v2 = a ** 2 / 8
    v13 = b ** 2 * math.pi ** 8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return [v1 / v, v2 / v, 0.0], [(v1 + v13) / v, v2 / v, v13 / v]


def test_ishigami_indices_lie_within_their_confidence_intervals():
    parameters = tuple(Parameter(f"x{i}", -math.pi, math.pi, False) for i in (1, 2, 3))
    plan = indices.plan(parameters, "sobol", 1024, seed=0)
    assert plan.scaled.shape == (1024 * 5, 3)
    output = ishigami(plan.values)
    rows, warnings = indices.analyse(plan, {"y": output})
    assert not warnings and [r["parameter"] for r in rows] == ["x1", "x2", "x3"]
    first, total = ishigami_indices()
    for row, s1, st in zip(rows, first, total, strict=True):
        assert abs(row["S1"] - s1) <= row["S1_conf"], row
        assert abs(row["ST"] - st) <= row["ST_conf"], row
        assert row["S1_conf"] < 0.1 and row["ST_conf"] < 0.1  # informative intervals
    # The bootstrap is seeded, and the analysis of the same values is the same to the bit
    # wherever they lie in memory (NumPy's vector loops may round differently with the
    # alignment of an array: np.sin does, so the function's values are computed once).
    for offset in (0, 1, 3):
        memory = np.empty(len(output) + 4)
        shifted = memory[offset:offset + len(output)]
        shifted[:] = output
        again, _ = indices.analyse(plan, {"y": shifted})
        assert again == rows, offset


def test_morris_of_a_linear_function_is_its_coefficients_times_the_ranges():
    parameters = (Parameter("x", 0.0, 2.0, False), Parameter("y", 1.0, 1000.0, True))
    plan = indices.plan(parameters, "morris", 20, seed=3, levels=4)
    assert plan.scaled.shape == (20 * 3, 2)
    # linear in x and in log10(y): the elementary effects are the coefficients times the ranges
    output = 3.0 * plan.values[:, 0] - 0.5 * np.log10(plan.values[:, 1])
    rows, _ = indices.analyse(plan, {"f": output})
    for row, expected in zip(rows, (3.0 * 2.0, 0.5 * 3.0), strict=True):
        assert row["mu_star"] == pytest.approx(expected, rel=1e-12)
        assert abs(row["sigma"]) <= 1e-12 * expected


def test_plans_are_seeded_and_work_on_the_log_scale():
    parameters = (Parameter("a", 0.5, 1.0, False), Parameter("b", 1e-3, 1e-1, True))
    plan = indices.plan(parameters, "sobol", 64, seed=5)
    assert np.array_equal(plan.values, indices.plan(parameters, "sobol", 64, seed=5).values)
    assert not np.array_equal(plan.values, indices.plan(parameters, "sobol", 64, seed=6).values)
    assert plan.scaled[:, 1].min() >= -3 and plan.scaled[:, 1].max() <= -1
    np.testing.assert_allclose(plan.values[:, 1], 10.0 ** plan.scaled[:, 1], rtol=1e-15)
    assert (plan.values[:, 0] >= 0.5).all() and (plan.values[:, 0] <= 1.0).all()


def test_a_constant_or_a_missing_measure_has_no_indices_and_a_warning():
    plan = indices.plan((Parameter("a", 0.0, 1.0, False),), "sobol", 8)
    values = plan.values[:, 0]
    broken = values.copy()
    broken[3] = np.nan
    rows, warnings = indices.analyse(plan, {"c": np.ones(len(values)), "n": broken,
                                            "v": values})
    assert [r["measure"] for r in rows] == ["v"]
    assert "c has no indices: it is constant" in warnings[0]
    assert "n has no indices: not a number in 1 of its 24 runs" in warnings[1]


# --- campaigns ----------------------------------------------------------------------------------

# The rod settles to its stationary state by t = 20, which ζ (a viscosity) does not change.
SETTLED = {"scene": "paper1", "samples": 16, "outputs": ["u_1_final", "t_final", "peak_stress"],
           "set": {"mesh.cells": 8, "time.end": 20.0, "time.dt": 0.02,
                   "solver.method": "direct"},
           "parameters": {"model.zeta": [0.5, 1.0], "model.theta_A": [5.0, 15.0]},
           "measures": {"peak_stress": {"column": "sigma_1", "reduce": "min"}}}


def test_a_settled_state_has_no_sensitivity_to_the_viscosity(shared_dir):
    result = rodfem.sensitivity(SETTLED, shared_dir / "settled")
    assert result.status == "complete" and result.failed == 0
    st = result.indices("u_1_final")["model.zeta"]["ST"]
    assert abs(st) < 1e-6, st  # the stationary state is ζ's to round-off only
    assert result.indices("peak_stress")["model.zeta"]["ST"] > 0.1  # the transient is not
    assert any("t_final has no indices: it is constant" in w for w in result.warnings)
    with pytest.raises(KeyError, match="t_final"):
        result.indices("t_final")
    # samples.csv holds the points the runs ran, in their order
    samples = np.loadtxt(shared_dir / "settled" / "samples.csv", delimiter=",", skiprows=1)
    runs = rodfem.load_sweep(shared_dir / "settled" / "runs")
    np.testing.assert_array_equal(samples[:, 1], runs["model.zeta"])
    np.testing.assert_array_equal(samples[:, 2], runs["model.theta_A"])
    loaded = rodfem.load_sensitivity(shared_dir / "settled")
    assert loaded.table == result.table and loaded.status == "complete"
    assert loaded.warnings == result.warnings  # a measure left out says why when loaded too
    frame = loaded.to_pandas()
    assert frame.loc[("u_1_final", "model.zeta"), "ST"] == st
    assert "Sobol" in repr(loaded) and "<table>" in loaded._repr_html_()
    if COMM.size > 1:  # the same indices as one rank alone
        alone = rodfem.sensitivity(SETTLED, comm=MPI.COMM_SELF)
        assert alone.table == result.table


def test_morris_screening_of_a_campaign_in_memory():
    study = {**SETTLED, "method": "morris", "samples": 4, "outputs": ["u_1_final"]}
    result = rodfem.sensitivity(study)
    assert result.path is None and result.columns == ("mu_star", "mu_star_conf", "sigma")
    screened = result.indices("u_1_final")
    assert len(result.table) == 2 and result.numbers["runs"] == 12
    # θ_A moves the settled state (thermal expansion); ζ only what is left of the transient
    # at t = 20 (measured: 3e-7 of θ_A's effect)
    assert screened["model.zeta"]["mu_star"] < 1e-5 * screened["model.theta_A"]["mu_star"]
    with pytest.raises(rodfem.SceneError, match="must be a sensitivity file's path"):
        rodfem.sensitivity(5)


FAILING = """scene = "paper1"
samples = 2
outputs = ["u_1_final"]
[set]
"mesh.cells" = 8
"time.end" = 0.5
"solver.method" = "picard"
[parameters]
"obstacle.epsilon" = [1e-7, 1e-6]
"""


@serial_only
def test_failed_runs_leave_no_indices_and_exit_3(tmp_path, capsys):
    study = tmp_path / "failing.toml"
    study.write_text(FAILING)
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "out")]) == 3
    err = capsys.readouterr().err
    assert err == (f"rodfem: error: 6 of the 6 runs failed (their rows in "
                   f"{tmp_path / 'out' / 'runs' / 'results.csv'} say why); no indices in "
                   f"{tmp_path / 'out' / 'sensitivity.csv'}\n"), err  # once, not as a warning too
    assert (tmp_path / "out" / "sensitivity.csv").read_text() == \
        "measure,parameter,S1,S1_conf,ST,ST_conf\n"
    loaded = rodfem.load_sensitivity(tmp_path / "out")
    assert loaded.failed == 6 and loaded.warnings == ("no indices: 6 of the 6 runs failed "
                                                      "(their rows in runs/results.csv say why)",)


# --- the command line: bad files, MPI, stopped and resumed -------------------------------------

GOOD = """scene = "paper1"
samples = 4
outputs = ["u_1_final"]
[set]
"mesh.cells" = 8
"time.end" = 0.2
"solver.method" = "direct"
[parameters]
"model.zeta" = [0.5, 1.0]
"""

BAD = {
    "unknown method": ('method = "fast"\n', "method must be one of sobol, morris"),
    "not a power of 2": ("samples = 6\n", "samples must be a power of 2"),
    "too few samples": ("samples = 1\n", "samples must be an integer from 2"),
    "too many runs": ("samples = 524288\n", "makes 1572864 runs"),
    "negative seed": ("seed = -1\n", "seed must be an integer from 0"),
    "odd levels": ('method = "morris"\nlevels = 3\n', "levels must be even"),
    "confidence": ("confidence = 1.5\n", "confidence must be a number between 0 and 1"),
    "unknown output": ('outputs = ["u_2_final"]\n', "unknown measure 'u_2_final'; allowed: "),
    "no outputs": ("outputs = []\n", "outputs must be a list of measures' names"),
    "timing output": ('outputs = ["loop_seconds"]\n', "unknown measure 'loop_seconds'"),
    "unknown entry": ("sample = 4\n", "unknown entry 'sample'"),
    "bad range": ('[parameters]\n"model.k" = [2, 1]\n', "low 2 must be < high 1"),
}


@serial_only
@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_sensitivity_files_are_one_line_exit_2_nothing_written(case, tmp_path, capsys):
    body, expected = BAD[case]
    lines = [line for line in GOOD.splitlines()
             if not line.startswith(body.split(" ")[0].split("\n")[0] + " ")]
    if body.startswith("[parameters]"):
        text = GOOD.replace('"model.zeta" = [0.5, 1.0]', body.split("\n")[1])
    else:
        text = body + "\n".join(lines) + "\n"
    study = tmp_path / "bad.toml"
    study.write_text(text)
    assert_refused(["sensitivity", str(study), "--out", str(tmp_path / "out")],
                   tmp_path / "out", expected, capsys)


@serial_only
def test_outputs_default_to_the_declared_measures_else_refused(tmp_path, capsys):
    study = tmp_path / "none.toml"
    study.write_text(GOOD.replace('outputs = ["u_1_final"]\n', ""))
    assert_refused(["sensitivity", str(study), "--out", str(tmp_path / "out")],
                   tmp_path / "out", "declare some in [measures]; allowed: t_final", capsys)
    study.write_text(GOOD.replace('outputs = ["u_1_final"]\n', "")
                     + '[measures]\nlow = { column = "u_1", reduce = "min" }\n')
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert rodfem.load_sensitivity(tmp_path / "out").outputs == ("low",)


SLOW = """scene = "paper1"
samples = 16
seed = 2
outputs = ["u_1_final", "lowest"]
[set]
"mesh.cells" = 24
"time.end" = 4
"time.dt" = 0.004
"solver.method" = "direct"
[parameters]
"model.zeta" = [0.2, 1.0]
"obstacle.epsilon" = [1e-3, 1e-1]
[measures]
lowest = { column = "sigma_1", reduce = "min" }
"""


def command(*args, ranks=1):
    line = [RODFEM, *map(str, args)]
    return ["mpirun", "-n", str(ranks), *line] if ranks > 1 else line


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    root = tmp_path_factory.mktemp("sensitivity")
    study = root / "slow.toml"
    study.write_text(SLOW)
    if COMM.size == 1:
        done = subprocess.run(command("sensitivity", study, "--out", root / "whole"), env=ENV,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        assert "64 runs in" in done.stdout and "Sobol indices of 2 of 2 measures" in done.stdout
    return study, root / "whole"


@serial_only
def test_the_indices_under_mpirun_are_the_serial_ones(uninterrupted, tmp_path):
    study, whole = uninterrupted
    done = subprocess.run(command("sensitivity", study, "--out", tmp_path / "two", ranks=2),
                          env=ENV, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    for name in ("sensitivity.csv", "samples.csv"):
        assert (tmp_path / "two" / name).read_bytes() == (whole / name).read_bytes(), name
    assert (tmp_path / "two" / "sensitivity.png").is_file()


def wait_for_records(out: Path, count: int, process) -> None:
    deadline = time.time() + 120
    while time.time() < deadline and process.poll() is None:
        if (out / "runs").is_dir() and len(journal.read(out / "runs")) >= count:
            return
        time.sleep(0.02)
    raise AssertionError(f"the campaign did not record {count} runs in time")


@serial_only
@pytest.mark.parametrize("how, ranks", [("SIGKILL", 2), ("SIGTERM", 1)])
def test_a_stopped_campaign_resumes_to_the_same_indices(how, ranks, uninterrupted, tmp_path):
    """Stopped serially, resumed on ``ranks`` ranks (a sweep resumes on any number)."""
    study, whole = uninterrupted
    out = tmp_path / "out"
    process = subprocess.Popen(command("sensitivity", study, "--out", out), env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_records(out, 5, process)
    process.send_signal(getattr(signal, how))
    _, err = process.communicate(timeout=120)
    if how == "SIGTERM":
        assert process.returncode == 143, err
        assert "rodfem resume" in err and "Traceback" not in err, err
    else:
        assert process.returncode == -signal.SIGKILL
    assert not (out / "sensitivity.csv").exists()
    done = subprocess.run(command("resume", out, ranks=ranks), env=ENV, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (out / "sensitivity.csv").read_bytes() == (whole / "sensitivity.csv").read_bytes()
    again = subprocess.run(command("resume", out), env=ENV, capture_output=True, text=True,
                           timeout=600)
    assert again.returncode == 0 and "complete sensitivity study" in again.stdout


@serial_only
def test_resume_refuses_the_runs_of_another_study(uninterrupted, tmp_path, capsys):
    import shutil

    study, whole = uninterrupted
    other = tmp_path / "other.toml"
    other.write_text(SLOW.replace("seed = 2", "seed = 3").replace("samples = 16", "samples = 2"))
    assert main(["sensitivity", str(other), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    mixed = tmp_path / "mixed"
    shutil.copytree(whole, mixed)
    shutil.rmtree(mixed / "runs")
    shutil.copytree(tmp_path / "o" / "runs", mixed / "runs")
    marker = (mixed / "rodfem.json").read_text().replace('"complete"', '"interrupted"')
    (mixed / "rodfem.json").write_text(marker)
    capsys.readouterr()
    assert main(["resume", str(mixed)]) == 2
    err = capsys.readouterr().err
    assert "holds the runs of another study" in err and err.count("\n") == 1, err
