"""The time loops of ``direct`` and ``picard`` in compiled C (cffi): a block of steps per call,
the same algebra as the PETSc loops to round-off (Picard: the same iterations at every step).

``direct.py`` + ``direct.c`` and ``picard.py`` + ``picard.c`` are the two loops, on the base
class of ``loop.py``; ``contact.h`` (the contact laws), ``exchange.h`` (the heat-exchange laws)
and ``record.h`` (the raw history row) are shared by both, ``end.h`` (the eliminated massless end)
and ``band.h`` (the banded substitutions) are parts of ``direct.c``; ``build.py`` compiles, checks
and caches them. :func:`compiled_kind` says which loop a scene's run uses, :func:`loop_name` names
it (what a run records, and ``rodfem resume`` compares), :func:`ready` builds it on every rank
before a run starts, and :func:`compiled_loop` makes it.

A run's loop is the compiled one wherever it applies (:func:`compiled_kind`), the PETSc loop
elsewhere and with ``RODFEM_KERNEL=0``. The two agree to round-off, not bit for bit, so where the
compiled loop applies and cannot be built a run is refused (:class:`KernelUnavailable`), never
switched to the PETSc loop unasked.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from rodfem.solver.errors import KernelUnavailable

if TYPE_CHECKING:
    from mpi4py import MPI

PETSC = "petsc"  # loop_name of the PETSc loop
UNRECORDED = "unrecorded"  # the loop of the steps of a checkpoint that does not say


def compiled_kind(scene, method: str | None = None) -> str | None:
    """The compiled loop a run of ``scene`` uses (with its ``solver.method``, or ``method``),
    ``"direct"`` or ``"picard"``, or None where it keeps the PETSc loop: RODFEM_KERNEL=0 in the
    environment, sources (the manufactured scene), Newton, Picard with a = 0 or a rigid
    obstacle, and an eliminated massless end with the power law (:func:`.loop.end_supported`)."""
    from rodfem.model.contact import of_scene
    from rodfem.solver.methods.massless import eliminated

    if os.environ.get("RODFEM_KERNEL", "1") == "0":
        return None
    if any(scene.source_term(name) is not None for name in ("heat", "momentum")):
        return None
    law = of_scene(scene)
    if eliminated(scene) and not (law.rigid or law.name == "linear"):
        return None
    method = method or scene["solver.method"]
    if method == "direct":
        return "direct"
    if method == "picard" and scene["model.a"] != 0.0 and not law.rigid:
        return "picard"
    return None


def _module(kind: str):
    from rodfem.solver.compiled import direct, picard

    return direct if kind == "direct" else picard


def loop_name(scene) -> str:
    """The loop a run of ``scene`` takes its steps with: ``"compiled direct <digest>"``,
    ``"compiled picard <digest>"`` (the digest of what decides its arithmetic: the C sources,
    the flags and the compiler, :func:`.build.arithmetic_digest`) or ``"petsc"``. Two runs with
    the same name take the same steps bit for bit. Builds nothing."""
    kind = compiled_kind(scene)
    if kind is None:
        return PETSC
    return f"compiled {kind} {_module(kind)._source.arithmetic()}"


def ready(scene, comm: MPI.Comm) -> None:
    """Build (or load, checked) the compiled loop a run of ``scene`` uses, on every rank of
    ``comm``; :class:`KernelUnavailable` on every rank if some rank cannot."""
    ready_for({compiled_kind(scene)}, comm)


def ready_for(kinds, comm: MPI.Comm) -> None:
    """:func:`ready` for the scenes whose :func:`compiled_kind` are ``kinds`` (the same on every
    rank; None among them is the PETSc loop's)."""
    for kind in sorted(k for k in kinds if k is not None):
        _agreed(_module(kind), comm)


def _agreed(module, comm: MPI.Comm) -> None:
    """Every rank runs the same loop (the same arithmetic, the same failures)."""
    try:
        module._source.library()
        reason = None
    except RuntimeError as error:
        reason = str(error)
    reasons = [r for r in comm.allgather(reason) if r is not None]
    if reasons:
        raise KernelUnavailable(reasons[0])


def compiled_loop(method, history, compress: bool = True):
    """The compiled time loop of the direct method (:mod:`.direct`) or of Picard's
    (:mod:`.picard`) where it applies (:func:`compiled_kind`), else None: the same steps, a block
    of them per C call, to round-off (Picard: the same iterations).
    :class:`KernelUnavailable` where it applies and cannot be built on every rank.
    ``compress=False``: the loop reads a coefficient row per node, not tables of the distinct
    rows (the same steps bit for bit, quicker to build: for a loop that takes a step or two)."""
    kind = compiled_kind(method.disc.scene, method.name)
    if kind is None:
        return None
    module = _module(kind)
    _agreed(module, method.disc.comm)
    cls = module.DirectKernel if kind == "direct" else module.PicardKernel
    return cls(method, history, compress=compress)


def loops_of(meta: dict | None, step: int, name: str) -> list:
    """The loops that made a run's steps (:func:`loop_name`), each with the step it began at,
    for a run whose steps from ``step`` on are made by ``name``: ``[[step, name]]`` for a new
    run (``meta`` None); for one resumed from a checkpoint of metadata ``meta``, its loops, and
    ``name`` from ``step`` on where it is another (``rodfem resume --any-loop``;
    :mod:`rodfem.output.resume` refuses it otherwise). A checkpoint of an earlier rodfem records
    none: its steps are ``unrecorded``."""
    if meta is None:
        return [[step, name]]
    loops = [list(entry) for entry in meta.get("loops") or [[0, UNRECORDED]]]
    if loops[-1][1] != name:
        loops.append([step, name])
    return loops
