"""A sweep's journal: what each rank has done, in a file of its own, appended to scene by scene, so
that a killed or interrupted sweep continues without running a scene twice.

``journal/part-SSSS-RRRRR.bin`` holds the records of session S (0 for ``rodfem sweep``, 1 for
the first ``rodfem resume``, …) on rank R. A record is a header (the sweep's tag, the scene's
index, the lengths, a CRC-32 of all of it) followed by the scene's line of results.csv and, with
``--histories``, its history as float64 rows. The tag is the start of the digest of the sweep
the record belongs to (its ``sweep.json``): a record of another sweep is refused, never mixed.
Records are appended with one ``write`` each and the file is synced about once a second: after
SIGKILL every record whose ``write`` returned is whole (the system has it), and after a power
cut at most the last second's are lost or cut. A record that is cut or whose CRC does not match
ends the file for the reader: its scene, and any after it in that file, run again.
"""

from __future__ import annotations

import dataclasses
import os
import re
import struct
import time
import zlib
from pathlib import Path

import numpy as np

from rodfem.output.atomic import named

DIRECTORY = "journal"
PART = re.compile(r"^part-(\d{4,})-(\d{5,})\.bin$")
MAGIC = b"RDJ2"
HEADER = struct.Struct("<4s8sqIIII")  # magic, tag, index, text bytes, rows, columns, CRC-32
SYNC_SECONDS = 1.0


class JournalError(ValueError):
    """A journal holding whole records of another sweep than the one it is read for (``path``:
    the part file that holds them)."""

    def __init__(self, message: str, path: Path | None = None):
        super().__init__(message)
        self.path = path


def part_name(session: int, rank: int) -> str:
    return f"part-{session:04d}-{rank:05d}.bin"


@dataclasses.dataclass(frozen=True)
class Record:
    """One scene's record: where it is, its results line, and its history's shape."""

    index: int
    line: str
    tag: bytes
    session: int
    path: Path
    offset: int  # of the history's first byte
    rows: int
    columns: int

    def history(self) -> np.ndarray | None:
        """The scene's history rows, or None if the sweep did not keep histories."""
        if self.rows == 0:
            return None
        with open(self.path, "rb") as file:
            file.seek(self.offset)
            data = file.read(8 * self.rows * self.columns)
        return np.frombuffer(data, dtype="<f8").reshape(self.rows, self.columns).copy()


class Journal:
    """The journal file of this rank in this session (created on first :meth:`append`)."""

    def __init__(self, out: Path, session: int, rank: int, tag: bytes):
        self.path = out / DIRECTORY / part_name(session, rank)
        self.tag = tag
        self._fd: int | None = None
        self._size = 0  # the bytes of whole records in the file
        self._synced = time.monotonic()

    def append(self, index: int, line: str, history: np.ndarray | None = None) -> None:
        """Add a scene's record; OSError (naming the file) if it cannot be written, with the
        file cut back to its whole records (what a full disk took is given back)."""
        text = line.encode("utf-8")
        data = b"" if history is None else np.ascontiguousarray(history, dtype="<f8").tobytes()
        rows, columns = (0, 0) if history is None else history.shape
        body = text + data
        head = HEADER.pack(MAGIC, self.tag, index, len(text), rows, columns, 0)
        crc = zlib.crc32(body, zlib.crc32(head[:-4]))
        record = HEADER.pack(MAGIC, self.tag, index, len(text), rows, columns, crc) + body
        try:
            if self._fd is None:
                self.path.parent.mkdir(exist_ok=True)
                self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_CLOEXEC,
                                   0o644)
                self._size = os.fstat(self._fd).st_size
            view = memoryview(record)
            while view:
                written = os.write(self._fd, view)
                view = view[written:]
            self._size += len(record)
            if time.monotonic() - self._synced > SYNC_SECONDS:
                self.sync()
        except OSError as err:
            if self._fd is not None:
                try:
                    os.ftruncate(self._fd, self._size)
                except OSError:
                    pass  # a cut record ends the file for the reader anyway
            raise named(err, self.path) from None

    def sync(self) -> None:
        if self._fd is not None:
            os.fsync(self._fd)
            self._synced = time.monotonic()

    def close(self) -> None:
        if self._fd is not None:
            try:
                self.sync()
            finally:
                os.close(self._fd)
                self._fd = None


def _records(path: Path, session: int):
    """The whole records of one part file, in order (the first bad one ends it)."""
    try:
        with open(path, "rb") as file:
            data = file.read()
    except OSError:
        return
    at = 0
    while at + HEADER.size <= len(data):
        magic, tag, index, text, rows, columns, crc = HEADER.unpack_from(data, at)
        end = at + HEADER.size + text + 8 * rows * columns
        if magic != MAGIC or end > len(data):
            return
        head = data[at:at + HEADER.size - 4]
        if zlib.crc32(data[at + HEADER.size:end], zlib.crc32(head)) != crc:
            return
        try:
            line = data[at + HEADER.size:at + HEADER.size + text].decode("utf-8")
        except UnicodeDecodeError:
            return
        yield Record(index, line, tag, session, path, at + HEADER.size + text, rows, columns)
        at = end


def read(out: Path, tag: bytes | None = None) -> dict[int, Record]:
    """Every scene's last whole record (the latest session's wins), by index: of the sweep
    ``tag`` (or, without one, of the sweep of the first record).

    Raises:
        JournalError: a whole record of another sweep (one line naming its file).
    """
    latest: dict[int, Record] = {}
    directory = out / DIRECTORY
    parts = sorted((int(m[1]), p) for p in directory.glob("part-*.bin")
                   if (m := PART.match(p.name))) if directory.is_dir() else []
    for session, path in parts:
        for record in _records(path, session):
            tag = record.tag if tag is None else tag
            if record.tag != tag:
                raise JournalError(f"{path} holds a scene of another sweep than the directory's "
                                   "sweep.json", path)
            latest[record.index] = record
    return latest


def exists(out: Path) -> bool:
    """Whether ``out`` has a journal: part files, which a complete sweep has removed."""
    directory = out / DIRECTORY
    return directory.is_dir() and any(PART.match(p.name) for p in directory.iterdir())


def remove(out: Path) -> None:
    """Delete the journal's part files, and its directory if that leaves it empty (a file a
    user put there stays, and so does the directory)."""
    directory = out / DIRECTORY
    if not directory.is_dir():
        return
    for path in directory.iterdir():
        if PART.match(path.name) and path.is_file() and not path.is_symlink():
            path.unlink()
    try:
        directory.rmdir()
    except OSError:
        pass


def sessions(out: Path) -> int:
    """How many sessions have written the journal: the next one's number."""
    directory = out / DIRECTORY
    numbers = [int(m[1]) for p in directory.glob("part-*.bin")
               if (m := PART.match(p.name))] if directory.is_dir() else []
    return max(numbers, default=-1) + 1
