"""The stability map (``rodfem stability``) and the edge of Picard's convergence it predicts.

While the contact is active, Picard's iteration (3.3)–(3.4) maps the contact force through the
compliance w of the step (the response of Uⁿ(1) to a unit force): p ← (1/ε)[s − w p − g]_+, a
contraction by w/ε (exactly for a = 0; the coupling adds O(a²)). So ε = 1.25 w converges and
ε = 0.8 w cannot, although both are far outside the paper's sufficient condition Δt < εζ
(Δt/(εζ) = 18 and 29).
"""

import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem.scene
from conftest import COMM, assert_refused, history_rows, serial_only
from rodfem.cli import main
from rodfem.output.directories import finish
from rodfem.studies.verification import stability as st

# Far from every boundary: w/ε is 0.011-0.25 or 1.96-50 at these points (w = 2.2e-3, 9.8e-3,
# 2.2e-2, 5.0e-2 for (ζ, Δt) = (0.2, 0.01), (0, 0.01), (0.2, 0.05), (0, 0.05)).
TINY = st.Grid(dt=(0.01, 0.05), epsilon=(1e-3, 5e-3, 0.2), zeta=(0.0, 0.2), a=(0.017,), end=0.4)
# The edge scene: the rod reaches the obstacle at t ≈ 0.18 and stays in contact to the end.
EDGE = ["time.dt=0.01", "time.end=0.3", "model.zeta=0.2"]
MPI_ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1",
           "PRTE_MCA_rmaps_default_mapping_policy": ":oversubscribe"}


@pytest.fixture(scope="module")
def tiny():
    """The tiny grid's records, shared by COMM_WORLD's ranks, and again on this rank alone."""
    base = st.check("paper1", [], TINY)
    shared = st.sweep(base, TINY, COMM)
    return shared, st.sweep(base, TINY, MPI.COMM_SELF) if COMM.size > 1 else shared


def test_sweep_records(tiny):
    records, _ = tiny
    assert len(records) == 2 * 3 * 2 * 3
    assert [{k: r[k] for k in ("method", "a", "zeta", "dt", "epsilon")} for r in records] \
        == TINY.points()
    for r in records:
        assert set(r) == set(st.COLUMNS)
        assert r["w_ratio"] == pytest.approx(r["w"] / r["epsilon"], rel=1e-15)
        if r["zeta"] == 0:
            assert r["paper_ratio"] == math.inf and not r["paper_predicts"]
        if r["method"] != "picard":  # the exact methods solve every step
            assert r["converged"] and r["steps"] == r["steps_planned"] and r["error"] == ""
        if r["converged"]:
            assert r["contact_steps"] > 0 and r["min_sigma_1"] < 0  # the contact was active
            assert r["energy_non_increasing"]
        else:
            assert r["fail_step"] == r["steps"] + 1 and "Picard iteration" in r["error"]
    picard = [r for r in records if r["method"] == "picard"]
    # Far from w = ε, w/ε < 1 tells exactly where Picard converges; the paper's condition is
    # sufficient (never violated) but misses most of the points where it converges.
    assert [r["converged"] for r in picard] == [r["w_predicts"] for r in picard]
    assert all(r["converged"] for r in picard if r["paper_predicts"])
    summary = st.summarise(records, TINY)
    assert summary["picard"]["compliance"]["agree"] == 1.0
    assert summary["picard"]["paper"]["predicted_but_failed"] == 0
    assert summary["picard"]["paper"]["converged_unpredicted"] > 0


def test_records_do_not_depend_on_the_ranks(tiny):
    """Under mpirun the points are shared among the ranks; the records are the serial ones, bit
    for bit, except the timings."""
    shared, alone = tiny
    for r, s in zip(shared, alone, strict=True):
        assert {k: v for k, v in r.items() if k not in st.TIMING} \
            == {k: v for k, v in s.items() if k not in st.TIMING}


def test_csv_and_json(tiny, shared_dir):

    records, _ = tiny
    base = st.check("paper1", [], TINY)
    out = shared_dir / "map"
    st.prepare(out, False, COMM, st.FILES, "stability")
    st.write(out, records, TINY, base, [], 1.0, COMM)
    finish(out, "complete", COMM)  # as the command does: the directory is not left held
    COMM.barrier()
    with open(out / "stability.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == st.COLUMNS and len(rows) == len(records) + 1
    first = dict(zip(st.COLUMNS, rows[1], strict=True))
    assert first["method"] == "direct" and float(first["dt"]) == 0.01
    assert first["converged"] == "true" and first["paper_ratio"] == "inf"
    assert float(first["w"]) == records[0]["w"]  # repr: every digit kept
    data = json.loads((out / "stability.json").read_text())  # strict JSON (no Infinity)
    assert data["grid"]["dt"] == [0.01, 0.05] and data["machine"]["mpi_ranks"] == COMM.size
    by = {(b["zeta"], b["a"]): b for b in data["summary"]["picard_by_zeta_a"]}
    assert by[(0.0, 0.017)]["paper"]["predicted_converge"] == 0  # ζ = 0: Δt < εζ never holds
    # Picard converges above the measured boundary, which lies between failing and converging ε
    for row in by[(0.2, 0.017)]["per_dt"]:
        assert row["monotone"]
        assert row["largest_failed_epsilon"] < row["w"] < row["smallest_converged_epsilon"]


def _edge_scene(a: float, factor: float, method: str, max_iterations: int) -> list[str]:
    w = st.Compliance(rodfem.scene.load("paper1", EDGE), 0.3)(0.01, 0.2, a)
    return [*EDGE, f"model.a={a!r}", f"obstacle.epsilon={factor * w!r}",
            f"solver.method={method}", f"solver.max_iterations={max_iterations}"]


def _run(shared_dir, name, overrides, capsys):
    out = shared_dir / name
    argv = ["run", "paper1", "--out", str(out), "--quiet"]
    for item in overrides:
        argv += ["--set", item]
    code = main(argv)
    err = capsys.readouterr().err
    history = history_rows(out)

    return code, err, history, json.loads((out / "summary.json").read_text())


# A contraction by 0.8 from an increment of about 1e-2 reaches tol = 1e-10 in about 85 iterations.
@pytest.mark.parametrize("a", [0.0, 0.017])
def test_picard_converges_just_inside_and_fails_just_outside(a, shared_dir, capsys):
    code, _, history, summary = _run(shared_dir, "inside", _edge_scene(a, 1.25, "picard", 400),
                                     capsys)
    assert code == 0 and summary["status"] == "complete"
    assert (history[:, 4] < 0).sum() >= 10  # σ(1) < 0: the contact is active
    assert 50 <= summary["iterations_max"] < 400  # slow, as a contraction by 0.8 is
    assert summary["energy_non_increasing"]

    code, err, _, summary = _run(shared_dir, "outside", _edge_scene(a, 0.8, "picard", 400),
                                 capsys)
    assert code == 3 and summary["status"] == "failed"
    assert 0.17 <= summary["steps"] * 0.01 <= 0.19  # at the first step in contact
    if COMM.rank == 0:
        assert err.startswith("rodfem: Picard iteration did not converge at step")
        assert "after 400 iterations" in err and err.count("\n") == 1
    for method in ("newton", "direct"):  # the exact methods do not care
        code, _, history, summary = _run(shared_dir, method, _edge_scene(a, 0.8, method, 400),
                                         capsys)
        assert code == 0 and summary["status"] == "complete"
        assert (history[:, 4] < 0).any() and summary["energy_non_increasing"]


@pytest.mark.parametrize("a", [0.0, 0.017])
def test_picard_step_agrees_with_the_exact_step(a):
    """From the same state, a Picard step and the exact (direct) step differ by at most the
    a-posteriori bound of a contraction by ρ = w/ε stopped at an increment below tol:
    |x_l − x*| ≤ ρ/(1 − ρ) tol (here ρ = 0.8: 4 tol)."""
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.solver.methods.direct import DirectMethod
    from rodfem.solver.methods.picard import PicardMethod

    scene = rodfem.scene.load("paper1", _edge_scene(a, 1.25, "picard", 400))
    exact = DirectMethod(Discretisation(scene, MPI.COMM_SELF))
    picard = PicardMethod(Discretisation(scene, MPI.COMM_SELF))
    rho = exact.compliance / scene["obstacle.epsilon"]
    assert rho == pytest.approx(0.8, rel=1e-12)
    bound = rho / (1 - rho) * scene["solver.tol"]
    errors, pressures = [], []
    for _ in range(scene.steps):
        for name in ("theta", "u", "u_prev", "du"):
            getattr(exact, name).copy(getattr(picard, name))
        picard.n = exact.n
        exact.advance()
        picard.advance()
        errors.append(max(np.abs(picard.u.array - exact.u.array).max(),
                          np.abs(picard.theta.array - exact.theta.array).max()))
        pressures.append(exact.pressure)
    errors = np.array(errors)
    assert np.count_nonzero(pressures) >= 10  # steps in contact, where Picard iterates on p
    assert errors.max() <= bound
    assert errors[np.array(pressures) > 0].max() > 0.1 * scene["solver.tol"]  # not trivially


BAD = [
    (["--dt", "1e-3,abc"], "--dt: 'abc' is not a number"),
    (["--epsilon", ""], "--epsilon: '' is not a number"),
    (["--zeta", "0.2,nan"], "--zeta: 'nan' is not a finite number"),
    (["--methods", "direct,gauss"], "--methods: unknown method 'gauss'; allowed: direct, newton"),
    (["--epsilon", "-1"], "--epsilon -1: obstacle.epsilon: must be >= 1e-12"),
    (["--a", "0.017,-2"], "--a -2: model.a: must be >= 0"),
    (["--dt", "0.3"], "--dt 0.3: time.end: must be a whole number of steps"),
    (["--end", "1,2"], "--end: expected one number"),
    (["--end", "0.001", "--dt", "0.01"], "--dt 0.01: time.dt: must be <= time.end"),
    (["--end", "-1"], "--end -1: time.end: must be >= 1e-12"),
    (["--scene", "nope"], "scene 'nope': not a built-in scene"),
    (["--set", "model.zetta=1"], "unknown key 'model.zetta'"),
    (["--set", "obstacle.kind=rigid"], 'solver.method: "picard" cannot solve obstacle.kind'),
    (["--set", "obstacle.kind=rigid", "--set", "solver.method=direct", "--methods", "direct"],
     'needs obstacle.kind = "elastic"'),
    (["--end", "1e13"], "--end 1e+13: time.end: must be <= 1e+12"),
    (["--end", "0.0015"], "--dt 0.0002: time.end: must be a whole number of steps"),
]


@pytest.mark.parametrize("args, message", BAD)
def test_bad_input(args, message, shared_dir, capsys):
    out = shared_dir / "map"
    assert_refused(["stability", "--out", str(out), *args], out, message, capsys)


def test_existing_directory(shared_dir, capsys):
    """Never overwritten without --force; with it, only an earlier map is replaced."""
    out = shared_dir / "map"
    st.prepare(out, False, COMM, st.FILES, "stability")  # an earlier map's directory
    finish(out, "complete", COMM)
    if COMM.rank == 0:
        (out / "figures").mkdir(parents=True)
        (out / "stability.csv").write_text("old")
        (out / "figures" / "stability_picard.png").write_bytes(b"old")
    COMM.barrier()
    grid = ["--dt", "0.1", "--epsilon", "1", "--zeta", "0.2", "--a", "0.017", "--end", "0.2",
            "--methods", "direct"]
    assert main(["stability", "--out", str(out), *grid]) == 2
    assert "exists; use --force" in capsys.readouterr().err or COMM.rank > 0
    assert (out / "stability.csv").read_text() == "old"
    if COMM.rank == 0:
        (out / "notes.txt").write_text("mine")
    COMM.barrier()
    assert main(["stability", "--out", str(out), "--force", *grid]) == 2
    assert "holds notes.txt" in capsys.readouterr().err or COMM.rank > 0
    assert (out / "stability.csv").read_text() == "old" and (out / "notes.txt").exists()
    COMM.barrier()
    if COMM.rank == 0:
        (out / "notes.txt").unlink()
    COMM.barrier()
    assert main(["stability", "--out", str(out), "--force", *grid]) == 0
    capsys.readouterr()
    assert (out / "stability.csv").read_text().startswith("method,")
    assert (out / "figures" / "stability_direct.png").stat().st_size > 10_000
    assert not (out / "figures" / "stability_picard.png").exists()


def _cli_csv(out: Path, ranks: int) -> list[dict]:
    rodfem_cmd = str(Path(sys.executable).with_name("rodfem"))
    command = [rodfem_cmd, "stability", "--out", str(out), "--dt", "0.05,0.1",
               "--epsilon", "1e-3,0.2", "--zeta", "0.2", "--a", "0.017", "--end", "0.5"]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    done = subprocess.run(command, env=MPI_ENV, capture_output=True, text=True, timeout=300,
                          check=True)
    assert done.stdout.count("stability: 4 points x 3 methods") == 1
    assert all((out / "figures" / f"stability_{m}.png").is_file()
               for m in ("picard", "newton", "direct"))
    with open(out / "stability.csv", newline="", encoding="utf-8") as f:
        return [{k: v for k, v in row.items() if k not in st.TIMING} for row in csv.DictReader(f)]


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_command_under_mpirun_writes_the_serial_map(tmp_path):
    assert _cli_csv(tmp_path / "n2", 2) == _cli_csv(tmp_path / "n1", 1)
