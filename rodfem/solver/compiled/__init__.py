"""The time loops of ``direct`` and ``picard`` in compiled C (cffi): a block of steps per call,
the same algebra as the PETSc loops to round-off (Picard: the same iterations at every step).

``direct.py`` + ``direct.c`` and ``picard.py`` + ``picard.c`` are the two loops, on the base
class of ``loop.py``; ``contact.h`` (the contact laws), ``exchange.h`` (the heat-exchange laws)
and ``record.h`` (the raw history row) are shared by both, ``end.h`` (the eliminated massless end)
and ``band.h`` (the banded substitutions) are parts of ``direct.c``; ``build.py`` compiles and
caches them. :func:`compiled_loop` picks the loop a run can use.
"""

from __future__ import annotations

import os
import sys

from mpi4py import MPI

_warned: dict[str, bool] = {}


def compiled_loop(method, history, compress: bool = True):
    """The compiled time loop of the direct method (:mod:`.direct`) or of Picard's
    (:mod:`.picard`) where it applies and can be built, else None: the same steps, a block of
    them per C call, to round-off (Picard: the same iterations). RODFEM_KERNEL=0 in the
    environment keeps the PETSc loop; so do sources (the manufactured scene), Newton, Picard
    with a = 0 or a rigid obstacle, and an eliminated massless end with the power law
    (:func:`.loop.end_supported`). ``compress=False``: the loop reads a coefficient row per node,
    not tables of the distinct rows (the same steps bit for bit, quicker to build: for a loop
    that takes a step or two)."""
    from rodfem.solver.compiled.loop import end_supported

    if os.environ.get("RODFEM_KERNEL", "1") == "0":
        return None
    if any(f is not None for f in method.sources.values()) or not end_supported(method):
        return None
    if method.name == "direct":
        from rodfem.solver.compiled import direct as module
    elif method.name == "picard" and method.coupled and not method.law.rigid:
        from rodfem.solver.compiled import picard as module
    else:
        return None
    # Every rank must run the same loop (the same arithmetic, the same failures).
    comm = method.disc.comm
    if not comm.allreduce(module.available(), op=MPI.LAND):
        if comm.rank == 0 and not _warned.get(module.__name__):
            _warned[module.__name__] = True
            reason = module.unavailable_reason() or "not built on every rank"
            print(f"rodfem: the compiled loop is not available ({reason}); using the PETSc "
                  "loop, the same steps, slower", file=sys.stderr)
        return None
    cls = module.DirectKernel if method.name == "direct" else module.PicardKernel
    return cls(method, history, compress=compress)
