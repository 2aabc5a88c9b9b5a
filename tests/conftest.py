"""Shared fixtures. The suite runs serially and under ``mpirun -n 2 python -m mpi4py -m pytest``:
fixtures that create files agree on one directory across ranks.

Keeping the suite quick (the native serial suite within 8 minutes on two cores):

* Profiles. ``RODFEM_TEST_PROFILE=quick`` (the default) leaves out the tests marked
  ``@pytest.mark.slow``: the long property tests and the wide grids whose promise a quick test of
  the same file guards too (a representative case, a smaller grid). ``RODFEM_TEST_PROFILE=full``
  (``make test-full``) runs them; so does ``-m slow`` (them alone). The header of pytest's output
  says which profile ran and how many tests it left out. A new long test: mark it ``slow`` and
  keep a short version (a few cases, a small mesh, a short time.end) unmarked.
* Shared runs. An expensive run that several tests read is made once by a module- or
  session-scoped fixture (see ``reference`` in test_resume.py); a test that changes it works on a
  copy (``copied``).
* In-process. ``rodfem.cli.main([...])`` runs a command in the test's process (``assert_refused``,
  ``cli``); a process of its own is needed only for signals, kills, mpirun, and environment
  variables read at import.
"""

import os
import shutil
import signal
import subprocess
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest


_MPI_JOB = ("PMIX_", "ORTE_", "OMPI_MCA_", "OMPI_APP_CTX_")


def _leave_the_controllers_mpi() -> None:
    """A pytest-xdist worker inherits the environment of its controller, whose MPI (a singleton,
    started by this file's import) wrote its PMIx server's address there: a worker's own MPI
    and every ``mpirun`` a test starts would take that job for theirs, and ``mpirun`` ends at
    once, with exit 1 and nothing said. The controller names the variables it had before its
    MPI started (Open MPI's parameters the user set, say); a worker drops the others."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        os.environ["RODFEM_TEST_OWN_MPI_ENV"] = ",".join(
            name for name in os.environ if name.startswith(_MPI_JOB))
    elif "RODFEM_TEST_OWN_MPI_ENV" in os.environ:
        own = set(os.environ["RODFEM_TEST_OWN_MPI_ENV"].split(","))
        for name in [n for n in os.environ if n.startswith(_MPI_JOB) and n not in own]:
            del os.environ[name]
        # The workers share the cores with the ranks their tests start: a rank waiting for
        # another gives up its core instead of spinning on it (answers unchanged).
        os.environ.setdefault("OMPI_MCA_mpi_yield_when_idle", "1")


_leave_the_controllers_mpi()
from mpi4py import MPI  # noqa: E402  (after the controller's MPI is left)

import rodfem.scene
from rodfem.output import interrupts

COMM = MPI.COMM_WORLD
serial_only = pytest.mark.skipif(COMM.size > 1, reason="starts its own processes; run serially")
PROFILE = os.environ.get("RODFEM_TEST_PROFILE", "quick")
PROFILES = ("quick", "full")


def _full(config) -> bool:
    """Whether the tests marked slow run: the full profile, or ``-m`` naming them."""
    return PROFILE == "full" or "slow" in (config.getoption("markexpr", "") or "")


def pytest_configure(config):
    if PROFILE not in PROFILES:
        raise pytest.UsageError(f"RODFEM_TEST_PROFILE={PROFILE!r}: use one of {PROFILES}")


def pytest_collection_modifyitems(config, items):
    """The quick profile leaves out the tests marked slow (deselected, and counted)."""
    if _full(config):
        return
    slow = [item for item in items if item.get_closest_marker("slow") is not None]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if item.get_closest_marker("slow") is None]


def pytest_report_header(config):
    if _full(config):
        return "rodfem test profile: full (the tests marked slow included)"
    return ("rodfem test profile: quick (tests marked slow deselected; "
            "RODFEM_TEST_PROFILE=full or make test-full runs them)")


def cli(*args) -> int:
    """``rodfem ARGS`` run in this process (no start-up of its own): its exit code."""
    from rodfem.cli import main

    return main([str(a) for a in args])


# The test process's own stop-signal handlers, as it started.
PROCESS_HANDLERS = {s: signal.getsignal(s) for s in interrupts.SIGNALS}


@pytest.fixture(autouse=True)
def _process_handlers():
    """The stop signals' handlers that a command run in the test's process (``rodfem.cli.main``,
    in a test or a module's fixture) installs for the rest of its process are the test
    process's own again after each test (:data:`PROCESS_HANDLERS`): a signal to a test worker
    (a CI's time limit) ends it as it would have, without rodfem's handling. (The unraisable
    hook it installs is pytest's to put back, after each phase of a test.)"""
    yield
    for s, handler in PROCESS_HANDLERS.items():
        if handler is not None and signal.getsignal(s) is not handler:
            signal.signal(s, handler)


def copied(source: Path, target: Path) -> Path:
    """A copy of a shared run directory (``source``) for a test that changes it."""
    shutil.copytree(source, target, symlinks=True)
    return target


@pytest.fixture
def shared_dir():
    """A temporary directory that every rank sees (rank 0 makes it and removes it)."""
    path = Path(tempfile.mkdtemp(prefix="rodfem-test-")) if COMM.rank == 0 else None
    path = COMM.bcast(path, root=0)
    yield path
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture
def simulate(shared_dir):
    """Run a scene in-process: ``simulate("paper1", "time.end=0.5", ...)`` → (RunResult, dir)."""
    from rodfem.output.directories import prepare_directory
    from rodfem.run import simulate as run

    count = [0]

    def _simulate(scene: str, *overrides: str):
        count[0] += 1
        out = shared_dir / f"run{count[0]}"
        prepared = rodfem.scene.load(scene, list(overrides))
        prepare_directory(out, False, COMM)
        return run(prepared, out, COMM, progress=False), out

    return _simulate


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs (CI runs as root); skipped where mounting is refused (a container)."""
    disk = tmp_path / f"disk-{uuid.uuid4().hex[:6]}"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({mounted.stderr.strip()})")
    yield disk
    subprocess.run(["umount", "-l", str(disk)], check=False)


def history_rows(out) -> "np.ndarray":  # noqa: F821 (NumPy is the reader's)
    """A run directory's history as its file holds it: steps × columns, float64."""
    from rodfem.output.readers import HISTORY, read_history

    return read_history(Path(out) / HISTORY, empty=True).rows


def run_history(scene, **overrides):
    """The history of a complete run of ``scene`` with ``overrides``."""
    result = rodfem.simulate(scene, overrides)
    assert result.status == "complete", result.summary
    return result.history


def dense(A) -> np.ndarray:
    """A PETSc matrix as a NumPy array (a copy: the dense matrix's own memory goes with it)."""
    D = A.convert("dense")
    array = D.getDenseArray().copy()
    D.destroy()
    return array


def assert_refused(args, out, message, capsys):
    """``rodfem ARGS`` refuses a user's mistake: exit 2, one line ``rodfem: error: …`` holding
    ``message`` on rank 0, and no ``out`` written."""
    from rodfem.cli import main

    code = main(args)
    err = capsys.readouterr().err
    assert code == 2
    assert not Path(out).exists()
    if COMM.rank == 0:
        assert err.startswith("rodfem: error: ") and message in err, err
        assert err.count("\n") == 1


def representative(cases, keep):
    """A grid's ``cases`` for ``@pytest.mark.parametrize``, those not in ``keep`` marked slow:
    the quick profile runs ``keep`` (each promise of the grid at least once), the full profile
    all of them. A case of several arguments is a tuple, as parametrize takes it."""
    missing = [k for k in keep if k not in cases]
    assert not missing, f"representative cases not in the grid: {missing}"
    return [case if case in keep else
            pytest.param(*(case if isinstance(case, tuple) else (case,)), marks=pytest.mark.slow)
            for case in cases]
