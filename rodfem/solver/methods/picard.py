"""The paper's method: the scheme (3.1)–(3.2) solved by its Picard iteration (3.3)–(3.4).

Each iteration solves the heat equation with the last displacement iterate, then the momentum
equation with the new temperature and the contact force of the last iterate. Both operators are
LU-factored once per run, so an iteration is two mat-vecs and two triangular solves.

The paper proves convergence for a < 1 and Δt < εζ. Where the contact is active, the iteration
maps the contact force through the compliance w of the momentum operator at x = 1 (the U(1)
response to a unit force, :attr:`rodfem.solver.methods.direct.DirectMethod.compliance`): it
contracts by about w φ''(U(1)) per iteration, w/ε for the paper's law, and cannot converge where
that exceeds 1 (:meth:`rodfem.model.contact.ContactLaw.contraction`, ``rodfem stability``).

With a = 0 the heat equation does not see the motion: it is solved once per step, and the
iteration only updates the contact force; as soon as that force repeats, the next iterate would
repeat too, and the step is done.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from rodfem.discrete.discretisation import Discretisation
from rodfem.solver.errors import PicardNotConverged
from rodfem.solver.linalg import lu_solver, stacked
from rodfem.solver.methods.base import Method

INF = PETSc.NormType.INFINITY


class PicardMethod(Method):
    """(3.3)–(3.4) from Θ^{n,0} = Θⁿ⁻¹, U^{n,0} = Uⁿ⁻¹ until the max-norm of the change of
    (Θ, U) between two iterations is below tol."""

    name = "picard"

    def __init__(self, disc: Discretisation, dt: float | None = None):
        super().__init__(disc, dt)
        self.solve_momentum = lu_solver(self.momentum.A, "rodfem_momentum_")
        new = self.heat.A.createVecRight
        self._work = [new() for _ in range(4)]
        self._fixed, (self._heat_step, self._momentum_step) = stacked(2, disc.nodes.size)
        self._rhs = new()

    def _step(self) -> None:
        h_step, m_step, rhs = self._heat_step, self._momentum_step, self._rhs
        N_du, N_theta = self.heat.N["du"], self.momentum.N["dtheta"]
        # The parts of both right-hand sides that stay fixed during the step; Θ^{n,l} = Θⁿ⁻¹ +
        # ΔΘ^{n,l} in the momentum equation.
        self._fixed_parts(self._fixed)
        solve_heat, solve_momentum = self.solve_heat, self.solve_momentum
        load, last, tol, coupled = self.contact_load, self.last, self.tol, self.coupled
        end, law = self.massless, self.law if self.massless is None else self.massless.law
        # The law is taken at Uⁿ(1) from Uⁿ⁻¹(1), or at an eliminated end's free position y
        # (massless.MasslessEnd) from yⁿ⁻¹.
        u_last = self.u.getValue(last) if end is None else end.position(self.values)

        dtheta_it, dtheta_new, du_it, du_new = self._work
        dtheta_it.zeroEntries()  # Θ^{n,0} = Θⁿ⁻¹
        du_it.zeroEntries()  # U^{n,0} = Uⁿ⁻¹
        if not coupled:  # a = 0: ΔΘⁿ once; the momentum right-hand side without contact, once
            solve_heat(h_step, dtheta_it)
            N_theta.multAdd(dtheta_it, m_step, m_step)
            dtheta_new.zeroEntries()
        increment, pressure = np.inf, np.nan
        deepest = u_last  # the largest U(1) of the iterates, for the failure's message
        for iteration in range(1, self.max_iterations + 1):  # noqa: B007 (used after the loop)
            last_pressure = pressure
            y = u_last + (du_it.getValue(last) if end is None
                          else end.moved_by(dtheta_it.array_r, du_it.array_r))
            deepest = max(deepest, y)
            pressure = self.time_scheme.contact_force(law, y, u_last)
            if not coupled and pressure == last_pressure:
                # The same load as the last iteration: this iterate would equal the last one.
                iteration, increment = iteration - 1, 0.0
                break
            if coupled:
                N_du.multAdd(du_it, h_step, rhs)
                solve_heat(rhs, dtheta_new)
                N_theta.multAdd(dtheta_new, m_step, rhs)
            else:
                m_step.copy(rhs)
            if pressure:
                rhs.axpy(-pressure, load)
            solve_momentum(rhs, du_new)
            du_it.aypx(-1.0, du_new)  # the changes, in the vectors of the old iterates
            change_u = du_it.norm(INF)
            if coupled:
                dtheta_it.aypx(-1.0, dtheta_new)
                change_theta = dtheta_it.norm(INF)
                dtheta_it, dtheta_new = dtheta_new, dtheta_it
            else:
                change_theta = 0.0
            increment = max(change_theta, change_u)
            du_it, du_new = du_new, du_it
            if not (change_theta < np.inf and change_u < np.inf):  # inf or nan: stop at once
                increment = np.nan
                break
            if increment < tol:
                break
        if not increment < tol:
            self._work = [dtheta_it, dtheta_new, du_it, du_new]
            raise PicardNotConverged(self.n + 1, (self.n + 1) * self.dt, increment, iteration,
                                     deepest)
        y = u_last + (du_it.getValue(last) if end is None
                      else end.moved_by(dtheta_it.array_r, du_it.array_r))
        self.pressure = self.time_scheme.contact_force(law, y, u_last)
        self._accept(dtheta_it, du_it)
        self._work = [dtheta_it, dtheta_new, du_it, du_new]
        self.iterations = iteration
