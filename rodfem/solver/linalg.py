"""The PETSc side of the time loop: sequential vectors in blocks, and LU factorisations with
rodfem's default options (merged under the user's: PETSC_OPTIONS can override them)."""

from __future__ import annotations

import numpy as np
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
    options = PETSc.Options()
    for key, value in defaults.items():
        if not options.hasName(prefix + key):
            options[prefix + key] = value


def lu_factor(A: PETSc.Mat, prefix: str, ordering: str = "natural"):
    """Factor A once (KSP preonly + LU, options under ``prefix``). Returns the KSP, which owns the
    factorisation, and the factor, whose ``solve`` is a plain forward/back substitution."""
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
    size)."""
    made = []

    def solve(b: PETSc.Vec, x: PETSc.Vec) -> None:
        if not made:
            made.extend(lu_factor(A, prefix))  # the KSP (which owns the factor) and the factor
        made[1].solve(b, x)

    return solve


def stacked(parts: int, n: int) -> tuple[PETSc.Vec, list[PETSc.Vec]]:
    """A sequential vector of ``parts`` blocks of length n, and a vector for each block that
    shares its memory."""
    array = np.zeros(parts * n)
    wrap = lambda a: PETSc.Vec().createWithArray(a, comm=PETSc.COMM_SELF)  # noqa: E731
    return wrap(array), [wrap(array[i * n:(i + 1) * n]) for i in range(parts)]



def free_garbage(comm) -> None:
    """Destroy now the PETSc objects of ``comm`` (and of this process alone) that nothing
    references any more. petsc4py (3.18 on) does not destroy an object when its last reference
    goes, since destroying a parallel object is collective: it keeps it for a collective
    ``garbage_cleanup``. Without one, a sweep of 10⁴ paper1 scenes grew to 5 GB. Collective on
    ``comm``."""
    PETSc.garbage_cleanup(PETSc.COMM_SELF)
    if comm.size > 1:
        PETSc.garbage_cleanup(comm)
