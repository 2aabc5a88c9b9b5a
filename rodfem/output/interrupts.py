"""Signals that stop a command: Ctrl-C (SIGINT), SIGTERM (a cluster's time limit), SIGHUP (a
closed terminal) and SIGUSR1 (which Open MPI's mpirun forwards to the ranks).

A command stops on any of them with exit code 128 + the signal's number (130, 143, 129, 138) and
no traceback. A signal the command was started ignoring (``nohup``; SIGINT for a shell's ``&``
job) stays ignored. Where it stops depends on when the signal comes:

* during start-up (imports, just-in-time compilation, set-up) and between runs, the signal raises
  :class:`Interrupted` at once; nothing is half-written, since every file rodfem writes outside
  the time loop is written whole or not at all;
* inside :func:`deferred` (the time loop, and the writing of a run's files), it is only noted:
  the loop stops at the end of a step, writes its checkpoint and files whole, and reports the run
  as interrupted. Under MPI the ranks agree on the step (:func:`requested`).

:func:`install` is called by the ``rodfem`` command first thing; a library caller who did not call
it gets the handlers inside :func:`deferred` only, and its own handlers back afterwards; inside
:func:`call`, a signal received is forgotten when the call ends.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

from rodfem import parallel
# Environment variables a launcher (mpirun, mpiexec, srun) gives each process it starts.
from rodfem.parallel import LAUNCHED

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGUSR1)

_received: list[int] = []  # the signals this process has received
_depth = [0]  # > 0 inside deferred(): a signal is noted, not raised
_depth_calls = [0]  # > 0 inside call()


class Interrupted(Exception):
    """A stop signal (Ctrl-C, SIGTERM, SIGUSR1 …) that stopped a command or a study outside a
    run's time loop; ``signum`` is the signal's number."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(f"interrupted by {signal.Signals(signum).name}")

    @property
    def exit_code(self) -> int:
        """128 + the signal's number, the exit code of a command stopped so."""
        return 128 + self.signum


def _handler(signum, frame) -> None:
    _received.append(signum)
    if _depth[0] == 0:
        raise Interrupted(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _unraisable(unraisable) -> None:
    """A stop signal whose :class:`Interrupted` was raised where Python cannot pass it on (a
    destructor or a finaliser, a library's logging in one, during start-up) is not printed as an
    ignored exception: it is noted (:func:`signal_received`), and the command stops at its next
    check, the time loop's first step at the latest."""
    if isinstance(unraisable.exc_value, Interrupted):
        return
    _printed(unraisable)


_printed = sys.unraisablehook


@contextlib.contextmanager
def command():
    """While a ``rodfem`` command runs, the same for an :class:`Interrupted` that a library's C
    code printed itself (``PyErr_Print``, through ``sys.excepthook``: seen from an import that a
    signal interrupted during start-up, under mpirun): the signal is noted and the command stops
    at its next check, in one line. Outside, Python's hook is back: an Interrupted nobody
    caught is printed as any exception is."""
    printed = sys.excepthook

    def hook(kind, value, traceback) -> None:
        if not isinstance(value, Interrupted):
            printed(kind, value, traceback)

    sys.excepthook = hook
    try:
        yield
    finally:
        sys.excepthook = printed


def install() -> None:
    """Route the stop signals to rodfem for the rest of the process. PETSc installs handlers of
    its own (SIGHUP and SIGTERM call MPI_Abort) unless told not to: this tells it, so call it
    before petsc4py is imported."""
    options = os.environ.get("PETSC_OPTIONS", "")
    if "-no_signal_handler" not in options.split():
        os.environ["PETSC_OPTIONS"] = f"{options} -no_signal_handler".strip()
    sys.unraisablehook = _unraisable
    if _main_thread():
        for s in SIGNALS:
            if signal.getsignal(s) is not signal.SIG_IGN:  # nohup, or a shell's & job: kept
                signal.signal(s, _handler)


def signal_received() -> int | None:
    """The first stop signal received, or None."""
    return _received[0] if _received else None


def exit_code() -> int:
    """128 + the first stop signal received (130 for Ctrl-C if none was)."""
    return 128 + (signal_received() or signal.SIGINT)


@contextlib.contextmanager
def deferred():
    """Inside, a stop signal is noted (:func:`signal_received`) instead of raised. The handlers
    are (re)installed on entry: the libraries imported since may have replaced them."""
    if not _main_thread():
        yield
        return
    previous = [signal.getsignal(s) for s in SIGNALS]
    for s, handler in zip(SIGNALS, previous, strict=True):
        if handler is not signal.SIG_IGN:
            signal.signal(s, _handler)
    _depth[0] += 1
    try:
        yield
    finally:
        _depth[0] -= 1
        for s, handler in zip(SIGNALS, previous, strict=True):
            if handler is not None:
                signal.signal(s, handler)


@contextlib.contextmanager
def call():
    """A library call (``rodfem.simulate``) that a signal may stop: a signal received during
    it concerns it alone, so the next call starts as if none had come. The handlers are
    restored on the way out by :func:`deferred`. Under a launcher, PETSc is started here on
    every rank (:func:`rodfem.parallel.start`)."""
    parallel.start()
    _depth_calls[0] += 1
    try:
        yield
    finally:
        _depth_calls[0] -= 1
        if _depth_calls[0] == 0:
            _received.clear()


def requested(comm, n: int, every: int, also: bool = False) -> bool:
    """Whether to stop after step n: a stop signal was received (or ``also``, e.g. a write
    failed). Under MPI every rank must answer alike, so the ranks agree (one reduction) every
    ``every`` steps only."""
    local = bool(_received) or also
    if comm.size == 1:
        return local
    from mpi4py import MPI

    return n % every == 0 and comm.allreduce(local, op=MPI.LOR)


def agreed(comm) -> int | None:
    """The stop signal that any rank of ``comm`` received, or None: every rank answers alike (one
    reduction), and a rank that received none notes it as received, so that it stops alike.
    For the phases after a command's runs (an analysis, its files, its figures), which run
    inside :func:`deferred` and check here between one and the next."""
    signum = signal_received() or 0
    if comm.size > 1:
        from mpi4py import MPI

        signum = comm.allreduce(signum, op=MPI.MAX)
    if signum and not _received:
        _received.append(signum)
    return signum or None


def stop_if_received(comm) -> None:
    """Raise :class:`Interrupted` on every rank if any rank of ``comm`` received a stop signal
    (:func:`agreed`)."""
    signum = agreed(comm)
    if signum is not None:
        raise Interrupted(signum)


def signal_behind(err: BaseException) -> int | None:
    """The stop signal that raised ``err``, or that a library turned into another error (an
    import of a compiled module reports "initialization failed"), or None."""
    seen = set()
    while err is not None and id(err) not in seen:
        if isinstance(err, Interrupted):
            return err.signum
        seen.add(id(err))
        err = err.__cause__ or err.__context__
    return signal_received()
