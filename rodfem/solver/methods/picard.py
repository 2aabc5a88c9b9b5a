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

**A variable heat exchange** (``heat_exchange.law``, :mod:`rodfem.model.exchange`) adds to the
heat row of x = 1 the flux φ = q (Θⁿ⁻¹(1) + w ΔΘ(1) + offset) (w the time scheme's weight). As
(3.3) takes k Θ^{n,l}(1), iteration l takes q^{l−1}, the law at U^{n,l−1}(1) and its contact
force, and Θ^{n,l}(1) implicitly: the heat operator gains w q^{l−1} e eᵀ, which Sherman–Morrison
solves with A_h's LU and v = A_h⁻¹ e (once per run). With z = A_h⁻¹(h + N_U ΔU^{n,l−1}), the
step without the exchange,

    ΔΘ^{n,l} = z − φ v,   φ = q (Θⁿ⁻¹(1) + offset + w z(1)) / (1 + w q v(1)).

With a = 0 the heat depends on the motion only through q: it is solved again when q changes, and
the step is done when both the contact force and q repeat. An eliminated end
(:mod:`.massless`) takes q at its settled U(1). The constant law (q = 0) is the paper's
iteration, untouched.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.discretisation import Discretisation
from rodfem.solver.errors import PicardNotConverged
from rodfem.solver.linalg import lu_solver, stacked
from rodfem.solver.methods.base import Method

if TYPE_CHECKING:
    from petsc4py import PETSc


class PicardMethod(Method):
    """(3.3)–(3.4) from Θ^{n,0} = Θⁿ⁻¹, U^{n,0} = Uⁿ⁻¹ until the max-norm of the change of
    (Θ, U) between two iterations is below tol."""

    name = "picard"

    def __init__(self, disc: Discretisation, dt: float | None = None):
        super().__init__(disc, dt)
        self.solve_momentum = lu_solver(self.momentum.A, "rodfem_momentum_")
        new = self.heat.A.createVecRight
        self._work = [new() for _ in range(4)]
        self._fixed, (self._heat_step, self._momentum_step) = stacked(2, disc.nodes.size,
                                                                      disc.petsc)
        self._inf = None  # PETSc's max-norm, on the first step it takes
        self._rhs = new()
        self._unit_response = None  # v = A_h⁻¹ e, for a variable exchange (on first use)
        self._heat_free = new()  # with a = 0 and a variable exchange, ΔΘⁿ without it

    def _exchanged(self, dtheta: PETSc.Vec, q: float, theta_end: float) -> None:
        """ΔΘ = z − φ v in place of z (the module's docstring): the heat step with the exchange
        w q^{l−1} (Θ(1) + offset) at x = 1, Θⁿ⁻¹(1) + offset = ``theta_end``."""
        v, w = self.unit_response(), self.time_scheme.weight
        flux = q * (theta_end + w * dtheta.getValue(self.last)) / (
            1.0 + w * q * v.getValue(self.last))
        dtheta.axpy(-flux, v)

    def unit_response(self) -> PETSc.Vec:
        """v = A_h⁻¹ e: the heat step's response to a unit flux at x = 1 (made on first use)."""
        if self._unit_response is None:
            self._unit_response = self.heat.A.createVecRight()
            self.solve_heat(self.contact_load, self._unit_response)
        return self._unit_response

    def _end_displacement(self, y: float) -> float:
        """U(1) of an iterate whose end (its free position, if eliminated) is at y."""
        end = self.massless
        return y if end is None else end.displacement(y, end.law.force(y))

    def _step(self) -> None:
        if self._inf is None:
            from petsc4py import PETSc

            self._inf = PETSc.NormType.INFINITY
        INF = self._inf  # noqa: N806
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
        # A variable exchange's q at the iterate's U(1) from Uⁿ⁻¹(1) (settled, for an eliminated
        # end) and its contact force; theta_end = Θⁿ⁻¹(1) + offset.
        variable = self.exchange.variable
        c_end, theta_end = self.u.getValue(last), self.theta.getValue(last) + self.offset
        q_used = q = 0.0  # the q of the last heat solve, and the iterate's

        dtheta_it, dtheta_new, du_it, du_new = self._work
        dtheta_it.zeroEntries()  # Θ^{n,0} = Θⁿ⁻¹
        du_it.zeroEntries()  # U^{n,0} = Uⁿ⁻¹
        if not coupled:  # a = 0: ΔΘⁿ once; the momentum right-hand side without contact, once
            solve_heat(h_step, dtheta_it)
            N_theta.multAdd(dtheta_it, m_step, m_step)
            dtheta_new.zeroEntries()
            if variable:  # ΔΘⁿ without the exchange, z, from which each new q's is made
                heat_free = self._heat_free
                dtheta_it.copy(heat_free)
        increment, pressure = np.inf, np.nan
        deepest = u_last  # the largest U(1) of the iterates, for the failure's message
        for iteration in range(1, self.max_iterations + 1):  # noqa: B007 (used after the loop)
            last_pressure = pressure
            y = u_last + (du_it.getValue(last) if end is None
                          else end.moved_by(dtheta_it.array_r, du_it.array_r))
            deepest = max(deepest, y)
            pressure = self.time_scheme.contact_force(law, y, u_last)
            if variable:
                q = self.exchange_extra(self._end_displacement(y), c_end, pressure)
            if not coupled and pressure == last_pressure and q == q_used:
                # The same loads as the last iteration: this iterate would equal the last one.
                iteration, increment = iteration - 1, 0.0
                break
            if coupled:
                N_du.multAdd(du_it, h_step, rhs)
                solve_heat(rhs, dtheta_new)
                if q:
                    self._exchanged(dtheta_new, q, theta_end)
                N_theta.multAdd(dtheta_new, m_step, rhs)
            else:
                m_step.copy(rhs)
            if pressure:
                rhs.axpy(-pressure, load)
            solve_momentum(rhs, du_new)
            du_it.aypx(-1.0, du_new)  # the changes, in the vectors of the old iterates
            change_u = du_it.norm(INF)
            reheated = not coupled and q != q_used
            if reheated:  # a = 0: the heat again, for the new q
                heat_free.copy(dtheta_new)
                self._exchanged(dtheta_new, q, theta_end)
                q_used = q
            if coupled or reheated:
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
