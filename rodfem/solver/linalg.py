"""The PETSc side of the time loop: sequential vectors in blocks, and LU factorisations with
rodfem's default options (merged under the user's: PETSC_OPTIONS can override them). A method
whose operators are NumPy containers (:mod:`rodfem.discrete.arrays`: a serial run whose loop is
compiled) gets NumPy vectors and PETSc's LU done in NumPy, and imports no petsc4py."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete import arrays

if TYPE_CHECKING:
    from petsc4py import PETSc

# In node order the operators are tridiagonal, so LU in the natural ordering has no fill; the
# coupled operator [[A_h, −N_U], [−N_Θ, A_m]] is banded after reverse Cuthill–McKee.
LU_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "petsc",
    "pc_factor_mat_ordering_type": "natural",
}


def set_default_options(prefix: str, defaults: dict[str, str]) -> None:
    """Set PETSc options under ``prefix`` unless the user has set them."""
    from petsc4py import PETSc

    options = PETSc.Options()
    for key, value in defaults.items():
        if not options.hasName(prefix + key):
            options[prefix + key] = value


def lu_factor(A: PETSc.Mat, prefix: str, ordering: str = "natural"):
    """Factor A once (KSP preonly + LU, options under ``prefix``). Returns the KSP, which owns the
    factorisation, and the factor, whose ``solve`` is a plain forward/back substitution. A NumPy
    matrix is made a PETSc one first."""
    from petsc4py import PETSc

    if isinstance(A, arrays.Matrix):
        A = A.petsc()
    set_default_options(prefix, {**LU_OPTIONS, "pc_factor_mat_ordering_type": ordering})
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setFromOptions()
    ksp.setUp()
    return ksp, ksp.getPC().getFactorMatrix()


def lu_solver(A: PETSc.Mat, prefix: str):
    """``solve(b, x)`` by A's LU (:func:`lu_factor`), factored on the first solve: a method whose
    steps its compiled loop takes never needs it (an adaptive run makes one for each step
    size). A NumPy matrix is factored as PETSc would, in NumPy (:class:`arrays.NaturalLU`),
    unless the user may have set PETSc options (:func:`options_set`)."""
    if isinstance(A, arrays.Matrix):
        if not options_set():
            made_here = []

            def solve_here(b, x) -> None:
                if not made_here:
                    made_here.append(arrays.NaturalLU(A))
                made_here[0].solve(b, x)

            return solve_here
        A = A.petsc()
    made = []

    def solve(b: PETSc.Vec, x: PETSc.Vec) -> None:
        if not made:
            made.extend(lu_factor(A, prefix))  # the KSP (which owns the factor) and the factor
        made[1].solve(*(arrays.petsc_vector(v) if isinstance(v, arrays.Vector) else v
                        for v in (b, x)))

    return solve


def options_set() -> bool:
    """Whether the user may have set PETSc options, which rodfem's defaults give way to: in
    PETSC_OPTIONS (beyond the ``-no_signal_handler`` rodfem's command puts there:
    :func:`rodfem.output.interrupts.install`), or in the files PETSc reads (~/.petscrc,
    ./.petscrc, ./petscrc)."""
    if set(os.environ.get("PETSC_OPTIONS", "").split()) - {"-no_signal_handler"}:
        return True
    return any(os.path.exists(path) for path in (os.path.expanduser("~/.petscrc"), ".petscrc",
                                                  "petscrc"))


def stacked(parts: int, n: int, petsc: bool = True):
    """A sequential vector of ``parts`` blocks of length n, and a vector for each block that
    shares its memory: PETSc's, or with ``petsc=False`` NumPy's (:mod:`rodfem.discrete.arrays`)."""
    if not petsc:
        return arrays.stacked(parts, n)
    from petsc4py import PETSc

    array = np.zeros(parts * n)
    wrap = lambda a: PETSc.Vec().createWithArray(a, comm=PETSc.COMM_SELF)  # noqa: E731
    return wrap(array), [wrap(array[i * n:(i + 1) * n]) for i in range(parts)]



def free_garbage(comm) -> None:
    """Destroy now the PETSc objects of ``comm`` (and of this process alone) that nothing
    references any more. petsc4py (3.18 on) does not destroy an object when its last reference
    goes, since destroying a parallel object is collective: it keeps it for a collective
    ``garbage_cleanup``. Without one, a sweep of 10⁴ paper1 scenes grew to 5 GB. Collective on
    ``comm``. Nothing to do in a process that has not loaded petsc4py."""
    if comm.size == 1 and "petsc4py.PETSc" not in sys.modules:
        return
    from petsc4py import PETSc

    PETSc.garbage_cleanup(PETSc.COMM_SELF)
    if comm.size > 1:
        PETSc.garbage_cleanup(comm)
