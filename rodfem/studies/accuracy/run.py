"""A scene with an accuracy target, from the ladder of runs (:mod:`.ladder`) to its run
directory: the reported run with its files, and beside them

* ``accuracy.csv``: every run of the ladder (cells, time step or tolerance, steps, rejected steps,
  wall time, each targeted measure), in the order made;
* ``accuracy.json``: what summary.json holds of it (``errors``, ``accuracy``, with the digest of
  the reported run's scene), which a resumed reported run writes into its summary again (not a
  run extended by ``resume --set``: its scene is another);
* ``scene.toml``: the reported run's own scene (its cells and time step, no target), which runs
  it again bit for bit.
"""

from __future__ import annotations

import hashlib
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
    from rodfem.output import interrupts
    from rodfem.output.files import write_json, write_text
    from rodfem.run import simulate

    ladder = Ladder(scene, comm, say, setups)
    cells, level, errors = ladder.climb()
    chosen = ladder.scene_at(cells, level)
    record = ladder.record(cells, level, errors)
    record["accuracy"]["scene"] = digest(chosen)
    if out is not None:
        # the choice's files, then the chosen scene in place of the asked one, all before a
        # signal is taken: a resume runs the chosen scene with its estimates, or chooses again
        with interrupts.deferred():
            write_json(out / RECORD, record, comm)
            if comm.rank == 0:
                write_csv(out / "accuracy.csv", (*COLUMNS, *ladder.targets), ladder.rows())
            write_text(out / "scene.toml", chosen.to_toml(), comm)
    result = simulate(chosen, out, comm, progress=progress, setups=ladder.setups,
                      keep_fields=keep_fields, annotate=record)
    return chosen, result, record


def digest(scene: Scene) -> str:
    """What names the reported run's scene in its record: the SHA-256 of its resolved values
    (:meth:`Scene.data`; not its description, which does not change the run)."""
    text = json.dumps(scene.data(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def recorded(out: Path, scene: Scene) -> dict | None:
    """The accuracy record of a run directory whose run is ``scene`` (None: its run had no
    target, or the record is of another scene's run: one extended by ``resume --set``)."""
    try:
        record = json.loads((out / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("accuracy", {}).get("scene") != digest(scene):
        return None
    return record
