"""The step family of a run's compiled loop (:mod:`.family`): the direct loop's
(:mod:`.family_direct`) or Picard's (:mod:`.family_picard`), or none."""

from __future__ import annotations

from rodfem.solver.compiled.laurent import read_parts


def step_family(home, history, kernel):
    """The :class:`StepFamily` of the home method and its compiled loop ``kernel``, or None
    (the module's docstring)."""
    from rodfem.solver.compiled.direct import DirectKernel
    from rodfem.solver.compiled.picard import PicardKernel

    if kernel is None:
        return None
    parts = read_parts(home)
    if parts is None:
        return None
    if isinstance(kernel, DirectKernel):
        from rodfem.solver.compiled.family_direct import DirectFamily

        return DirectFamily(home, history, kernel, parts)
    if isinstance(kernel, PicardKernel):
        from rodfem.solver.compiled.family_picard import PicardFamily

        return PicardFamily(home, history, kernel, parts)
    return None
