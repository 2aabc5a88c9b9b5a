"""The command's start: a process not started by a launcher asks Open MPI for its ob1 layer (no
UCX to initialise) and no daemon of its own; one under a launcher, or with a choice of its own,
keeps it."""

import pytest

from rodfem import __main__ as entry

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
