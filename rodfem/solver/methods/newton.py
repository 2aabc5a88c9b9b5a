"""Newton's method: each step of (3.1)–(3.2) solved monolithically by PETSc SNES.

The unknown is [ΔΘⁿ; ΔUⁿ] and the residual is the coupled scheme with its contact term,

    F(x) = C x − [h; m] + p(x) [0; e],   p(x) the contact force at Uⁿ(1) = Uⁿ⁻¹(1) + x_U(1),

with C the coupled operator (:meth:`Method.coupled_operator`) and p the obstacle's law at the time
scheme's rule, e.g. (1/ε)[Uⁿ(1) − g]_+. The Jacobian is C plus the law's generalized derivative
(:meth:`rodfem.solver.time_schemes.TimeScheme.contact_slope`: 1/ε where the rod penetrates and 0
elsewhere for the paper's law, m[·]₊^{m−1}/ε for the power law) in the one diagonal entry of
x = 1: a semismooth Newton method, which for the paper's law ends in finitely many iterations with
the exact solution of the step. The rigid obstacle is a variational inequality, solved by PETSc's
reduced-space active-set method ``vinewtonrsls`` with the bound ΔUⁿ(1) ≤ g − Uⁿ⁻¹(1); the
contact force is the multiplier −F_U(1).

A variable heat exchange (:mod:`rodfem.model.exchange`) adds φ = q (Θⁿ⁻¹(1) + w x_Θ(1) + offset)
to the heat row of x = 1, q the law at the time scheme's place of Uⁿ(1) and the step's contact
force p (for the rigid obstacle its multiplier, −F_U(1) without the bound: the multiplier at the
solution). The Jacobian gains in that row w q in the column of Θ(1) and (∂q/∂y ∂place/∂y +
∂q/∂p dp/dy) T in the column of U(1) (T = Θ(1) at the weight, plus the offset), or along the
row of an eliminated end's free position: with the contact's slope, a change of rank two of C,
solved by Woodbury's formula with C's LU and C⁻¹[e_Θ(1), e_U(1)] (once per run).

A step has converged when ‖F‖ reaches the round-off of its own evaluation, componentwise:
64 ε_mach ‖ |C| |x| + |[h; m]| + |φ| ‖ (the exchange's |q| (|Θⁿ⁻¹(1)| + w |x_Θ(1)| + |offset|) in
the heat row of x = 1; a norm bound such as ‖C‖_F ‖x‖ grows like n^1.5 and, at 10⁶ cells,
accepted a wrong first guess without an iteration). The converged reason is checked after every
step, and any other outcome stops the run (exit code 3). The first guess is the last step's
increment.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from rodfem.discrete.discretisation import Discretisation
from rodfem.solver.errors import NotConverged, NotFinite
from rodfem.solver.linalg import LU_OPTIONS, lu_factor, set_default_options, stacked
from rodfem.solver.methods.base import Method

REASONS = {getattr(PETSc.SNES.ConvergedReason, name): name
           for name in dir(PETSc.SNES.ConvergedReason) if name.isupper()}
ROUNDOFF = 64 * np.finfo(float).eps
PREFIX = "rodfem_newton_"


class NewtonMethod(Method):
    name = "newton"

    def __init__(self, disc: Discretisation, dt: float | None = None):
        super().__init__(disc, dt)
        n = disc.nodes.size
        self.C = self.coupled_operator()
        self.C_last = self.C.getValue(self._index, self._index)
        self.J = self.C.duplicate(copy=True)
        indptr, indices, values = self.C.getValuesCSR()
        self.C_abs = PETSc.Mat().createAIJ(size=self.C.getSize(), comm=PETSc.COMM_SELF,
                                           csr=(indptr, indices, np.abs(values)))
        self.x, (self.x_heat, self.x_momentum) = stacked(2, n)
        self.rhs = self.x.duplicate()
        self._abs_x, self._abs_rhs, self._bound = (self.x.duplicate() for _ in range(3))

        # Defaults that hold for every scene go to the options database (where PETSC_OPTIONS can
        # override them); the scene's own choices are set on the object, before the options.
        set_default_options(PREFIX, {"snes_linesearch_type": "basic", **LU_OPTIONS,
                                     "pc_factor_mat_ordering_type": "rcm"})
        # The law of the step's contact: the obstacle's at Uⁿ(1), or for an eliminated end
        # (massless.MasslessEnd) the obstacle in series with the last cell at its free position
        # y, a linear function of x whose row enters the Jacobian's row of x = 1.
        end = self.massless
        self.step_law = self.law if end is None else end.law
        self.rigid = self.step_law.rigid
        if end is not None:
            self._end_columns = np.flatnonzero(end.step_row).astype(PETSc.IntType)
            self._end_row = end.step_row[self._end_columns]
            self._end_base = np.array([self.C.getValue(self._index, int(j))
                                       for j in self._end_columns])
        snes = PETSc.SNES().create(PETSc.COMM_SELF)
        snes.setOptionsPrefix(PREFIX)
        snes.setType("vinewtonrsls" if self.rigid else "newtonls")
        snes.setTolerances(max_it=self.max_iterations)
        self.F = self.x.duplicate()
        snes.setFunction(self._residual, self.F)
        snes.setJacobian(self._jacobian, self.J)
        snes.setConvergenceTest(self._converged)
        if self.rigid:
            self.lower, self.upper = self.x.duplicate(), self.x.duplicate()
            self.lower.set(PETSc.NINFINITY)
            self.upper.set(PETSc.INFINITY)
            snes.setVariableBounds(self.lower, self.upper)
        snes.setFromOptions()
        # A variable heat exchange: the heat row of x = 1 (Θ(1), the index ``last``) gains
        # w q Θ(1) and β U(1), or β along the eliminated end's row (the module's docstring)
        self.variable = self.exchange.variable
        self._exchange = (0.0, 0.0)  # (w q, β) of the last Jacobian
        self._theta_end = 0.0  # Θⁿ⁻¹(1) of the step
        self._rigid_F = self.x.duplicate()  # C x − [h; m], for the rigid obstacle's multiplier
        if not self.rigid:
            self._rank_one_solver(snes.getKSP())
        self.snes = snes
        self._floor = 0.0

    def _rank_one_solver(self, ksp: PETSc.KSP) -> None:
        """The Jacobian is C plus a rank one term in the row of x = 1, J = C + κ e rᵀ (κ the
        contact force's slope, r the unit vector of x = 1 or the eliminated end's row): solved
        by C's LU, factored once, and Sherman–Morrison, J⁻¹b = C⁻¹b − q (κ rᵀC⁻¹b)/(1 + κ rᵀq)
        with q = C⁻¹e, in place of a factorisation of J at every iteration. Exact (1 + κ rᵀq ≥ 1:
        rᵀq is the compliance w > 0). A variable heat exchange adds the rank one term
        e_Θ (w q e_Θᵀ + β rᵀ) in the heat row of x = 1: Woodbury's formula (:meth:`apply`)."""
        self._c_ksp, factor = lu_factor(self.C, PREFIX + "c_", "rcm")
        self._solve_c = factor.solve
        self._q = self._response(self._index)
        if self.massless is None:
            self._r_dot = lambda v: v.getValue(self._index)
        else:
            row = self.massless.step_row
            self._r_dot = lambda v: float(row @ v.array_r)
        self._r_q = self._r_dot(self._q)
        if self.variable:  # q_Θ = C⁻¹e_Θ, and [e_Θ, r]ᵀ[q_Θ, q]
            self._q_theta = self._response(self.last)
            self._gram = np.array([[self._q_theta.getValue(self.last),
                                    self._q.getValue(self.last)],
                                   [self._r_dot(self._q_theta), self._r_q]])
        self._slope = 0.0
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("python")
        pc.setPythonContext(self)

    def _response(self, index: int) -> PETSc.Vec:
        """C⁻¹ of the unit vector of the unknown ``index``."""
        unit, response = self.x.duplicate(), self.x.duplicate()
        unit.setValue(index, 1.0)
        unit.assemble()
        self._solve_c(unit, response)
        return response

    def apply(self, pc, b: PETSc.Vec, y: PETSc.Vec) -> None:
        """J⁻¹b (PETSc's python preconditioner, with KSP preonly: the linear solve)."""
        self._solve_c(b, y)
        if self._exchange != (0.0, 0.0):
            # J = C + [e_Θ, e] M [e_Θ, r]ᵀ, M = [[w q, β], [0, κ]]: J⁻¹b = y − [q_Θ, q] z with
            # (I + M G) z = M [e_Θ, r]ᵀ y, G = [e_Θ, r]ᵀ[q_Θ, q] (Woodbury, M need not be
            # invertible); (I + M G)⁻¹ M is made with the Jacobian
            z = self._woodbury @ [y.getValue(self.last), self._r_dot(y)]
            y.maxpy([-z[0], -z[1]], [self._q_theta, self._q])
        elif self._slope:
            y.axpy(-self._slope * self._r_dot(y) / (1.0 + self._slope * self._r_q), self._q)

    def saved_state(self) -> dict[str, np.ndarray]:
        """The base state and Newton's first guess for the next step: the last increments."""
        return {**super().saved_state(), "guess": self.x.array_r.copy()}

    def restore(self, saved: dict[str, np.ndarray]) -> None:
        super().restore(saved)
        self.x.array[:] = saved["guess"]
        self.x.stateIncrease()

    def _residual(self, snes, x: PETSc.Vec, F: PETSc.Vec) -> None:
        self.C.mult(x, F)
        F.axpy(-1.0, self.rhs)
        if not self.rigid:
            pressure = self._force(x)
            if pressure:
                F.setValue(self._index, F.getValue(self._index) + pressure)
                F.assemble()
        if self.variable:
            flux = self._exchange_terms(x, F)[0]
            if flux:
                F.setValue(self.last, F.getValue(self.last) + flux)
                F.assemble()

    def _exchange_terms(self, x: PETSc.Vec, F: PETSc.Vec | None = None):
        """(φ, q, T, β, ∂q/∂p T) of the variable exchange at the increments x: q at the place
        of Uⁿ(1) (an eliminated end's settled U(1)) and the step's contact force, for the rigid
        obstacle −F_U(1) of the residual F without the exchange (read before it is added) or,
        without F, recomputed; β = dq/dU(1) T, through the place and the contact law (along the
        end's free position y, if eliminated); ∂q/∂p T where p > 0 (the rigid obstacle's
        multiplier's derivative in J, :meth:`_rigid_exchange_row`), else 0."""
        y, c = self._where(x)
        w, end, law = self.time_scheme.weight, self.massless, self.exchange
        if self.rigid:
            if F is None:
                F = self._rigid_F
                self.C.mult(x, F)
                F.axpy(-1.0, self.rhs)
            # the multiplier where the bound holds (as _step reads it); off it the rod is free
            touching = x.getValue(self._index) >= self.upper.getValue(self._index)
            pressure = max(-F.getValue(self._index), 0.0) if touching else 0.0
            slope = 0.0
        else:
            pressure = self.time_scheme.contact_force(self.step_law, y, c)
            slope = self.time_scheme.contact_slope(self.step_law, y, c)
        u_1, moves = y, 1.0  # U(1), and its derivative along y
        if end is not None:
            u_1, moves = end.displacement(y, end.law.force(y)), end.displacement_slope(y)
        place = self.time_scheme.exchange_place(u_1, self.u.getValue(self.last))
        q = law.extra(place, pressure)
        T = self._theta_end + self.offset + w * x.getValue(self.last)
        dq_dy, dq_dp = law.extra_slopes(place, pressure)
        beta = (dq_dy * w * moves + (dq_dp * slope if slope else 0.0)) * T
        return q * T, q, T, beta, dq_dp * T if pressure > 0.0 else 0.0

    def _where(self, x: PETSc.Vec) -> tuple[float, float]:
        """(y, c): where the contact law is taken for the increments x, and a step before."""
        if self.massless is None:
            c = self.u.getValue(self.last)
            return c + x.getValue(self._index), c
        c = self._end_position
        return c + self.massless.moved(x.array_r), c

    def _force(self, x: PETSc.Vec) -> float:
        return self.time_scheme.contact_force(self.step_law, *self._where(x))

    def _jacobian(self, snes, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        """C plus the generalized derivative of the contact force in the row of x = 1: in its
        diagonal entry, or along the row of the eliminated end's free position."""
        slope = 0.0
        if not self.rigid:
            slope = self._slope = self.time_scheme.contact_slope(self.step_law, *self._where(x))
        if self.massless is None:
            J.setValue(self._index, self._index, self.C_last + slope)
        else:
            J.setValues(self._index, self._end_columns, self._end_base + slope * self._end_row)
        if self.variable:
            _, q, _, beta, by_pressure = self._exchange_terms(x)
            self._exchange = (self.time_scheme.weight * q, beta)
            if not self.rigid and self._exchange != (0.0, 0.0):
                M = np.array([[self._exchange[0], beta], [0.0, slope]])
                self._woodbury = np.linalg.solve(np.eye(2) + M @ self._gram, M)
            if self.rigid:  # J itself is factored: the heat row of x = 1, explicitly
                self._rigid_exchange_row(J, by_pressure)
        J.assemble()

    def _rigid_exchange_row(self, J: PETSc.Mat, by_pressure: float) -> None:
        """The rigid obstacle's heat row of x = 1 in J: C's, plus w q at Θ(1), β at U(1) and
        ∂q/∂p T times ∂(−F_U(1))/∂x = −C's row of U(1) (the multiplier's dependence)."""
        columns, values = self.C.getRow(self.last)
        row = dict(zip(columns.tolist(), values.tolist(), strict=True))
        row[self.last] = row.get(self.last, 0.0) + self._exchange[0]
        row[self._index] = row.get(self._index, 0.0) + self._exchange[1]
        if by_pressure:
            for j, value in zip(*self.C.getRow(self._index), strict=True):
                row[int(j)] = row.get(int(j), 0.0) - by_pressure * value
        J.setValues(self.last, list(row), list(row.values()))

    def _converged(self, snes, its: int, norms) -> int:
        _, _, fnorm = norms
        reason = PETSc.SNES.ConvergedReason
        if not np.isfinite(fnorm):
            return reason.DIVERGED_FNORM_NAN
        snes.getSolution().copy(self._abs_x)
        self._abs_x.abs()
        self.C_abs.multAdd(self._abs_x, self._abs_rhs, self._bound)  # |C| |x| + |[h; m]|
        if self.variable:  # + |q| (|Θⁿ⁻¹(1)| + w |x_Θ(1)| + |offset|)
            x = snes.getSolution()
            q = abs(self._exchange_terms(x)[1])
            if q:
                size = abs(self._theta_end) + self.time_scheme.weight * abs(
                    x.getValue(self.last)) + abs(self.offset)
                self._bound.setValue(self.last, self._bound.getValue(self.last) + q * size)
                self._bound.assemble()
        if fnorm <= ROUNDOFF * self._bound.norm():
            return reason.CONVERGED_FNORM_ABS
        if its >= snes.getTolerances()[3]:
            return reason.DIVERGED_MAX_IT
        return reason.ITERATING

    def _step(self) -> None:
        self._fixed_parts(self.rhs)
        self._theta_end = self.theta.getValue(self.last)
        self.rhs.copy(self._abs_rhs)
        self._abs_rhs.abs()
        if self.massless is not None:
            self._end_position = self.massless.position(self.values)
        if self.rigid:
            self.upper.setValue(self._index, self.law.gap - self.u.getValue(self.last))
            self.upper.assemble()
        # The first guess: the last step's increments, which x still holds.
        self.snes.solve(None, self.x)
        reason = self.snes.getConvergedReason()
        iterations = self.snes.getIterationNumber()
        if reason <= 0:
            from rodfem.discrete import compat  # (imports dolfinx: only for a failed step)

            if reason == compat.SNES_DIVERGED_NAN:
                raise NotFinite("newton", self.n + 1, (self.n + 1) * self.dt,
                                "the residual of (3.1)-(3.2)")
            raise NotConverged("newton", self.n + 1, (self.n + 1) * self.dt,
                               f"{REASONS.get(reason, reason)} after {iterations} iterations",
                               iterations)
        if self.rigid:  # the multiplier, where the bound holds; off it, the rod is free
            bound = self.upper.getValue(self._index)
            self._residual(self.snes, self.x, self.F)
            touching = self.x.getValue(self._index) >= bound
            self.pressure = max(-self.F.getValue(self._index), 0.0) if touching else 0.0
        else:
            self.pressure = self._force(self.x)
        self._accept(self.x_heat, self.x_momentum)
        self.iterations = iterations
