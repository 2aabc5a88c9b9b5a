"""Shared fixtures. The suite runs serially and under ``mpirun -n 2 python -m mpi4py -m pytest``:
fixtures that create files agree on one directory across ranks."""

import shutil
import subprocess
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem.scene

COMM = MPI.COMM_WORLD
serial_only = pytest.mark.skipif(COMM.size > 1, reason="starts its own processes; run serially")


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
