"""The files of a run besides its fields (:mod:`rodfem.output.fields`): history.h5, scene.toml
and summary.json.

Rank 0 writes them, each whole or not at all (:mod:`rodfem.output.atomic`): the history at every
checkpoint, so that a run that fails, is interrupted or is killed keeps whole rows up to its last
checkpoint.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rodfem.output.atomic import named, replacing, temporary
from rodfem.output.columns import COLUMNS
from rodfem.output.readers import DATASET

if TYPE_CHECKING:
    from mpi4py import MPI

CHUNK = 1024  # rows of an HDF5 chunk of the history: 1024 × 7 × 8 bytes = 57 kB by default


def rows_digest(rows: np.ndarray) -> hashlib._Hash:
    """The SHA-256 of history rows as the file holds them (little-endian float64, row after
    row), to be continued with ``update``: a checkpoint records it for the rows it counts."""
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(rows, dtype="<f8").tobytes())
    return digest


class HistoryFile:
    """history.h5, one row per kept step (``output.history_every``), in full float64: whole rows
    only, whatever happens to the process.

    The dataset ``/history`` (steps × columns, chunked by :data:`CHUNK` rows, its attribute
    ``columns`` the names, comma-separated). Rank 0 keeps the rows appended since the last
    checkpoint; :meth:`checkpoint` writes them: a copy of the file with the dataset extended,
    synced, renamed over it (:mod:`rodfem.output.atomic`). Binary rows cost nothing to format,
    and take 8 bytes a number where text took about 24.

    ``keep``: the rows of an existing history to continue (a resumed run: the checkpoint's count);
    None for a new file without rows. ``digest`` is the SHA-256 of the rows on the disk."""

    def __init__(self, path: Path, comm: MPI.Comm, columns=COLUMNS, keep: int | None = None):
        self.path, self.rank0 = path, comm.rank == 0
        self.names = ",".join(c.name for c in columns)
        self.width = len(columns)
        self._pending: list[np.ndarray] = []
        self.rows = 0
        self.digest = hashlib.sha256()
        if not self.rank0:
            return
        import h5py  # after dolfinx (rodfem.output.readers says why)

        if keep is None:
            self._replace(self._create, copy=False)
            return
        with h5py.File(path, "r") as file:
            kept = file[DATASET][:keep]
            longer = file[DATASET].shape[0] > keep
        self.digest, self.rows = rows_digest(kept), keep
        if longer:  # rows written after the checkpoint: not kept
            self._replace(lambda file: file[DATASET].resize(keep, axis=0))

    def _create(self, file) -> None:
        data = file.create_dataset(DATASET, shape=(0, self.width), maxshape=(None, self.width),
                                   dtype="<f8", chunks=(CHUNK, self.width))
        data.attrs["columns"] = self.names

    def _replace(self, change, copy: bool = True) -> None:
        """Apply ``change`` to a copy of the file (a new file if not ``copy``), sync it and
        rename it over the file."""
        import h5py

        part = temporary(self.path)
        try:
            if copy:
                shutil.copyfile(self.path, part)
            with h5py.File(part, "a" if copy else "w") as file:
                change(file)
            fd = os.open(part, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(part, self.path)
        except BaseException as err:
            part.unlink(missing_ok=True)
            if isinstance(err, OSError):
                raise named(err, self.path) from None
            raise

    def append(self, rows: np.ndarray) -> None:
        if self.rank0 and len(rows):
            self._pending.append(np.array(rows, dtype="<f8", copy=True))

    def checkpoint(self) -> int:
        """Write the rows appended so far (rank 0); return how many rows the file holds."""
        if not self.rank0 or not self._pending:
            return self.rows
        rows = np.concatenate(self._pending)

        def extend(file) -> None:
            data = file[DATASET]
            data.resize(self.rows + len(rows), axis=0)
            data[self.rows:] = rows

        self._replace(extend)
        self.rows += len(rows)
        self.digest.update(np.ascontiguousarray(rows).tobytes())
        self._pending.clear()
        return self.rows

    def close(self) -> None:
        """Nothing to stop (the history's rows need no formatting thread)."""


def write_text(path: Path, text: str, comm: MPI.Comm) -> None:
    """A text file, whole or not at all (rank 0)."""
    if comm.rank == 0:
        with replacing(path) as file:
            file.write(text)


def write_json(path: Path, data: dict, comm: MPI.Comm) -> None:
    """Strict JSON: a non-finite number is written as null."""

    def finite(value):
        if isinstance(value, float) and not np.isfinite(value):
            return None
        if isinstance(value, dict):
            return {k: finite(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [finite(v) for v in value]
        return value

    write_text(path, json.dumps(finite(data), indent=2, allow_nan=False) + "\n", comm)
