"""What every subcommand shares: its exit codes and the one line it says.

Exit codes: 0 complete; 2 bad input (nothing written); 3 a step could not be taken: the method
did not converge, the values overflowed, or adaptive steps needed one below time.dt_min (the steps
before it kept); 4 a file could not be
written, e.g. a full disk (the files stay whole, up to the last checkpoint); 128 + the signal's
number when stopped by a signal: 130 Ctrl-C (SIGINT), 143 SIGTERM, 129 SIGHUP, 138 SIGUSR1.
"""

from __future__ import annotations

import sys

EXIT_INPUT, EXIT_DIVERGED, EXIT_IO = 2, 3, 4


def say(message: str, stream=None) -> None:
    """Print one line, once (on rank 0), to stderr unless a stream is given."""
    from rodfem.parallel import world

    if world().rank == 0:
        print(message, file=stream or sys.stderr, flush=True)


def said_cost(scene_of, count: int, yes: bool, quiet: bool, runs: int | None = None) -> None:
    """Say what a study of ``count`` scenes (``scene_of(i)``; ``runs``: at most so many runs of
    them) will cost, from ten minutes on (unless ``quiet``); SceneError (exit 2, one line, nothing
    written) beyond a day unless ``yes`` (:mod:`rodfem.studies.cost`)."""
    from mpi4py import MPI

    from rodfem.studies.cost import check

    found = check(scene_of, count, MPI.COMM_WORLD, yes, runs)
    if found is not None and not quiet:
        say(f"rodfem: {found.line()}")


def resume_as_written(args, out, marker: dict, what: str, complete, resume) -> int:
    """``rodfem resume`` of the directory ``out`` of a sweep or a study (``what``; held by this
    command, its ``marker`` read): ``--set`` refused, a complete one checked by ``complete()``
    and left as it is, any other continued by ``resume()``, which gives the exit code. A mistake
    either finds is one line and exit code 2."""
    from mpi4py import MPI

    from rodfem.output.directories import release
    from rodfem.scene import SceneError

    comm = MPI.COMM_WORLD
    if args.overrides:
        release(out, comm)
        say(f"rodfem: error: --set: a {what} resumes as it was written; {out} is a {what} "
            f"(change its file and run it again instead)")
        return EXIT_INPUT
    try:
        if marker.get("status") == "complete":  # nothing to do: a job script's resume is fine
            complete()
            release(out, comm)
            say(f"rodfem: {out} is a complete {what}; nothing was changed", sys.stdout)
            return 0
        return resume()
    except SceneError as err:
        release(out, comm)
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
