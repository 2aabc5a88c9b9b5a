"""The histories recorded from the code before its layers were redesigned (``tests/golden``)
stay what they were: every column to 1e-13 of its largest value, the iteration counts exactly,
through the compiled loops and the PETSc ones, serially and under MPI (every rank runs the whole
rod, so the parallel history is the serial one)."""

import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem.scene
from rodfem.run import simulate

sys.path.insert(0, str(Path(__file__).parent / "golden"))
import dolfinx  # noqa: E402
from cases import CASES, END, PETSC_LOOP, RECORDED_WITH  # noqa: E402

pytestmark = pytest.mark.skipif(
    not dolfinx.__version__.startswith(RECORDED_WITH + "."),
    reason=f"recorded with dolfinx {RECORDED_WITH}; another version's assembly rounds otherwise")

RECORDED = np.load(Path(__file__).parent / "golden" / "histories.npz")
RUNS = [(name, False) for name in CASES] + [(name, True) for name in PETSC_LOOP]


@pytest.mark.parametrize(("name", "petsc"), RUNS,
                         ids=[name + ("-petsc" if petsc else "") for name, petsc in RUNS])
def test_history_is_kept(name, petsc, monkeypatch):
    monkeypatch.setenv("RODFEM_KERNEL", "0" if petsc else "1")
    scene, overrides = CASES[name]
    result = simulate(rodfem.scene.load(scene, [*overrides, END]), None, MPI.COMM_WORLD,
                      progress=False)
    assert result.status == "complete"
    recorded = RECORDED[name + ("-petsc" if petsc else "")]
    history = result.history
    assert history.shape == recorded.shape
    np.testing.assert_array_equal(history[:, -1], recorded[:, -1])  # iterations
    scale = np.max(np.abs(recorded[:, :-1]), axis=0)
    worst = np.max(np.abs(history[:, :-1] - recorded[:, :-1]), axis=0) / np.where(scale, scale, 1)
    assert np.all(worst <= 1e-13), dict(zip(("t", "u_1", "u_half", "ut_1", "sigma_1", "energy"),
                                            worst, strict=True))
