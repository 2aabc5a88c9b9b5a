"""MPI's world, started where it is needed: a command's process that no launcher started is MPI's
only process, and a run of it that finds its operators cached needs no MPI at all.

:func:`world` is MPI's ``COMM_WORLD`` in a process a launcher started (mpirun, mpiexec, srun:
:data:`LAUNCHED`) or one that has started MPI already (``mpi4py.MPI`` imported: dolfinx does);
in any other process it is :data:`SERIAL`, a world of one process that answers what rodfem asks
of a communicator (rank, size, the collectives of Python objects) without MPI, and starts MPI for
anything else (:meth:`Serial.__getattr__`). ``MPI_Init`` is 20–30 ms of a small run's start.
Where a library needs a real communicator (dolfinx's mesh), :func:`real` gives it.
"""

from __future__ import annotations

import os
import pickle
import sys

# The variables a launcher sets in the processes it starts (Open MPI, PMIx, MPICH/Hydra, Intel).
LAUNCHED = ("OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALRANKID")


def _copy(obj):
    """What a process receives of ``obj`` through MPI: a copy, pickled (as mpi4py sends it)."""
    return pickle.loads(pickle.dumps(obj, pickle.HIGHEST_PROTOCOL))


class Serial:
    """The world of a process that is MPI's only one, as mpi4py's lower-case collectives see it:
    rank 0 of 1, every collective of Python objects the identity (on a copy, as mpi4py's)."""

    rank = 0
    size = 1

    def Get_rank(self) -> int:  # noqa: N802 (mpi4py's names)
        return 0

    def Get_size(self) -> int:  # noqa: N802
        return 1

    def bcast(self, obj, root: int = 0):
        return _copy(obj)

    def allgather(self, obj) -> list:
        return [_copy(obj)]

    def gather(self, obj, root: int = 0) -> list:
        return [_copy(obj)]

    def allreduce(self, obj, op=None):
        return _copy(obj)

    def barrier(self) -> None:
        pass

    Barrier = barrier

    def __getattr__(self, name: str):
        """Anything else is MPI's own (MPI started)."""
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(real(self), name)

    def __repr__(self) -> str:
        return "<rodfem.parallel.SERIAL: one process, MPI not started>"


SERIAL = Serial()


def launched() -> bool:
    """Whether a launcher started this process."""
    return any(name in os.environ for name in LAUNCHED)


def start() -> None:
    """Start PETSc on every process of a launched world of more than one, here and together.

    PETSc's start (``PetscInitialize``) is collective over MPI's world. Left to the first use,
    it happens where one rank's run first needs PETSc (its operators not cached, say) and not
    where another's does: that rank then waits for ever for the others. So the entries of rodfem
    (the command line, the library's calls, :func:`world`), which every rank passes alike,
    start it first; in a process no launcher started this is free (nothing imported)."""
    if launched() and "petsc4py.PETSc" not in sys.modules:
        from mpi4py import MPI

        if MPI.COMM_WORLD.size > 1:
            from petsc4py import PETSc  # noqa: F401 (collective: every rank, at this point)


def world():
    """MPI's COMM_WORLD where MPI is (or must be) started, else :data:`SERIAL`."""
    if "mpi4py.MPI" in sys.modules or launched():
        start()
        from mpi4py import MPI

        return MPI.COMM_WORLD
    return SERIAL


def real(comm):
    """``comm``, or for :data:`SERIAL` MPI's COMM_WORLD (MPI started): for libraries that take
    an MPI communicator."""
    if isinstance(comm, Serial):
        from mpi4py import MPI

        return MPI.COMM_WORLD
    return comm
