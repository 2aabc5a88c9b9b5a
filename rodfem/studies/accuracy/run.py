"""A scene with an accuracy target, from the ladder of runs (:mod:`.ladder`) to its run
directory: the reported run with its files, and beside them

* ``accuracy.csv``: every run of the ladder (cells, time step or tolerance, steps, rejected steps,
  wall time, each targeted measure), in the order made;
* ``accuracy.json``: what summary.json holds of it (``errors``, ``accuracy``), which a resumed
  reported run writes into its summary again;
* ``scene.toml``: the reported run's own scene (its cells and time step, no target), which runs
  it again bit for bit.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from rodfem.scene import Scene
from rodfem.studies.accuracy.ladder import COLUMNS, Ladder
from rodfem.studies.common import write_csv

if TYPE_CHECKING:
    from mpi4py import MPI

RECORD = "accuracy.json"


def simulate_to_target(scene: Scene, out: Path | None, comm: MPI.Comm,
                       say: Callable[[str], None] | None = None, progress: bool = False,
                       keep_fields: bool = False, setups=None):
    """Run ``scene`` to its targets: (the reported run's scene, its
    :class:`rodfem.run.RunResult`, the record of summary.json's ``errors`` and ``accuracy``).
    ``out``: the run directory, made already (None: in memory); ``setups``: the
    discretisations to share (:class:`rodfem.run.SetUps`).

    Raises:
        LadderFailed: a run of the ladder failed or was stopped (nothing is written).
    """
    from rodfem.output.files import write_text
    from rodfem.run import simulate

    ladder = Ladder(scene, comm, say, setups)
    cells, level, errors = ladder.climb()
    record = ladder.record(cells, level, errors)
    chosen = ladder.scene_at(cells, level)
    if out is not None:
        write_text(out / "scene.toml", chosen.to_toml(), comm)
        write_text(out / RECORD, json.dumps(record, indent=1, allow_nan=True) + "\n", comm)
        if comm.rank == 0:
            write_csv(out / "accuracy.csv", (*COLUMNS, *ladder.targets), ladder.rows())
    result = simulate(chosen, out, comm, progress=progress, setups=ladder.setups,
                      keep_fields=keep_fields, annotate=record)
    return chosen, result, record


def recorded(out: Path) -> dict | None:
    """The accuracy record of a run directory (None: its run had no target)."""
    try:
        return json.loads((out / RECORD).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
