"""The paper's scheme (3.1)–(3.2) advanced by its Picard iteration (3.3)–(3.4).

Both equations are linear once the other unknown and the contact pressure are frozen, so each has
a constant operator: it is assembled and LU-factored once per run, and every step and iteration
only multiplies and back-substitutes. Θ and U live in sequential PETSc vectors in node order
(:mod:`rodfem.nodes`), rotated rather than copied; x = 1 is the last node.

Both unknowns are advanced through their increments over a step, ΔΘⁿ = Θⁿ − Θⁿ⁻¹ and
ΔUⁿ = Uⁿ − Uⁿ⁻¹, with (3.1)–(3.2) written for them (``forms.copetti.heat_increment`` and
``momentum_increment``): the same equations and Picard iterates, computed to the accuracy of the
increments. Solved for Uⁿ itself, (3.2) loses |U| ε_mach/Δt² of the acceleration every step
(2e-10 at Δt = 1e-3), and (3.1) loses cond·|Θ| ε_mach of Θ.
"""

from __future__ import annotations

import numpy as np
import ufl
from petsc4py import PETSc

import forms.copetti as copetti
from rodfem.discretisation import Discretisation

# Default options of both solvers, merged under the user's (PETSC_OPTIONS can override). In node
# order the operators are tridiagonal, so LU in the natural ordering has no fill.
LU_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "petsc",
    "pc_factor_mat_ordering_type": "natural",
}
INF = PETSc.NormType.INFINITY


class PicardNotConverged(RuntimeError):
    """The iteration (3.3)–(3.4) did not reach the tolerance within max_iterations, or produced
    values that are not finite."""

    def __init__(self, step: int, time: float, increment: float, iterations: int):
        self.step, self.time, self.increment, self.iterations = step, time, increment, iterations
        if np.isfinite(increment):
            what = f"increment {increment:.3e} after {iterations} iterations"
        else:
            what = f"it diverged to non-finite values at iteration {iterations}"
        super().__init__(f"Picard iteration did not converge at step {step} (t = {time:g}): {what}")


def lu_factor(A: PETSc.Mat, prefix: str) -> tuple[PETSc.KSP, PETSc.Mat]:
    """Factor A once (KSP preonly + LU, options under ``prefix``). Returns the KSP, which owns the
    factorisation, and the factor, whose ``solve`` is a plain forward/back substitution."""
    options = PETSc.Options()
    for key, value in LU_OPTIONS.items():
        if not options.hasName(prefix + key):
            options[prefix + key] = value
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setFromOptions()
    ksp.setUp()
    return ksp, ksp.getPC().getFactorMatrix()


class PicardScheme:
    """Θⁿ, Uⁿ of (3.1)–(3.2), from n = 0 on, one step per call of :meth:`advance`.

    After each call, ``theta`` holds Θⁿ, ``u`` holds Uⁿ, ``du`` the increment Uⁿ − Uⁿ⁻¹ and
    ``u_prev`` holds Uⁿ⁻¹ (for n = 0, ``du`` = Δt P u₁, so that δ⁰ = P u₁).
    """

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        self.disc = disc
        self.dt = scene["time.dt"]
        self.epsilon, self.gap = scene["obstacle.epsilon"], scene["obstacle.gap"]
        self.tol, self.max_iterations = scene["solver.tol"], scene["solver.max_iterations"]
        c = disc.const
        dt, a, b, zeta, k, theta_A = c.dt, c.a, c.b, c.zeta, c.k, c.theta_A
        f = disc.function
        ΔΘ, Θ_prev, Θ_iterate = f("ΔΘ"), f("Θ_prev"), f("Θ_iterate")
        ΔU, ΔU_prev, U_prev, ΔU_iterate = f("ΔU"), f("ΔU_prev"), f("U_prev"), f("ΔU_iterate")
        w = ufl.TestFunction(disc.V)
        dx_m, dx, ds_1 = disc.dx_m, disc.dx, disc.ds_1

        # (3.3): the heat equation for ΔΘ^{n,l} = Θ^{n,l} − Θⁿ⁻¹, with the displacement at the
        # previous iterate, U^{n,l−1} − Uⁿ⁻¹ = ΔU^{n,l−1}.
        F_heat = copetti.heat_increment(ΔΘ, Θ_prev, ΔU_iterate, w, dt, a, k, dx_m, dx, ds_1)
        self.heat = disc.affine_operator(
            F_heat, ΔΘ, {"theta_prev": Θ_prev, "du_iterate": ΔU_iterate}
        )
        # (3.4) for ΔU^{n,l} = U^{n,l} − Uⁿ⁻¹, with the new temperature Θ^{n,l}; the contact term
        # is a load, below.
        F_momentum = copetti.momentum_increment(ΔU, ΔU_prev, U_prev, Θ_iterate, w, dt, b, zeta,
                                                a, theta_A, disc.r, dx_m, dx)
        self.momentum = disc.affine_operator(
            F_momentum, ΔU, {"du_prev": ΔU_prev, "u_prev": U_prev, "theta_iterate": Θ_iterate}
        )
        # The contact term p v(1) for p = 1: the load of a unit pressure at x = 1.
        self.contact_load = disc.vector(copetti.contact(1.0, w, ds_1))
        self.last = disc.nodes.size - 1  # the node x = 1

        self.heat_ksp, heat_factor = lu_factor(self.heat.A, "rodfem_heat_")
        self.momentum_ksp, momentum_factor = lu_factor(self.momentum.A, "rodfem_momentum_")
        self.solve_heat, self.solve_momentum = heat_factor.solve, momentum_factor.solve

        new = self.heat.A.createVecRight
        self.theta, self.u, self.u_prev, self.du = new(), new(), new(), new()
        self._work = [new() for _ in range(4)]
        self._rhs, self._heat_step, self._momentum_step = new(), new(), new()
        self.n = 0
        self.iterations = 0
        self._set_initial_state()

    def _set_initial_state(self) -> None:
        """Θ⁰ = P(θ₀ + θ_A r), U⁰ = P u₀ and P u₁, P the H¹_E projection: in 1D with P1, nodal
        interpolation. The node x = 0 is set to exactly 0 (the scene checked compatibility)."""
        scene = self.disc.scene
        theta_A, k = scene["model.theta_A"], scene["model.k"]
        x = self.disc.nodes.x
        clamped = x == 0.0
        params = scene.parameters
        r = k / (k + 1.0) * x - 1.0
        theta0 = scene.initial("theta0")(x, params) + theta_A * r
        u0, u1 = (scene.initial(name)(x, params) for name in ("u0", "u1"))
        for values in (theta0, u0, u1):
            values[clamped] = 0.0
        self.theta.array[:] = theta0
        self.u.array[:] = u0
        self.du.array[:] = self.dt * u1
        self.u_prev.waxpy(-1.0, self.du, self.u)

    def advance(self) -> int:
        """Go from step n to n + 1; return the number of Picard iterations it took."""
        if self.n == 0:
            self._first_step()
        else:
            self._picard_step()
        self.n += 1
        return self.iterations

    def _first_step(self) -> None:
        """U¹ = U⁰ + Δt P u₁, and Θ¹ from (3.1) with U¹ and U⁰ known: no iteration."""
        N, rhs, dtheta = self.heat.N, self._rhs, self._work[0]
        self.u_prev, self.u = self.u, self.u_prev
        self.u.waxpy(1.0, self.du, self.u_prev)  # ΔU¹ = Δt P u₁, as at n = 0
        N["theta_prev"].multAdd(self.theta, self.heat.b, rhs)
        N["du_iterate"].multAdd(self.du, rhs, rhs)
        self.solve_heat(rhs, dtheta)
        self.theta.axpy(1.0, dtheta)
        self.iterations = 0

    def _picard_step(self) -> None:
        """(3.3)–(3.4) from Θ^{n,0} = Θⁿ⁻¹, U^{n,0} = Uⁿ⁻¹ until the max-norm of the change of
        (Θ, U) between two iterations is below tol."""
        Nh, Nm = self.heat.N, self.momentum.N
        h_step, m_step, rhs = self._heat_step, self._momentum_step, self._rhs
        N_du, N_theta = Nh["du_iterate"], Nm["theta_iterate"]
        # The parts of both right-hand sides that stay fixed during the step (Θⁿ⁻¹ = theta,
        # Uⁿ⁻¹ = u, ΔUⁿ⁻¹ = du); Θ^{n,l} = Θⁿ⁻¹ + ΔΘ^{n,l} in the momentum equation.
        Nh["theta_prev"].multAdd(self.theta, self.heat.b, h_step)
        Nm["u_prev"].multAdd(self.u, self.momentum.b, m_step)
        Nm["du_prev"].multAdd(self.du, m_step, m_step)
        N_theta.multAdd(self.theta, m_step, m_step)
        solve_heat, solve_momentum = self.solve_heat, self.solve_momentum
        load, last = self.contact_load, self.last
        gap, epsilon, tol = self.gap, self.epsilon, self.tol
        u_last = self.u.getValue(last)

        dtheta_it, dtheta_new, du_it, du_new = self._work
        dtheta_it.zeroEntries()  # Θ^{n,0} = Θⁿ⁻¹
        du_it.zeroEntries()  # U^{n,0} = Uⁿ⁻¹
        increment = np.inf
        for iteration in range(1, self.max_iterations + 1):  # noqa: B007 (used after the loop)
            N_du.multAdd(du_it, h_step, rhs)
            solve_heat(rhs, dtheta_new)
            N_theta.multAdd(dtheta_new, m_step, rhs)
            pressure = max(u_last + du_it.getValue(last) - gap, 0.0) / epsilon
            if pressure:
                rhs.axpy(-pressure, load)
            solve_momentum(rhs, du_new)
            dtheta_it.aypx(-1.0, dtheta_new)  # the changes, in the vectors of the old iterates
            du_it.aypx(-1.0, du_new)
            change_theta, change_u = dtheta_it.norm(INF), du_it.norm(INF)
            increment = max(change_theta, change_u)
            dtheta_it, dtheta_new = dtheta_new, dtheta_it
            du_it, du_new = du_new, du_it
            if not (change_theta < np.inf and change_u < np.inf):  # inf or nan: stop at once
                increment = np.nan
                break
            if increment < tol:
                break
        if not increment < tol:
            self._work = [dtheta_it, dtheta_new, du_it, du_new]
            raise PicardNotConverged(self.n + 1, (self.n + 1) * self.dt, increment, iteration)
        # Θⁿ = Θⁿ⁻¹ + ΔΘⁿ; (ΔUⁿ, Uⁿ, Uⁿ⁻¹) take the places of (ΔUⁿ⁻¹, Uⁿ⁻¹, Uⁿ⁻²).
        self.theta.axpy(1.0, dtheta_it)
        spare_du, spare_u = self.du, self.u_prev
        self.u_prev, self.u, self.du = self.u, spare_u, du_it
        self.u.waxpy(1.0, du_it, self.u_prev)
        self._work = [dtheta_it, dtheta_new, spare_du, du_new]
        self.iterations = iteration
