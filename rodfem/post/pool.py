"""Figures drawn by worker processes, while the caller goes on (``rodfem paper`` runs the next
experiment as the last one's figures are drawn), and by the caller once it has nothing else to do.

Drawing is software rendering (VTK through Mesa, matplotlib's Agg) on one core per process: the
figures of a run are independent, and the caller and one worker per other CPU draw them side by
side (a worker costs a second of start-up: not one more than the CPUs can keep busy).

A worker is a fresh ``python -m rodfem.post.pool``, not a fork nor multiprocessing's spawn: the
caller may hold MPI and PETSc, which a forked child must not touch, and spawn would run the
caller's main script again in every worker (a script without ``if __name__ == "__main__"``
would start workers without end). The worker imports the figure modules only (about a second),
without the launcher's MPI variables (so that it never joins the caller's job), reads pickled
:class:`~rodfem.post.tasks.Task`\\ s on stdin and answers each with the file written or the
exception raised. It ignores Ctrl-C, which reaches the whole process group: the caller stops it
by closing its stdin.
"""

from __future__ import annotations

import os
import pickle
import queue
import signal
import subprocess
import sys
import threading
from concurrent.futures import Future

from rodfem.post.tasks import Task

# The variables by which Open MPI, MPICH and PMIx tell a process it is a rank of a job.
MPI_PREFIXES = ("OMPI_", "PMIX_", "PMI_", "MPICH_", "HYDRA_", "PRTE_")


def cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


class Drawer:
    """A pool of drawing processes: ``with Drawer(1) as d: futures = d.submit(tasks)``; leaving
    the block draws the figures still queued here too (:meth:`work`) and waits for them all
    (after an exception: for those begun only)."""

    def __init__(self, workers: int):
        self._tasks: queue.Queue = queue.Queue()
        self._stopping = False
        env = {k: v for k, v in os.environ.items() if not k.startswith(MPI_PREFIXES)}
        self._processes = [
            subprocess.Popen([sys.executable, "-m", "rodfem.post.pool"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, env=env)
            for _ in range(max(0, workers))
        ]
        self._threads = [threading.Thread(target=self._feed, args=(p,), daemon=True)
                         for p in self._processes]
        for thread in self._threads:
            thread.start()

    def submit(self, tasks: list[Task]) -> list[Future]:
        """Queue the figures; each future's result is the file written (or the exception)."""
        futures = []
        for task in tasks:
            future: Future = Future()
            self._tasks.put((task, future))
            futures.append(future)
        return futures

    def _feed(self, process: subprocess.Popen) -> None:
        """Hand one worker the queued figures, one at a time, until the pool closes."""
        while True:
            item = self._tasks.get()
            if item is None:
                break
            task, future = item
            if self._stopping:
                future.cancel()
            if not future.set_running_or_notify_cancel():
                continue
            try:
                pickle.dump(task, process.stdin)
                process.stdin.flush()
                ok, value = pickle.load(process.stdout)
            except (OSError, EOFError, pickle.UnpicklingError):
                future.set_exception(RuntimeError(f"a drawing process ended while drawing "
                                                  f"{task.path.name}"))
                continue
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)
        try:
            process.stdin.close()  # the worker's end of input: it returns
        except OSError:  # it is gone already
            pass
        process.wait()

    def work(self) -> None:
        """Draw queued figures in this process as well, until the queue is empty. A stop signal
        is taken between two figures (raised as :class:`~rodfem.output.interrupts.Interrupted`):
        raised inside the drawing, it could land in a destructor of VTK's, which ignores it."""
        from rodfem.output import interrupts
        from rodfem.post.tasks import draw

        while True:
            try:
                item = self._tasks.get_nowait()
            except queue.Empty:
                return
            task, future = item
            if future.set_running_or_notify_cancel():
                with interrupts.deferred():
                    try:
                        future.set_result(draw(task))
                    except Exception as err:  # noqa: BLE001 (raised by future.result())
                        future.set_exception(err)
            if interrupts.signal_received() is not None:
                raise interrupts.Interrupted(interrupts.signal_received())

    def close(self, cancel: bool = False) -> None:
        """Draw and wait for the figures queued (``cancel``: only wait for those begun), end the
        workers."""
        self._stopping = cancel
        if not cancel:
            self.work()
        for _ in self._threads:
            self._tasks.put(None)
        for thread in self._threads:
            thread.join()

    def cancel(self) -> None:
        """Drop the figures not begun; wait for those begun (each is written whole)."""
        self.close(cancel=True)

    def __enter__(self) -> Drawer:
        return self

    def __exit__(self, kind, error, trace) -> None:
        self.close(cancel=error is not None)


def _serve() -> None:
    """A worker: draw each task read from stdin, answer (True, path) or (False, exception)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    answers = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # anything a library prints goes to stderr, not into the answers
    tasks = sys.stdin.buffer
    from rodfem.post.tasks import draw

    while True:
        try:
            task = pickle.load(tasks)
        except EOFError:
            return
        try:
            answer = (True, draw(task))
        except Exception as err:  # noqa: BLE001 (handed to the caller, which raises it)
            answer = (False, err)
        pickle.dump(answer, answers)
        answers.flush()


if __name__ == "__main__":
    _serve()
