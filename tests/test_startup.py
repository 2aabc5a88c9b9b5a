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
