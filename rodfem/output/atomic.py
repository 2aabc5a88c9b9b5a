"""Files written whole or not at all: write a temporary file beside the target, flush it to the
disk (fsync), then rename it over the target. A reader, a killed process or a power cut sees the
old file or the new one, never half of either.

The temporary file is ``.<name>.<pid>`` in the same directory; a failed write removes it.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
from pathlib import Path

TEMPORARY = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)$")  # the name of a temporary file


def named(err: OSError, path: Path) -> OSError:
    """``err`` with the file it concerns: a failed write or flush says only "No space left on
    device", and HDF5 reports its system errors as text ("errno = 28")."""
    if err.filename is not None and err.errno is not None:
        return err
    code = err.errno
    if code is None:
        found = re.search(r"errno = (\d+)", str(err))
        code = int(found[1]) if found else errno.EIO
    return OSError(code, os.strerror(code), str(path))


def io_line(err: OSError) -> str:
    """What a failed write says to the user: the file and the system's message, on one line."""
    where = f"{err.filename}: " if err.filename else ""
    return " ".join(f"cannot write {where}{err.strerror or err}".split())


def temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}")


@contextlib.contextmanager
def replacing(path: Path, mode: str = "w"):
    """``with replacing(path) as file: file.write(...)``: ``path`` is replaced by what was written
    when the block ends without an error; otherwise it is left as it was."""
    part = temporary(path)
    try:
        with open(part, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as file:
            yield file
            file.flush()
            os.fsync(file.fileno())
        os.replace(part, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            part.unlink()
        if isinstance(err, OSError):
            raise named(err, path) from None
        raise


def sync_directory(path: Path) -> None:
    """Flush a directory's entries (the renames into it) to the disk."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
