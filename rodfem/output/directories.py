"""Run directories: a directory knows it is rodfem's, is held by one command at a time, and is
replaced with ``--force`` only where everything in it is rodfem's.

Every command that writes a directory (``run``, ``paper``, ``stability``, ``verify``,
``work-precision``) first creates it and writes its marker, ``rodfem.json`` (the command, status
``running``, rodfem's version, pid, host, start time and the entries the command writes), by
write-then-rename, so that it is whole or absent. :func:`finish` replaces it, the same way, with
the final status. For the command's life the directory is locked: an exclusive ``flock`` on
``rodfem.lock`` beside the marker, which the system releases when the process ends however it
ends, so that the lock of a killed run is free again (a stale lock is taken over). A lock file
removed while its command runs is no way in: the marker still names the live process
(:mod:`rodfem.output.writers`), and the command takes a new lock at its next checkpoint.

``--force`` empties a directory of its entries and keeps the directory and its lock, and only
where the marker proves it is rodfem's: every entry is one its marker lists (a subdirectory
listed is itself a rodfem directory) or a ``figures/`` of images that ``rodfem plot`` drew; no
entry is a link or a mount point, and the directory is neither the current directory nor an
ancestor of it. Anything else is refused with a one-line :class:`OutputError` (exit code 2) and
nothing is touched.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import re
import shutil
import socket
import time
from pathlib import Path
from typing import TYPE_CHECKING

import rodfem
from rodfem.output import handover
from rodfem.output.atomic import TEMPORARY
from rodfem.output.writers import LOCK, MARKER, in_use, marker_error, read_marker, write_marker

if TYPE_CHECKING:
    from mpi4py import MPI

RUN_FILES = ("history.h5", "fields.xdmf", "fields", "scene.toml", "summary.json",
             "checkpoint.npz")
ACCURACY_FILES = ("accuracy.csv", "accuracy.json")  # a run with an accuracy target's too
FIGURE_DIRS = ("figures", "figure5")
# The names of the figures rodfem draws (rodfem.post; "_<run>" when several runs are drawn).
FIGURE_NAMES = re.compile(r"^((contact|energy)(_.+)?\.(png|pdf|svg)"
                          r"|spacetime_(u|theta|sigma|velocity|heat_flux)(_.+)?\.(png|pdf|svg)"
                          r"|rod(_.+)?\.gif|stability_\w+\.(png|pdf|svg)"
                          r"|(orders|workprecision|measures)_.+\.(png|pdf|svg)"
                          r"|sweep_\w+\.(png|pdf|svg)|(branches|orbit|periodic)\.(png|pdf|svg))$")
# A run's subdirectories of data, and the names of the files rodfem writes there.
DATA_DIRS = {"fields": re.compile(r"^(mesh|steps-\d{6,})\.h5$"),
             "journal": re.compile(r"^part-\d{4,}-\d{5,}\.bin$")}

RESUMABLE = ("run", "sweep", "fit", "sensitivity")  # the commands `rodfem resume` continues
_held: dict[Path, tuple[int, dict]] = {}  # the directories this process holds: lock fd, marker


class OutputError(ValueError):
    """The output directory cannot be used (exit code 2)."""


def _only_named(path: Path, names: re.Pattern) -> bool:
    """Whether ``path`` holds only files (no links) with names rodfem gives them, or rodfem's
    temporary files of those."""
    def ours(f: Path) -> bool:
        match = TEMPORARY.match(f.name)
        return names.match(match["name"] if match else f.name) is not None

    return all(f.is_file() and not f.is_symlink() and ours(f) for f in path.iterdir())


def mount_points() -> list[Path]:
    """Every mount point of this process's namespace (/proc/self/mountinfo), bind mounts
    included: a bind mount of a directory of the same file system has the same device, so
    ``os.path.ismount`` does not see it."""
    try:
        lines = Path("/proc/self/mountinfo").read_text().splitlines()
    except OSError:
        return []
    # the fifth field, with space, tab, newline and backslash escaped as octal
    unescape = lambda text: text.encode().decode("unicode_escape").encode("latin-1").decode()  # noqa: E731
    return [Path(unescape(line.split()[4])) for line in lines if len(line.split()) > 4]


def _foreign(path: Path, mounts: list[Path] | None = None) -> str | None:
    """Why ``path`` may not be emptied by ``--force`` (the first entry that is not rodfem's, or a
    mount point in it), or None."""
    marker = read_marker(path)
    if marker is None:
        return f"it has no {MARKER}"
    if mounts is None:
        real = path.resolve()
        mounts = [m for m in mount_points() if m == real or real in m.parents]
        if mounts:
            inside = mounts[0]
            return ("it is a mount point" if inside == real
                    else f"{inside.relative_to(real)} is a mount point")
    device = path.stat().st_dev
    listed = {name for name in marker["files"] if isinstance(name, str)}
    for entry in sorted(path.iterdir()):
        name = entry.name
        if entry.is_symlink():
            return f"it holds {name}, a link"
        if entry.is_dir() and (os.path.ismount(entry) or entry.stat().st_dev != device):
            return f"{name} is a mount point"
        if name in (MARKER, LOCK) and entry.is_file():
            continue
        if entry.is_dir() and name in FIGURE_DIRS and _only_named(entry, FIGURE_NAMES):
            continue
        if entry.is_dir() and name in listed and name in DATA_DIRS \
                and _only_named(entry, DATA_DIRS[name]):
            continue
        if name in listed and entry.is_file():
            continue
        temporary = TEMPORARY.match(name)
        if temporary and temporary["name"] in (*listed, MARKER) and entry.is_file():
            continue  # left by a killed process as it replaced one of its files
        if name in listed and entry.is_dir() and _foreign(entry, mounts) is None:
            continue
        return f"it holds {name}"
    return None


def _holder(command: str) -> bytes:
    """What the lock file says of the process that holds it."""
    return (f"rodfem {command} (pid {os.getpid()} on {socket.gethostname()}, since "
            f"{time.strftime('%Y-%m-%dT%H:%M:%S%z')})").encode()


def _lock(path: Path, command: str) -> int:
    """Take the lock of ``path`` for ``command`` and write who holds it into the lock file;
    OutputError naming the holder if another process has it."""
    fd = os.open(path / LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        try:
            holder = os.read(fd, 512).decode("utf-8", "replace").strip()
        finally:
            os.close(fd)
        # empty only in the instant between the holder's flock and its write
        holder = holder if holder.startswith("rodfem ") else "another rodfem command"
        raise OutputError(f"{path} is in use by {holder}; wait for it to end, or stop it") from None
    try:
        os.ftruncate(fd, 0)
        with contextlib.suppress(OSError):  # a full disk: held all the same, holder unnamed
            os.pwrite(fd, _holder(command), 0)
    except BaseException:
        os.close(fd)
        raise
    return fd


def _unlock(fd: int) -> None:
    """Release a lock taken by :func:`_lock`, its holder's name wiped first."""
    try:
        os.ftruncate(fd, 0)
    except OSError:
        pass  # the name of a holder that is gone is never shown: its lock is free
    finally:
        os.close(fd)


def _inside(path: Path) -> bool:
    """Whether the current directory is ``path`` or inside it."""
    here, there = Path.cwd().resolve(), path.resolve()
    return here == there or there in here.parents


def _unmarked_claim(path: Path) -> bool:
    """Whether ``path`` holds only what a command stopped between creating it and marking it
    leaves: its lock, and perhaps the temporary file of its marker."""
    def ours(entry: Path) -> bool:
        match = TEMPORARY.match(entry.name)
        return entry.is_file() and not entry.is_symlink() and (
            entry.name == LOCK or (match is not None and match["name"] == MARKER))

    entries = list(path.iterdir())
    return bool(entries) and all(ours(e) for e in entries)


def _claim(path: Path, force: bool, keep: Path | None, command: str) -> int:
    """Create ``path``, or (with ``force``) empty the rodfem directory it is; return its lock."""
    try:
        path.mkdir(parents=True)
        return _lock(path, command)
    except FileExistsError:
        pass
    if not force:
        raise OutputError(f"output directory {path} exists; use --force to replace it")
    if not path.is_dir() or path.is_symlink():
        raise OutputError(f"output path {path} exists and is not a directory")
    if _inside(path):
        raise OutputError(f"{path} is the current directory or holds it; not replacing it, even "
                          "with --force")
    if keep is not None and path.resolve() in keep.resolve().parents:
        raise OutputError(f"the scene {keep} is inside the output directory {path}")
    if read_marker(path) is None and not _unmarked_claim(path):
        # taking its lock would write into a directory not ours
        raise OutputError(f"{path} is not a rodfem output directory (it has no {MARKER}); not "
                          "replacing it, even with --force")
    if (writer := in_use(path, read_marker(path))) is not None:
        raise OutputError(writer)
    fd = _lock(path, command)
    try:
        why = None if _unmarked_claim(path) else _foreign(path)
        if why is not None:
            raise OutputError(f"{path} is not a rodfem output directory ({why}); not replacing "
                              "it, even with --force")
        for entry in sorted(path.iterdir()):
            if entry.name == LOCK:
                continue
            if entry.is_dir():
                shutil.rmtree(entry)  # checked above: rodfem's, on this file system
            else:
                entry.unlink()
    except BaseException:
        _unlock(fd)  # refused: the lock file as it was, no holder named in it
        raise
    return fd


def _hold(path: Path, fd: int, marker: dict) -> None:
    """Mark ``path`` with ``marker`` while holding its lock ``fd``, until :func:`finish`."""
    try:
        write_marker(path, marker)
    except BaseException:
        os.close(fd)
        raise
    _held[path.resolve()] = (fd, marker)


def prepare_directory(path: Path, force: bool, comm: MPI.Comm, keep: Path | None = None,
                      command: str = "run", files: tuple[str, ...] = RUN_FILES) -> None:
    """Create ``path`` for a command that writes ``files`` (rank 0), mark it and hold its lock
    until :func:`finish`. An existing one is replaced only with ``force``, and only if it is a
    rodfem directory that holds nothing but what rodfem writes; never if it holds ``keep`` (the
    scene being run).

    Raises:
        OutputError: on every rank, with one line saying why, and nothing touched.
    """
    error, marker = None, None
    if comm.rank == 0:
        marker = {"rodfem": rodfem.__version__, "command": command, "status": "running",
                  "pid": os.getpid(), "host": socket.gethostname(),
                  "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "files": list(files)}
        try:
            if "\0" in str(path):
                raise OutputError(f"output directory {str(path)!r}: a path cannot hold a NUL "
                                  "character")
            _hold(path, _claim(path, force, keep, command), marker)
        except OSError as err:
            error = f"cannot create output directory {path}: {err.strerror or err}"
        except OutputError as err:
            error = str(err)
    handover.meet(comm)  # rank 0 answers signals, and the other ranks' stops, till all are here
    error, marker = comm.bcast((error, marker), root=0)
    if error:
        raise OutputError(error)
    handover.remember(path, marker, comm)


def keep_lock(path: Path) -> None:
    """Hold ``path``'s lock still (rank 0, at each checkpoint): a lock file removed or replaced
    meanwhile is made and taken again. OSError if another process took it first (this one then
    holds it no more, and writes no marker)."""
    held = _held.get(path.resolve())
    if held is None:
        return
    fd, marker = held
    with contextlib.suppress(FileNotFoundError):
        if os.stat(path / LOCK).st_ino == os.fstat(fd).st_ino:
            return
    try:
        new = _lock(path, marker.get("command", "run"))
    except OutputError as err:
        _held.pop(path.resolve(), None)
        os.close(fd)
        raise OSError(errno.EBUSY, f"{err} (its lock file was removed)", str(path / LOCK)) \
            from None
    _held[path.resolve()] = (new, marker)
    os.close(fd)


def finish(path: Path, status: str, comm: MPI.Comm) -> None:
    """Record the command's final ``status`` in the marker (complete, failed, interrupted) and
    release the directory's lock (rank 0; nothing if this process does not hold it)."""
    if comm.rank != 0:
        handover.forget(path)
        return
    held = _held.pop(path.resolve(), None)
    if held is None:
        return
    fd, marker = held
    try:
        write_marker(path, {**marker, "status": status,
                             "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
    finally:
        _unlock(fd)


def reopen(path: Path, comm: MPI.Comm) -> dict:
    """Hold the run directory ``path`` again (``rodfem resume``): it must be one that a command
    of :data:`RESUMABLE` wrote and that no process holds. Returns its marker; nothing is
    written until :func:`mark_running` (or :func:`release`, which lets it go untouched).

    Raises:
        OutputError: on every rank, with one line saying why, and nothing touched.
    """
    error, before = None, None
    if comm.rank == 0:
        try:
            if not path.is_dir():
                raise OutputError(f"{path} is not a directory")
            before = read_marker(path)
            if before is None or before.get("command") not in RESUMABLE:
                raise OutputError(f"{path} is not a directory of 'rodfem run', 'rodfem sweep', "
                                  f"'rodfem fit' or 'rodfem sensitivity' (no {MARKER} of one)")
            why = marker_error(before)
            if why is not None:
                raise OutputError(f"{path / MARKER} is not a marker rodfem wrote ({why}); "
                                  "the run cannot be resumed from it")
            if (writer := in_use(path, before)) is not None:
                raise OutputError(writer)
            _held[path.resolve()] = (_lock(path, "resume"), before)
        except OSError as err:
            error = f"cannot resume {path}: {err.strerror or err}"
        except OutputError as err:
            error = str(err)
    error, before = comm.bcast((error, before), root=0)
    if error:
        raise OutputError(error)
    return before


def mark_running(path: Path, comm: MPI.Comm) -> None:
    """The marker of a directory held by :func:`reopen` says ``running`` again, with this
    process (rank 0)."""
    marker = None
    if comm.rank == 0:
        fd, before = _held.pop(path.resolve())
        marker = {**before, "status": "running", "pid": os.getpid(),
                  "host": socket.gethostname(), "resumed": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        marker.pop("finished", None)
        _hold(path, fd, marker)
    handover.remember(path, comm.bcast(marker, root=0), comm)


def release(path: Path, comm: MPI.Comm) -> None:
    """Let a held directory go without writing anything (rank 0)."""
    handover.forget(path)
    if comm.rank == 0:
        held = _held.pop(path.resolve(), None)
        if held is not None:
            _unlock(held[0])


def state(path: Path) -> str | None:
    """How a run directory's command ended: its marker's status (complete, failed,
    interrupted), ``running`` while a process holds it, ``gone`` if it says running but no
    process holds it (it was killed), None without a marker."""
    marker = read_marker(path)
    if marker is None:
        return None
    if marker.get("status") != "running":
        return str(marker.get("status"))
    try:
        fd = os.open(path / LOCK, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return "gone"
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return "running"
    finally:
        os.close(fd)
    return "gone"


def release_all(status: str) -> dict[Path, str]:
    """Record ``status`` in every directory this process still holds, and release them (a
    command stopped before it could finish them itself), and in those rank 0 holds whose marker
    still says running (:mod:`rodfem.output.handover`). Errors are ignored: the lock is freed
    when the process ends anyway, and a marker that still says running is read as 'gone'.
    Returns them, with the command of each."""
    from mpi4py import MPI  # here: reading a directory (rodfem.load) needs no MPI

    released = {path: str(marker.get("command")) for path, (_, marker) in _held.items()}
    for path in list(_held):
        try:
            finish(path, status, MPI.COMM_SELF)
        except OSError:
            pass
    return {**released, **handover.mark(status)}  # rank 0's, from a rank that ends it
