"""``rodfem prepare``: what a scene's first run on a machine would compile, compiled ahead.

A first run builds the compiled time loops (C, with cffi), compiles its forms (FFCx, through
dolfinx) and assembles its operators: 3–6 s before its first step, where a second run of the same
scene starts in a fraction of a second. ``rodfem prepare`` runs each scene named (by default
every built-in one) for three steps, with fixed and with adaptive steps, into a temporary
directory, so that all three land in the per-user caches (``~/.cache/rodfem`` and FFCx's
``~/.cache/fenics``, or under ``$XDG_CACHE_HOME``); ``make setup`` runs it, so that a user's first
run of a built-in scene compiles nothing. A scene of one's own shares the loops and, where its
physics is a built-in scene's, the forms; its operators are assembled on its first run (or name
it: ``rodfem prepare my.toml``). The manufactured scenes' adaptive steps still form each new step
size's operators through dolfinx, compiling as they go.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

from rodfem.commands.common import EXIT_DIVERGED, say

STEPS = 3  # enough to take the first step and the loop's own: a contact-free start is fine


def prepare(args: argparse.Namespace) -> int:
    from rodfem.scene import BUILTIN, EXTRA, load

    names = args.scenes or [*BUILTIN, *EXTRA]
    scenes = [load(name, []) for name in names]  # every name checked before any run
    from mpi4py import MPI

    from rodfem.api import simulate
    from rodfem.solver.compiled import KernelUnavailable, ready

    comm = MPI.COMM_WORLD
    started = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="rodfem-prepare-")) if comm.rank == 0 else None
    work = comm.bcast(work, root=0)
    try:
        for name, scene in zip(names, scenes):
            begun = time.perf_counter()
            for adaptive in (False, True):  # what each kind of step adds (the step family's)
                short = load(name, [f"time.end={STEPS * scene['time.dt']!r}",
                                    f"time.adaptive={str(adaptive).lower()}"])
                try:
                    ready(short, comm)
                except KernelUnavailable as err:
                    say(err.line())
                    return EXIT_DIVERGED
                with warnings.catch_warnings():  # three steps may be coarse for the contact
                    warnings.simplefilter("ignore")
                    result = simulate(short, out=work / Path(name).stem, comm=comm, force=True)
                if result.status != "complete":
                    say(f"rodfem: error: {name}: its first {STEPS} steps ended {result.status}")
                    return EXIT_DIVERGED
            if not args.quiet:
                say(f"prepared {name} ({time.perf_counter() - begun:.1f} s)", sys.stdout)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(work, ignore_errors=True)
    if not args.quiet:
        from rodfem.discrete.cache import cache_directory

        say(f"rodfem: the compiled loops, forms and operators of {len(names)} scene"
            f"{'s' if len(names) != 1 else ''} are in the caches under {cache_directory().parent}"
            f" ({time.perf_counter() - started:.1f} s)", sys.stdout)
    return 0
