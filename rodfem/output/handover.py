"""How a command stopped is recorded before any rank ends the others.

Under MPI rank 0 alone holds a command's directories and writes their markers; a rank stopped by
a signal outside the time loop ends every rank (:func:`abort_ranks`),
rank 0 with them, perhaps while rank 0 is busy in compiled code or waiting for that very rank.
Rank 0's marker must not be left saying ``running`` (read as ``gone``, as after a kill). So:

* every rank knows the directories rank 0 holds and their markers (:func:`remember`, called by
  :mod:`rodfem.output.directories` when rank 0 marks one, :func:`forget` when it finishes), and
  a rank that ends the others first records their status itself (:func:`mark`), a
  write-then-rename of the marker as rank 0 would write it, where the marker still names rank
  0's running command (never over a final status that rank 0 wrote);
* before the ranks know a new directory, they wait for each other listening (:func:`meet`):
  rank 0 answers its own signals there, and takes a rank's word that it is stopping
  (:func:`notify`), which the stopping rank gives before it ends the others, and then waits
  for rank 0 (which ends every rank itself once its marker is written) for at most
  :data:`GRACE` seconds: the job ends in any case, and no rank waits for ever.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

from rodfem.output.interrupts import SIGNALS, Interrupted, signal_received
from rodfem.output.writers import read_marker, write_marker
from rodfem.parallel import LAUNCHED

TAG = 0x52F0  # the tag of a rank's word to rank 0 that it is stopping
GRACE = 2.0  # seconds a stopping rank waits for rank 0 to end every rank itself
POLL = 0.005  # seconds between looks while the ranks wait for each other
# Test hook: once a run's directory is marked and its scene written, every rank waits this many
# seconds, rank 0 deaf to the stop signals (as in compiled code), so that another rank's stop
# comes first.
PAUSE = "RODFEM_TEST_PAUSE_AFTER_MARKING"

_known: dict[Path, dict] = {}  # on ranks other than 0: the directories rank 0 holds, markers


def remember(path: Path, marker: dict | None, comm) -> None:
    """``path``, marked ``marker`` by rank 0 of ``comm``, is known to this rank (not rank 0)."""
    if comm.rank != 0 and marker is not None:
        _known[path.resolve()] = marker


def forget(path: Path) -> None:
    """Rank 0 finished or let go of ``path``."""
    _known.pop(path.resolve(), None)


def mark(status: str) -> dict[Path, str]:
    """Record ``status`` in the directories rank 0 holds whose marker still names its running
    command; returns them with their command. Errors are ignored (the marker then reads
    ``gone``, as after a kill)."""
    marked = {}
    for path, marker in list(_known.items()):
        on_disk = read_marker(path)
        if on_disk is None or any(on_disk.get(k) != marker.get(k) for k in
                                  ("status", "pid", "host", "started", "resumed")):
            continue  # rank 0 wrote its own status, or another command holds it now
        try:
            write_marker(path, {**marker, "status": status,
                                "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")})
        except OSError:
            continue
        marked[path] = str(marker.get("command"))
    _known.clear()
    return marked


def meet(comm) -> None:
    """Wait until every rank of ``comm`` is here, answering signals meanwhile. On rank 0 a
    rank's word that it is stopping raises :class:`~rodfem.output.interrupts.Interrupted` at
    once (that rank will not come); a stop signal noted here (inside ``deferred``) raises it if
    the others have not come within :data:`GRACE` seconds (they are stopping too)."""
    if comm.size == 1:
        return
    from mpi4py import MPI

    request = comm.Ibarrier()
    world, word, noted = MPI.COMM_WORLD, MPI.Status(), None
    while not request.Test():
        if world.rank == 0 and world.Iprobe(MPI.ANY_SOURCE, TAG, word):
            raise Interrupted(world.recv(source=word.Get_source(), tag=TAG))
        if signal_received() is not None:
            noted = noted or time.monotonic()
            if time.monotonic() - noted > GRACE:
                raise Interrupted(signal_received())
        time.sleep(POLL)  # a signal's handler runs here


def notify(code: int) -> None:
    """This rank (not rank 0) stops with exit ``code``: where it knows no directory of rank
    0's, rank 0 may be waiting for it in :func:`meet`; tell it the signal, and give it
    :data:`GRACE` seconds to record it and end every rank itself."""
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    if world.rank == 0 or code <= 128 or _known:
        return
    world.isend(code - 128, dest=0, tag=TAG)
    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)  # this rank is ending anyway
    time.sleep(GRACE)


def abort_ranks(code: int) -> None:
    """Under MPI, end every rank: a rank stopped outside the time loop may leave the others
    waiting in a collective call for ever (a signal that reached the ranks at different
    points of their start-up). Open MPI then prints its own lines. A launcher's rank stopped
    in the import of mpi4py.MPI (MPI started, the module not kept) ends without MPI_Finalize,
    which would wait for those ranks: the launcher then ends the job. Rank 0's markers are
    written first (:func:`notify`)."""
    MPI = getattr(sys.modules.get("mpi4py.MPI"), "COMM_WORLD", None)
    if MPI is None and "mpi4py" in sys.modules and any(v in os.environ for v in LAUNCHED):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    if MPI is not None and MPI.Get_size() > 1:
        sys.stderr.flush()
        notify(code)  # rank 0 records how the command stopped before it is ended
        MPI.Abort(code)


def pause_for_tests(comm) -> None:
    """The test hook :data:`PAUSE` (nothing without it)."""
    seconds = float(os.environ.get(PAUSE, "0") or 0)
    if seconds <= 0:
        return
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS) if comm.rank == 0 \
        else None
    try:
        time.sleep(seconds)
    finally:
        if blocked is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
