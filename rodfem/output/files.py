"""The text files of a run: history.csv, scene.toml and summary.json (the fields are
:mod:`rodfem.output.fields`).

Rank 0 writes them, each whole or not at all (:mod:`rodfem.output.atomic`): the history at every
checkpoint, so that a run that fails, is interrupted or is killed keeps whole rows up to its last
checkpoint.
"""

from __future__ import annotations

import hashlib
import json
import os
import queue
import shutil
import threading
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from rodfem.output.atomic import named, replacing, temporary
from rodfem.output.columns import COLUMNS


class HistoryFile:
    """history.csv, one row per step: whole rows only, whatever happens to the process.

    Printing a row's seven default numbers to round-trip precision takes about 2 µs, as long as a compiled
    step itself, so rank 0 formats the blocks in a thread of its own while the time loop (a C call
    that releases the GIL) goes on, and keeps the text. :meth:`checkpoint` writes it: a copy of
    the file with the new rows appended, synced, renamed over it (:mod:`rodfem.output.atomic`).
    ``keep``: the length in bytes of an existing history to continue (a resumed run); None for a
    new file of just the header."""

    def __init__(self, path: Path, comm: MPI.Comm, columns=COLUMNS, keep: int | None = None):
        self.path, self.rank0 = path, comm.rank == 0
        # a row: integers as such, floats to round-trip precision
        self.row = ",".join("%d" if c.integer else "%.17g" for c in columns) + "\n"
        self._error: BaseException | None = None
        self._text: list[str] = []
        self.size = 0
        self.digest = hashlib.sha256()  # of the file as written: resume checks it is unchanged
        if not self.rank0:
            return
        if keep is None:
            header = ",".join(c.name for c in columns) + "\n"
            with replacing(path) as file:
                file.write(header)
            self.size = len(header.encode())
            self.digest.update(header.encode())
        else:
            with open(path, "rb") as old:
                kept = old.read(keep)
            self.digest.update(kept)
            if path.stat().st_size != keep:  # rows written after the checkpoint: not kept
                with replacing(path, "wb") as file:
                    file.write(kept)
            self.size = keep
        self._blocks: queue.Queue = queue.Queue()
        self._writer = threading.Thread(target=self._format, name="history.csv", daemon=True)
        self._writer.start()

    def _format(self) -> None:
        row = self.row
        while True:
            rows = self._blocks.get()
            try:
                if rows is None:
                    return
                for part in range(0, len(rows), 64):  # short holds of the GIL
                    self._text.append("".join([row % tuple(r)
                                               for r in rows[part:part + 64].tolist()]))
                    time.sleep(0)
            except BaseException as err:  # noqa: BLE001 (handed to checkpoint)
                self._error = err
            finally:
                self._blocks.task_done()

    def append(self, rows: np.ndarray) -> None:
        if self.rank0:
            self._blocks.put(np.array(rows, copy=True))

    def checkpoint(self) -> int:
        """Write the rows appended so far (rank 0); return the file's length in bytes."""
        if not self.rank0:
            return self.size
        self._blocks.join()
        if self._error is not None:
            raise self._error
        text = "".join(self._text).encode()
        if text:
            part = temporary(self.path)
            try:
                shutil.copyfile(self.path, part)
                with open(part, "ab") as file:
                    file.write(text)
                    file.flush()
                    os.fsync(file.fileno())
                os.replace(part, self.path)
            except BaseException as err:
                part.unlink(missing_ok=True)
                if isinstance(err, OSError):
                    raise named(err, self.path) from None
                raise
            self.size += len(text)
            self.digest.update(text)
            self._text.clear()
        return self.size

    def close(self) -> None:
        """Stop the formatting thread (after a last :meth:`checkpoint`, or without writing)."""
        if self.rank0 and self._writer.is_alive():
            self._blocks.put(None)
            self._writer.join()


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
