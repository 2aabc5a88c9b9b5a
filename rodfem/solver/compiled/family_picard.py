"""The Picard loop's step family (:mod:`.family`): pk_problem for a step h from the parts.

Once per run: the tridiagonals (in node order) of R's blocks with b, of N_U, N_ΔΘ with e, and of
A_h and A_m, as parts; the classes of the rows of [R | b] and [N_U | N_ΔΘ | e] from the parts
stacked. For a size h, at λ = Δt₀/h: the tables combined, A_h and A_m factored by ``pk_factor``
(as :class:`~.picard.PicardKernel` does) and, for a variable exchange, v = A_h⁻¹ e: a new
``pk_problem`` whose other fields are the home loop's.
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.compiled.family import (Bound, StepFamily, heat_first_step, tabled,
                                           tridiagonal_parts)
from rodfem.solver.compiled.laurent import combine
from rodfem.solver.compiled.picard import PicardKernel

FIXED = ((0, 0, "heat.theta_prev"), (1, 0, "momentum.theta_prev"),
         (1, 1, "momentum.du_prev"), (1, 2, "momentum.u_prev"))


class FamilyPicard(Bound, PicardKernel):
    """A :class:`~.picard.PicardKernel` of a step h bound to the home method (:mod:`.family`)."""

    what = "compiled Picard loop"


class PicardFamily(StepFamily):
    """The Picard loops of any size of one run (the module's docstring)."""

    bound = FamilyPicard

    def __init__(self, home, history, kernel: PicardKernel, parts):
        super().__init__(home, history, kernel, parts)
        n = self.n = kernel.n
        fixed = np.zeros((3, n, 20))
        for c, k, key in FIXED:
            fixed[:, :, 10 * c + 3 * k:10 * c + 3 * k + 3] = tridiagonal_parts(parts, key, n)
        fixed[:, :, 9] = parts.vector("heat.b")
        fixed[:, :, 19] = parts.vector("momentum.b")
        coupling = np.zeros((3, n, 8))
        coupling[:, :, 0:3] = tridiagonal_parts(parts, "heat.du", n)
        coupling[:, :, 3:6] = tridiagonal_parts(parts, "momentum.dtheta", n)
        coupling[:, :, 6] = parts.vector("contact.e")
        self.blocks = [int(np.any(fixed[:, :, 10 * c + 3 * k:10 * c + 3 * k + 3] != 0.0))
                       for c in range(2) for k in range(3)]
        self.fixed_class, tables = tabled({"fixed": fixed})
        self.fixed = tables["fixed"]
        self.coupling_class, tables = tabled({"coupling": coupling})
        self.coupling = tables["coupling"]
        # A_h and A_m as pk_factor reads them: 3 × (lower, diagonal, upper) × n
        self.A = [np.ascontiguousarray(tridiagonal_parts(parts, key, n).transpose(0, 2, 1))
                  for key in ("heat.A", "momentum.A")]
        self.e = combine(parts.vector("contact.e"), 1.0)
        self.first_step_operators = heat_first_step(parts, n) \
            if kernel.first_step_special or home.exchange.variable else None

    def _form(self, loop, lam: float) -> None:
        kernel, n = self.kernel, self.n
        ffi, lib = kernel._ffi, kernel._lib
        factors = []
        for A, ul in zip(self.A, (0, 1)):
            tri = combine(A, lam)
            out = np.zeros((n, 3))
            info = lib.pk_factor(n, *(ffi.cast("double *", ffi.from_buffer(tri[t]))
                                      for t in range(3)), ul,
                                 ffi.cast("double *", ffi.from_buffer(out)), 3)
            if info:
                raise ValueError(f"zero pivot at node {info - 1} factoring without pivoting")
            factors.append(out)
        heat, momentum = factors
        arrays = {
            "fixed_class": self.fixed_class,
            "fixed": np.ascontiguousarray(combine(self.fixed, lam)),
            "coupling_class": self.coupling_class,
            "coupling": np.ascontiguousarray(combine(self.coupling, lam)),
            "descending": np.ascontiguousarray(
                np.column_stack([heat[:, 2], momentum[:, 0], momentum[:, 1]])),
            "ascending": np.ascontiguousarray(
                np.column_stack([momentum[:, 2], heat[:, 0], heat[:, 1]])),
            "work": np.zeros(10 * (n + 2)),
        }
        if self.home.exchange.variable:  # v = A_h⁻¹ e
            from scipy.linalg import solve_banded

            arrays["unit_response"] = np.ascontiguousarray(solve_banded(
                (1, 1), self.first_step_operators(lam)["A"], self.e))
        P = ffi.new("pk_problem *")
        ffi.memmove(P, kernel._problem, ffi.sizeof("pk_problem"))
        for field, array in arrays.items():
            kind = "int" if field.endswith("_class") else "double"
            setattr(P, field, ffi.cast(kind + " *", ffi.from_buffer(array)))
        P.blocks = self.blocks
        loop._arrays = {**kernel._arrays, **arrays}
        loop._problem = P
        loop._pressure = ffi.new("double *")
        loop._iterations = ffi.new("int *")
        loop._increment = ffi.new("double *")
        loop._last_u_1 = ffi.new("double *")
