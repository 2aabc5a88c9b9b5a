"""``rodfem steady``: its tables, its figure, its refusals and its directory."""

import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import rodfem.scene
from conftest import COMM, assert_refused, serial_only
from rodfem.cli import main
from rodfem.model import steady
from rodfem.output.directories import finish
from rodfem.studies.steady import states as st

MPI_ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}


def read(path: Path) -> tuple[list[str], list[dict]]:
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def test_states_table(shared_dir, capsys):
    out = shared_dir / "states"
    assert main(["steady", "barber", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    columns, rows = read(out / "steady.csv")
    assert columns[:6] == ["u_1", "sigma_1", "theta_1", "contact", "stable", "growth_rate"]
    states = steady.of_scene(rodfem.scene.load("barber", [])).states()
    assert [float(r["u_1"]) for r in rows] == [s.u_1 for s in states]  # in increasing u(1)
    assert [float(r["sigma_1"]) for r in rows] == [s.sigma_1 for s in states]
    assert [r["contact"] for r in rows] == ["false", "true", "true"]
    assert [r["stable"] for r in rows] == ["true", "false", "true"]
    assert all((float(r["growth_rate"]) < 0) == (r["stable"] == "true") for r in rows)
    if COMM.rank == 0:
        assert printed.count("\n") == 1 + 3 + 2 and "growth rate" in printed
        assert str(out / "steady.csv") in printed


def test_branches(shared_dir, capsys):
    out = shared_dir / "branches"
    code = main(["steady", "barber", "--out", str(out), "--set", "mesh.cells=20",
                 "--continue", "obstacle.temperature=0:30:16"])
    assert code == 0
    printed = capsys.readouterr().out
    columns, rows = read(out / "branches.csv")
    assert columns[:8] == ["parameter", "u_1", "sigma_1", "theta_1", "contact", "stable",
                           "growth_rate", "branch"]
    values = sorted({float(r["parameter"]) for r in rows})
    assert values == [2.0 * i for i in range(16)]
    counts = [sum(float(r["parameter"]) == v for r in rows) for v in values]
    assert set(counts) == {1, 3}  # one state, three between the folds, one again
    assert counts[0] == 1 and counts[-1] == 1 and 3 in counts
    # the states at each value are those of the scene there, in increasing u(1)
    at = [r for r in rows if float(r["parameter"]) == 10.0]
    states = steady.of_scene(rodfem.scene.load("barber", ["obstacle.temperature=10.0"])).states()
    assert [float(r["u_1"]) for r in at] == [s.u_1 for s in states]
    assert len({r["branch"] for r in rows}) == 3
    assert (out / "steady.csv").is_file()
    assert (out / "figures" / "branches.png").stat().st_size > 10_000
    if COMM.rank == 0:
        assert "obstacle.temperature from" in printed


BAD = [
    (["--continue", "model.zeta"], "is not KEY=a:b or KEY=a:b:n"),
    (["--continue", "model.zeta=1:2:3:4"], "is not KEY=a:b or KEY=a:b:n"),
    (["--continue", "model.zeta=a:2:3"], "is not KEY=a:b or KEY=a:b:n"),
    (["--continue", "model.zeta=a:2"], "is not KEY=a:b or KEY=a:b:n"),
    (["--continue", "model.zeta=1:2:1"], "2 <= n"),
    (["--continue", "model.zeta=1:1:3"], "differ"),
    (["--continue", "model.zeta=1:inf:3"], "finite"),
    (["--continue", "model.nothing=1:2:3"], "unknown scene key 'model.nothing'"),
    (["--continue", "mesh.cells=10:20:3"], "mesh.cells is not a real value"),
    (["--continue", "heat_exchange.law=1:2:3"], "heat_exchange.law is not a real value"),
    (["--continue", "model.zeta=-1:1:3"], "model.zeta: must be >= 0"),
    (["--set", "heat_exchange.length=1"], "heat_exchange.length: applies only with"),
    (["--set", "model.k=-1"], "model.k: must be >= 0"),
    (["--set", "mesh.cells=20001"], "mesh.cells = 20001: the stability of steady states is "
     "computed on at most 20000 cells"),
]


@pytest.mark.parametrize("args, message", BAD)
def test_bad_input(args, message, shared_dir, capsys):
    out = shared_dir / "bad"
    assert_refused(["steady", "barber", "--out", str(out), *args], out, message, capsys)


def test_existing_directory(shared_dir, capsys):
    """Never overwritten without --force; with it, only an earlier result is replaced."""
    out = shared_dir / "again"
    st.prepare(out, False, COMM, (st.STATES,), "steady")
    finish(out, "complete", COMM)
    if COMM.rank == 0:
        (out / "steady.csv").write_text("old")
    COMM.barrier()
    args = ["steady", "barber", "--out", str(out), "--set", "mesh.cells=10"]
    assert main(args) == 2
    assert "exists; use --force" in capsys.readouterr().err or COMM.rank > 0
    assert (out / "steady.csv").read_text() == "old"
    if COMM.rank == 0:
        (out / "notes.txt").write_text("mine")
    COMM.barrier()
    assert main([*args, "--force"]) == 2
    assert "holds notes.txt" in capsys.readouterr().err or COMM.rank > 0
    assert (out / "steady.csv").read_text() == "old" and (out / "notes.txt").exists()
    COMM.barrier()
    if COMM.rank == 0:
        (out / "notes.txt").unlink()
    COMM.barrier()
    assert main([*args, "--force"]) == 0
    capsys.readouterr()
    assert (out / "steady.csv").read_text().startswith("u_1,")


def test_default_directory(shared_dir, monkeypatch, capsys):
    monkeypatch.chdir(shared_dir)
    assert main(["steady", "barber", "--set", "mesh.cells=10"]) == 0
    capsys.readouterr()
    assert (shared_dir / "results" / "barber-steady" / "steady.csv").is_file()


def _cli(out: Path, ranks: int) -> str:
    command = [str(Path(sys.executable).with_name("rodfem")), "steady", "barber", "--out",
               str(out), "--continue", "heat_exchange.k1=500:1500:3"]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    done = subprocess.run(command, env=MPI_ENV, capture_output=True, text=True, timeout=300,
                          check=True)
    assert done.stdout.count("growth rate") == 1
    return (out / "steady.csv").read_text() + (out / "branches.csv").read_text()


@serial_only
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.slow  # tests/test_steady_diagram.py runs the diagram's command under mpirun
def test_command_under_mpirun_writes_the_serial_tables(tmp_path):
    assert _cli(tmp_path / "n2", 2) == _cli(tmp_path / "n1", 1)


def test_branches_are_born_and_end_in_pairs_at_folds():
    """The S of a fold pair: the two states born together start two branches, the others keep
    theirs in order, and the two that meet end together."""
    s = [[0.0], [0.01, 0.5, 0.51], [0.02, 0.45, 0.6], [0.29, 0.31, 0.7], [0.8]]
    table = [[{"u_1": value, "sigma_1": 0.0} for value in states] for states in s]
    assert st.branches(table) == [[0], [0, 1, 2], [0, 1, 2], [0, 1, 2], [2]]


def test_python_api_gives_the_tables(shared_dir, capsys):
    out = shared_dir / "api"
    assert main(["steady", "barber", "--out", str(out), "--set", "mesh.cells=20",
                 "--continue", "heat_exchange.k1=500:1500:3"]) == 0
    capsys.readouterr()
    import rodfem

    states = rodfem.steady("barber", {"mesh.cells": 20})
    _, rows = read(out / "steady.csv")
    assert [r["u_1"] for r in rows] == [repr(s["u_1"]) for s in states]
    assert [r["growth_rate"] for r in rows] == [repr(s["growth_rate"]) for s in states]
    over = rodfem.steady("barber", {"mesh.cells": 20}, over=("heat_exchange.k1", [500, 1000, 1500]))
    _, rows = read(out / "branches.csv")
    assert [(r["parameter"], r["u_1"], r["growth_rate"], r["branch"]) for r in rows] == \
        [(repr(s["parameter"]), repr(s["u_1"]), repr(s["growth_rate"]), str(s["branch"]))
         for s in over]
    with pytest.raises(rodfem.SceneError, match="heat_exchange.k1: must be >= 0"):
        rodfem.steady("barber", over=("heat_exchange.k1", [-1.0]))
