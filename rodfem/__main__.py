"""``rodfem`` (the console script) and ``python -m rodfem``: the signal handlers first, before
anything heavy is imported, so that Ctrl-C or SIGTERM at any point of start-up is one line."""

import os
import sys

from rodfem.output.interrupts import LAUNCHED


def single_process_mpi() -> None:
    """A ``rodfem`` not started by a launcher is MPI's only process: Open MPI then needs no
    interconnect, yet initialising UCX, its default messaging layer, takes 0.2 s of a 0.3 s
    MPI_Init, the largest part of a small run's start; and a singleton starts a daemon of its
    own (``orted``) for the processes it might spawn, which rodfem never does: 0.1 s more. Such
    a process uses Open MPI's ob1 layer and no daemon (MPI_Init in about 25 ms), unless
    ``OMPI_MCA_pml`` or ``OMPI_MCA_ess_singleton_isolated`` is set already. Processes under a
    launcher keep Open MPI's choice; other MPIs ignore the variables. Only the command does this,
    not ``import rodfem``: a user's script may start mpirun itself, whose processes would inherit
    the variables."""
    if "mpi4py.MPI" in sys.modules or any(name in os.environ for name in LAUNCHED):
        return
    os.environ.setdefault("OMPI_MCA_pml", "ob1")
    os.environ.setdefault("OMPI_MCA_ess_singleton_isolated", "1")


def main() -> int:
    single_process_mpi()
    from rodfem.output import interrupts

    interrupts.install()
    try:
        from rodfem.cli import main as cli
    except Exception as err:  # noqa: BLE001 (a signal during the imports, or what it became)
        signum = interrupts.signal_behind(err)
        if signum is None:
            raise
        print(f"rodfem: {interrupts.Interrupted(signum)}; stopped during start-up, nothing "
              "written", file=sys.stderr)
        return 128 + signum
    code = cli()
    ending()
    return code


def ending() -> None:
    """The process ends after this: what it made is left to the interpreter's exit out of the
    reach of its cyclic garbage collection (``gc.freeze``), which at exit walks every object
    of every module imported, 25–35 ms of a small run's 0.25 s. Everything rodfem writes is
    closed by then; objects are freed by their reference counts as at any exit, and the C
    libraries' own exit handlers (HDF5's, MPI's through mpi4py) run as before."""
    import gc

    gc.freeze()


if __name__ == "__main__":
    sys.exit(main())
