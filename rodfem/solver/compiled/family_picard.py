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
        self.F, self.template, self.size = self._family(kernel)
        self.struct_size = kernel._ffi.sizeof("pk_problem")

    def _family(self, kernel):
        """The pk_family of the parts (kept alive here) and the template pk_problem: the home
        loop's, with the classes of the rows from the parts."""
        ffi = kernel._ffi
        self._kept = kept = {
            "fixed_parts": np.ascontiguousarray(self.fixed),
            "coupling_parts": np.ascontiguousarray(self.coupling),
            "operator_parts": np.ascontiguousarray(np.concatenate(self.A, axis=1).reshape(3, -1)),
            "fixed_class": np.ascontiguousarray(self.fixed_class, dtype=np.intc),
            "coupling_class": np.ascontiguousarray(self.coupling_class, dtype=np.intc),
        }
        F = ffi.new("pk_family *")
        F.n = self.n
        F.fixed_classes, F.coupling_classes = self.fixed.shape[1], self.coupling.shape[1]
        for field in ("fixed_parts", "coupling_parts", "operator_parts"):
            setattr(F, field, ffi.cast("double *", ffi.from_buffer(kept[field])))
        template = ffi.new("pk_problem *")
        ffi.memmove(template, kernel._problem, ffi.sizeof("pk_problem"))
        for field in ("fixed_class", "coupling_class"):
            setattr(template, field, ffi.cast("int *", ffi.from_buffer(kept[field])))
        template.blocks = self.blocks
        return F, template, int(kernel._lib.pk_form_size(F))

    @property
    def forms_in_c(self) -> bool:
        return not self.home.exchange.variable  # v = A_h⁻¹ e is solved here, in NumPy

    def _form(self, loop, lam: float) -> None:
        kernel = self.kernel
        ffi = kernel._ffi
        memory = np.empty(self.size)
        P = ffi.new("pk_problem *")
        ffi.memmove(P, self.template, self.struct_size)
        info = kernel._lib.pk_form(self.F, lam, P, ffi.cast("double *", ffi.from_buffer(memory)))
        if info:
            raise ValueError(f"zero pivot at node {info - 1} factoring without pivoting")
        loop._arrays = {"memory": memory}
        if self.home.exchange.variable:  # v = A_h⁻¹ e
            from scipy.linalg import solve_banded

            v = np.ascontiguousarray(solve_banded(
                (1, 1), self.first_step_operators(lam)["A"], self.e))
            loop._arrays["unit_response"] = v
            P.unit_response = ffi.cast("double *", ffi.from_buffer(v))
        loop._problem = P
        loop._pressure = ffi.new("double *")
        loop._iterations = ffi.new("int *")
        loop._increment = ffi.new("double *")
        loop._last_u_1 = ffi.new("double *")
