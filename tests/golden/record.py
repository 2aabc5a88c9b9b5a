"""Record the histories of ``cases.py`` into ``histories.npz`` (run once, from the code whose
results are to be kept): ``.venv/bin/python tests/golden/record.py``."""

import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
import os  # noqa: E402

from cases import CASES, END, PETSC_LOOP  # noqa: E402

import rodfem.scene  # noqa: E402
from rodfem.run import simulate  # noqa: E402

histories = {}
runs = [(name, False) for name in CASES] + [(name, True) for name in PETSC_LOOP]
for name, petsc in runs:
    scene, overrides = CASES[name]
    os.environ["RODFEM_KERNEL"] = "0" if petsc else "1"
    result = simulate(rodfem.scene.load(scene, [*overrides, END]), None, MPI.COMM_SELF,
                      progress=False)
    name += "-petsc" if petsc else ""
    assert result.status == "complete", (name, result.summary)
    histories[name] = result.history
    print(name, result.history.shape, f"{result.summary['loop_seconds']:.3f} s")
np.savez_compressed(HERE / "histories.npz", **histories)
