"""The command's start: a process not started by a launcher asks Open MPI for its ob1 layer (no
UCX to initialise) and no daemon of its own; one under a launcher, or with a choice of its own,
keeps it. A small serial run whose operators are cached starts neither PETSc nor MPI, and the
world without MPI answers as MPI's of one process does."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from rodfem import __main__ as entry
from rodfem import parallel

ROOT = Path(__file__).resolve().parents[1]

CHOICES = {"OMPI_MCA_pml": "ob1", "OMPI_MCA_ess_singleton_isolated": "1"}


@pytest.fixture
def environ(monkeypatch):
    for name in (*entry.LAUNCHED, *CHOICES):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.delitem(entry.sys.modules, "mpi4py.MPI", raising=False)
    return monkeypatch


def test_a_single_process_uses_ob1_and_no_daemon(environ):
    entry.single_process_mpi()
    assert {name: entry.os.environ.get(name) for name in CHOICES} == CHOICES


@pytest.mark.parametrize("launcher", entry.LAUNCHED)
def test_a_launched_process_keeps_open_mpis_choice(environ, launcher):
    environ.setenv(launcher, "0")
    entry.single_process_mpi()
    assert not any(name in entry.os.environ for name in CHOICES)


@pytest.mark.parametrize("name", CHOICES)
def test_a_users_choice_stands(environ, name):
    environ.setenv(name, "theirs")
    entry.single_process_mpi()
    assert entry.os.environ[name] == "theirs"


def test_a_commands_parser_alone_is_the_one_of_the_full_parser():
    """``rodfem COMMAND …`` builds COMMAND's parser alone: the same arguments, defaults and help
    as in the full parser, for every command there is."""
    from rodfem import cli

    def choices(parser):
        return parser._subparsers._group_actions[0].choices

    def described(parser):
        return [(a.option_strings, a.dest, a.default, a.nargs, a.help, a.choices)
                for a in parser._actions]

    full = choices(cli.parser())
    assert set(cli.ADDERS) == set(full)
    for name in cli.ADDERS:
        alone = choices(cli.parser(name))
        assert name in alone and len(alone) <= 2  # verify makes work-precision too
        assert described(alone[name]) == described(full[name]), name
        assert alone[name].description == full[name].description


# a small run of each kind of compiled loop: fixed steps (Picard's loop with the paper's first
# step; the direct method with Crank–Nicolson), and adaptive ones through a contact event (the
# paper scheme's first step and Picard's failures made in Python; Crank–Nicolson in C alone)
SMALL_RUNS = {
    "paper1": ["paper1", "--set", "time.end=0.01", "--set", "mesh.cells=100"],
    "impact": ["impact", "--set", "time.end=0.01", "--set", "mesh.cells=100"],
    "paper1, adaptive": ["paper1", "--set", "time.adaptive=true", "--set", "time.end=0.25",
                         "--set", "mesh.cells=100"],
    "stiff, adaptive": ["stiff", "--set", "time.adaptive=true", "--set",
                        "time.scheme=crank-nicolson", "--set", "time.end=0.3"],
}


@pytest.mark.skipif(parallel.launched(), reason="starts its own processes; run serially")
@pytest.mark.parametrize("name", SMALL_RUNS)
def test_a_small_serial_run_imports_neither_petsc4py_nor_mpi(tmp_path, name):
    """Once its operators are cached (a first run), a small run whose steps a compiled loop
    takes, fixed or adaptive, imports no petsc4py, nor dolfinx, nor scipy.linalg (the direct
    loop's band LU is its extension module's, loaded alone), and does not start MPI (the
    process is MPI's only one)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [
        str(ROOT), os.environ.get("PYTHONPATH")])))
    for run in range(2):
        done = subprocess.run(
            [sys.executable, "-X", "importtime", "-m", "rodfem", "run", *SMALL_RUNS[name],
             "--out", str(tmp_path / "out"), "--force", "--quiet"],
            env=env, cwd=tmp_path, capture_output=True, text=True, check=True)
    imported = {line.split("|")[-1].strip() for line in done.stderr.splitlines()
                if line.startswith("import time:")}
    assert "numpy" in imported and "rodfem.run" in imported  # the list is read
    assert "petsc4py.PETSc" not in imported
    assert "mpi4py.MPI" not in imported
    assert "dolfinx" not in imported
    assert "scipy.linalg" not in imported and "scipy.sparse" not in imported


def test_the_world_without_mpi_answers_as_mpis_of_one_process():
    """rank 0 of 1, collectives the identity on a copy (as mpi4py's lower-case ones give);
    anything else is MPI's own."""
    world = parallel.SERIAL
    data = {"a": [1, 2.5]}
    assert (world.rank, world.size, world.Get_rank(), world.Get_size()) == (0, 1, 0, 1)
    for got in (world.bcast(data, root=0), world.allgather(data)[0], world.gather(data)[0],
                world.allreduce(data)):
        assert got == data and got is not data
    world.barrier()
    from mpi4py import MPI

    assert world.Get_name() == MPI.COMM_WORLD.Get_name()
    assert parallel.real(world) is MPI.COMM_WORLD and parallel.world() is MPI.COMM_WORLD


@pytest.mark.skipif(parallel.launched(), reason="starts its own processes; run serially")
def test_the_command_leaves_its_objects_out_of_the_exits_collection(tmp_path):
    """After its command the process ends: what it made is frozen out of the cyclic garbage
    collection that Python's exit runs over every object (gc.freeze; 35 → 13 ms of exit after a
    small run), and the run it wrote is whole."""
    code = ("import gc, sys\nfrom rodfem.__main__ import main\n"
            "sys.argv = ['rodfem', *sys.argv[1:]]\ncode = main()\n"
            "print(len(gc.get_objects()), gc.get_freeze_count() > 10000, code)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [
        str(ROOT), os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, "-c", code, "run", *SMALL_RUNS["stiff, adaptive"],
                           "--out", str(tmp_path / "out"), "--quiet"],
                          env=env, cwd=tmp_path, capture_output=True, text=True, check=True)
    tracked, frozen, code = done.stdout.split()
    assert int(tracked) < 100 and frozen == "True" and code == "0", done.stdout
    import rodfem

    assert rodfem.load(tmp_path / "out").status == "complete"
