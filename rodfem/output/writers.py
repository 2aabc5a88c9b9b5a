"""Who writes a run directory: its marker (``rodfem.json``), written whole or not at all and read
back; the process it names, and whether that process is still alive on this host; and the
marker's fields, checked before a command trusts them.

The lock (``rodfem.lock``) says who holds a directory while its file exists; a user may remove it
while the run goes on. The marker says it too: a ``running`` marker whose process is alive, and
started before it marked the directory (so not a later process that was given the same number),
names the directory's writer whether or not the lock is still there.
"""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

from rodfem.output.atomic import replacing

MARKER, LOCK = "rodfem.json", "rodfem.lock"


def write_marker(path: Path, marker: dict) -> None:
    """rodfem.json by write-then-rename: whole or absent, never half-written."""
    with replacing(path / MARKER) as file:
        json.dump(marker, file, indent=2)
        file.write("\n")


def read_marker(path: Path) -> dict | None:
    """The marker of ``path``, or None if it has none that rodfem wrote."""
    try:
        marker = json.loads((path / MARKER).read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(marker, dict) or not isinstance(marker.get("files"), list):
        return None
    return marker


def _process(pid: int) -> tuple[str | None, float | None]:
    """The state of process ``pid`` of this host (``R``, ``S``, ``Z`` a zombie, …) and when it
    started (seconds since the epoch); None for what cannot be read."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None, None
    try:
        boot = next(int(line.split()[1]) for line in Path("/proc/stat").read_text().splitlines()
                    if line.startswith("btime "))
        ticks = int(fields[19])  # field 22, starttime
        return fields[0], boot + ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return fields[0] if fields else None, None


def _marked_at(marker: dict) -> float | None:
    """When the marker's process marked the directory (its start, or its resume)."""
    import datetime

    try:
        when = marker.get("resumed") or marker["started"]
        return datetime.datetime.strptime(when, "%Y-%m-%dT%H:%M:%S%z").timestamp()
    except (KeyError, TypeError, ValueError):
        return None


def live_writer(marker: dict) -> str | None:
    """The process a ``running`` marker names, if it is alive on this host (another than this
    one), as the lock names it; else None. Its lock file may have been removed: the marker
    still says who writes the directory. A process whose number was reused (started after the
    marker was written) is not its writer."""
    pid, host = marker.get("pid"), marker.get("host")
    if marker.get("status") != "running" or not isinstance(pid, int) or isinstance(pid, bool) \
            or host != socket.gethostname() or pid == os.getpid() or pid <= 0:
        return None
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):
        return None
    except PermissionError:
        pass  # alive, another user's
    (status, started), marked = _process(pid), _marked_at(marker)
    if status in ("Z", "X"):  # killed, not yet reaped (its parent gone, under an init that
        return None           # reaps no one): it writes nothing any more
    if started is not None and marked is not None and started > marked + 2:  # whole seconds
        return None
    return (f"rodfem {marker.get('command')} (pid {pid} on {host}, since "
            f"{marker.get('resumed') or marker.get('started')})")


def in_use(path: Path, marker: dict | None) -> str | None:
    """The line that refuses ``path`` if ``marker`` names a live process writing it, or None."""
    writer = live_writer(marker) if marker is not None else None
    return None if writer is None else (f"{path} is in use by {writer}; wait for it to end, or "
                                        "stop it")


# A marker's fields and their types (those a command reads; others are kept as they are).
MARKER_FIELDS = {"rodfem": str, "command": str, "status": str, "pid": int, "host": str,
                 "started": str, "resumed": str, "finished": str}
STATUSES = ("running", "complete", "failed", "interrupted")


def marker_error(marker: dict) -> str | None:
    """What is wrong with a marker rodfem would have written, or None."""
    for name, kind in MARKER_FIELDS.items():
        value = marker.get(name)
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            return f"its {name} is {json.dumps(value)[:40]}"
    for name in ("rodfem", "command", "status"):
        if name not in marker:
            return f"it has no {name}"
    if marker["status"] not in STATUSES:
        return (f"its status is {json.dumps(marker['status'])[:40]}, not one of "
                f"{', '.join(STATUSES)}")
    if not all(isinstance(name, str) for name in marker["files"]):
        return "its files are not names"
    return None
