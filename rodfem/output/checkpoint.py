"""Checkpoints: what a run needs to continue exactly where it was (``rodfem resume``).

``checkpoint.npz`` holds the method's state (:meth:`rodfem.solver.methods.base.Method.saved_state`)
and, as JSON in its entry ``meta``, the step, the length of history.csv at that step, the saved
fields, the energy monitor and the iteration counts, the seconds spent, and the resolved scene it
belongs to. It is written last at each checkpoint, after history.csv and the fields it counts are
on the disk, by write-then-rename: it is whole or the previous one. Whatever the process met
afterwards (Ctrl-C, SIGKILL, a full disk, a power cut), the run continues from it to the history
it would have had.

:class:`RunFiles` is a run's files together: history.csv, the fields, the checkpoint, and when to
write them.
"""

from __future__ import annotations

import json
import os
import time
import zipfile
from pathlib import Path

import numpy as np

from rodfem.output.atomic import TEMPORARY, replacing, sync_directory
from rodfem.output.columns import for_scene
from rodfem.output.fields import DIRECTORY, SEGMENT, FieldFile, segment_name
from rodfem.output.files import HistoryFile

NAME = "checkpoint.npz"
FORMAT = 1


class CheckpointError(ValueError):
    """A checkpoint that cannot be used (missing, corrupt, of another scene)."""


def write_checkpoint(out: Path, arrays: dict[str, np.ndarray], meta: dict) -> None:
    with replacing(out / NAME, "wb") as file:
        np.savez(file, meta=np.array(json.dumps({"format": FORMAT, **meta})), **arrays)


def read_checkpoint(out: Path) -> tuple[dict[str, np.ndarray], dict]:
    """The arrays and the metadata of ``out``'s checkpoint; CheckpointError (one line)."""
    path = out / NAME
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(str(arrays.pop("meta")))
    except FileNotFoundError:
        raise CheckpointError(f"{path} does not exist") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"{path} is not a readable checkpoint ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise CheckpointError(f"{path} is not a checkpoint this version of rodfem reads")
    return arrays, meta


class RunFiles:
    """history.csv, fields.xdmf (+ fields/) and checkpoint.npz of a run in ``out`` (every rank
    calls every method; rank 0 writes).

    A checkpoint is written at a field save once ``interval`` seconds of wall time have passed
    since the last (0: at every save), and when the run ends. ``resume``: the metadata of the
    checkpoint a resumed run starts from."""

    def __init__(self, out: Path, disc, interval: float, resume: dict | None = None,
                 pointwise=None):
        self.out, self.comm, self.interval = out, disc.comm, interval
        self.history = HistoryFile(out / "history.csv", self.comm, for_scene(disc.scene),
                                   keep=resume["history_bytes"] if resume else None)
        saves = resume["saves"] if resume else None
        self.fields = FieldFile(out / "fields.xdmf", disc, saves,
                                resume["segments"] if resume else 0, pointwise)
        if self.comm.rank == 0:
            self._remove_leftovers(resume["segments"] if resume else 0)
        self.last = time.perf_counter()
        self.seconds = 0.0  # spent writing checkpoints

    def _remove_leftovers(self, segments: int) -> None:
        """What a killed run of rodfem's left that is not the run's: segments written after its
        checkpoint, and its temporary files."""
        listed = {segment_name(k) for k in range(segments)}
        for entry in (self.out / DIRECTORY).iterdir():
            if entry.is_file() and not entry.is_symlink() and (
                    (SEGMENT.match(entry.name) and entry.name not in listed)
                    or TEMPORARY.match(entry.name)):
                entry.unlink()
        for entry in self.out.iterdir():
            match = TEMPORARY.match(entry.name)
            if match and entry.is_file() and not entry.is_symlink() and match["name"] in (
                    "history.csv", "fields.xdmf", "summary.json", "scene.toml", NAME,
                    "rodfem.json") and int(match["pid"]) != os.getpid():
                entry.unlink()

    def due(self) -> bool:
        """Whether a field save now should be a checkpoint (rank 0's clock decides: only rank 0
        writes)."""
        return time.perf_counter() - self.last >= self.interval

    def checkpoint(self, arrays: dict[str, np.ndarray] | None, meta: dict) -> None:
        """Write the fields and rows so far, then (given the method's state ``arrays``) the
        checkpoint that counts them. Without ``arrays`` (the state is not one to continue from:
        it is not finite) the previous checkpoint stays."""
        started = time.perf_counter()
        self.fields.checkpoint()
        size = self.history.checkpoint()
        if arrays is not None and self.comm.rank == 0:
            write_checkpoint(self.out, arrays, {**meta, "history_bytes": size,
                                                "history_sha256": self.history.digest.hexdigest(),
                                                "saves": self.fields.saves,
                                                "segments": self.fields.segments})
        if self.comm.rank == 0:
            sync_directory(self.out)
        self.last = time.perf_counter()
        self.seconds += self.last - started

    def close(self) -> None:
        self.history.close()
