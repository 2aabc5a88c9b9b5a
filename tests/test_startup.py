"""The command's start: a process not started by a launcher asks Open MPI for its ob1 layer (no
UCX to initialise); one under a launcher, or with a choice of its own, keeps it."""

import pytest

from rodfem import __main__ as entry


@pytest.fixture
def environ(monkeypatch):
    for name in (*entry.LAUNCHED, "OMPI_MCA_pml"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.delitem(entry.sys.modules, "mpi4py.MPI", raising=False)
    return monkeypatch


def test_a_single_process_uses_ob1(environ):
    entry.single_process_mpi()
    assert entry.os.environ["OMPI_MCA_pml"] == "ob1"


@pytest.mark.parametrize("launcher", entry.LAUNCHED)
def test_a_launched_process_keeps_open_mpis_choice(environ, launcher):
    environ.setenv(launcher, "0")
    entry.single_process_mpi()
    assert "OMPI_MCA_pml" not in entry.os.environ


def test_a_users_choice_stands(environ):
    environ.setenv("OMPI_MCA_pml", "ucx")
    entry.single_process_mpi()
    assert entry.os.environ["OMPI_MCA_pml"] == "ucx"
