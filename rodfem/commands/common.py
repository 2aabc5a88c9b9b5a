"""What every subcommand shares: its exit codes and the one line it says.

Exit codes: 0 complete; 2 bad input (nothing written); 3 a step could not be taken: the method
did not converge, or the values overflowed (the steps before it kept); 4 a file could not be
written, e.g. a full disk (the files stay whole, up to the last checkpoint); 128 + the signal's
number when stopped by a signal: 130 Ctrl-C (SIGINT), 143 SIGTERM, 129 SIGHUP, 138 SIGUSR1.
"""

from __future__ import annotations

import sys

EXIT_INPUT, EXIT_DIVERGED, EXIT_IO = 2, 3, 4


def say(message: str, stream=None) -> None:
    """Print one line, once (on rank 0), to stderr unless a stream is given."""
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(message, file=stream or sys.stderr, flush=True)
