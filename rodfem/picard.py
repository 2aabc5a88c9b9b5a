"""The paper's scheme (3.1)–(3.2) advanced by its Picard iteration (3.3)–(3.4).

Both equations are linear once the other unknown and the contact pressure are frozen, so each has
a constant operator: it is assembled and LU-factored once per run, and every step and iteration
only multiplies and back-substitutes. Θ and U live in sequential PETSc vectors in node order
(:mod:`rodfem.nodes`), rotated rather than copied; x = 1 is the last node.
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
    """The iteration (3.3)–(3.4) did not reach the tolerance within max_iterations."""

    def __init__(self, step: int, time: float, increment: float, iterations: int):
        self.step, self.time, self.increment, self.iterations = step, time, increment, iterations
        super().__init__(
            f"Picard iteration did not converge at step {step} (t = {time:g}): "
            f"increment {increment:.3e} after {iterations} iterations"
        )


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

    After each call, ``theta`` holds Θⁿ, ``u`` holds Uⁿ and ``u_prev`` holds Uⁿ⁻¹ (for n = 0, the
    virtual U⁻¹ = U⁰ − Δt P u₁, so that δ⁰ = P u₁).
    """

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        self.disc = disc
        self.dt = scene["time.dt"]
        self.epsilon, self.gap = scene["obstacle.epsilon"], scene["obstacle.gap"]
        self.tol, self.max_iterations = scene["solver.tol"], scene["solver.max_iterations"]
        a, b, zeta, k, theta_A = (scene[f"model.{p}"] for p in ("a", "b", "zeta", "k", "theta_A"))
        f = disc.function
        Θ, Θ_prev, Θ_iterate = f("Θ"), f("Θ_prev"), f("Θ_iterate")
        U, U_prev, U_prev2, U_iterate = f("U"), f("U_prev"), f("U_prev2"), f("U_iterate")
        w = ufl.TestFunction(disc.V)
        dt, dx_m, dx, ds_1 = self.dt, disc.dx_m, disc.dx, disc.ds_1

        # (3.3): the heat equation with the displacement at the previous iterate.
        F_heat = copetti.heat(Θ, Θ_prev, U_iterate, U_prev, w, dt, a, k, dx_m, dx, ds_1)
        self.heat = disc.affine_operator(
            F_heat, Θ, {"theta_prev": Θ_prev, "u_iterate": U_iterate, "u_prev": U_prev}
        )
        # (3.4): the momentum equation with the new temperature; contact is a load, below.
        F_momentum = copetti.momentum(U, U_prev, U_prev2, Θ_iterate, w, dt, b, zeta, a, theta_A,
                                      disc.r, dx_m, dx)
        self.momentum = disc.affine_operator(
            F_momentum, U, {"u_prev": U_prev, "u_prev2": U_prev2, "theta_iterate": Θ_iterate}
        )
        # The contact term p v(1) for p = 1: the load of a unit pressure at x = 1.
        self.contact_load = disc.vector(copetti.contact(1.0, w, ds_1))
        self.last = disc.nodes.size - 1  # the node x = 1

        self.heat_ksp, heat_factor = lu_factor(self.heat.A, "rodfem_heat_")
        self.momentum_ksp, momentum_factor = lu_factor(self.momentum.A, "rodfem_momentum_")
        self.solve_heat, self.solve_momentum = heat_factor.solve, momentum_factor.solve

        new = self.heat.A.createVecRight
        self.theta, self.u, self.u_prev = new(), new(), new()
        self._work = [new() for _ in range(4)]
        self._rhs, self._heat_step, self._momentum_step = new(), new(), new()
        self.n = 0
        self.iterations = 0
        self._set_initial_state(scene, theta_A, k)

    def _set_initial_state(self, scene, theta_A: float, k: float) -> None:
        """Θ⁰ = P(θ₀ + θ_A r), U⁰ = P u₀ and P u₁, P the H¹_E projection: in 1D with P1, nodal
        interpolation. The node x = 0 is set to exactly 0 (the scene checked compatibility)."""
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
        self.velocity0 = self.u.duplicate()
        self.velocity0.array[:] = u1
        self.u_prev.waxpy(-self.dt, self.velocity0, self.u)

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
        N = self.heat.N
        self.u_prev, self.u = self.u, self.u_prev
        self.u.waxpy(self.dt, self.velocity0, self.u_prev)
        rhs = self._rhs
        N["theta_prev"].multAdd(self.theta, self.heat.b, rhs)
        N["u_prev"].multAdd(self.u_prev, rhs, rhs)
        N["u_iterate"].multAdd(self.u, rhs, rhs)
        self.solve_heat(rhs, self.theta)
        self.iterations = 0

    def _picard_step(self) -> None:
        """(3.3)–(3.4) from Θ^{n,0} = Θⁿ⁻¹, U^{n,0} = Uⁿ⁻¹ until the max-norm of the increment of
        (Θ, U) is below tol."""
        Nh, Nm = self.heat.N, self.momentum.N
        h_step, m_step, rhs = self._heat_step, self._momentum_step, self._rhs
        # The parts of both right-hand sides that stay fixed during the step.
        Nh["theta_prev"].multAdd(self.theta, self.heat.b, h_step)
        Nh["u_prev"].multAdd(self.u, h_step, h_step)
        Nm["u_prev"].multAdd(self.u, self.momentum.b, m_step)
        Nm["u_prev2"].multAdd(self.u_prev, m_step, m_step)
        N_u, N_theta = Nh["u_iterate"], Nm["theta_iterate"]
        solve_heat, solve_momentum = self.solve_heat, self.solve_momentum
        load, last = self.contact_load, self.last
        gap, epsilon, tol = self.gap, self.epsilon, self.tol

        theta_it, theta_new, u_it, u_new = self._work
        self.theta.copy(theta_it)
        self.u.copy(u_it)
        increment = np.inf
        for iteration in range(1, self.max_iterations + 1):  # noqa: B007 (used after the loop)
            N_u.multAdd(u_it, h_step, rhs)
            solve_heat(rhs, theta_new)
            N_theta.multAdd(theta_new, m_step, rhs)
            pressure = max(u_it.getValue(last) - gap, 0.0) / epsilon
            if pressure:
                rhs.axpy(-pressure, load)
            solve_momentum(rhs, u_new)
            theta_it.aypx(-1.0, theta_new)  # the increments, in the vectors of the old iterates
            u_it.aypx(-1.0, u_new)
            increment = max(theta_it.norm(INF), u_it.norm(INF))
            theta_it, theta_new = theta_new, theta_it
            u_it, u_new = u_new, u_it
            if increment < tol:
                break
        else:
            self._work = [theta_it, theta_new, u_it, u_new]
            raise PicardNotConverged(self.n + 1, (self.n + 1) * self.dt, increment, iteration)
        # (Θⁿ, Uⁿ, Uⁿ⁻¹) take the places of (Θⁿ⁻¹, Uⁿ⁻¹, Uⁿ⁻²); the rest go back to the pool.
        spare_theta, spare_u = self.theta, self.u_prev
        self.theta, self.u_prev, self.u = theta_it, self.u, u_it
        self._work = [spare_theta, theta_new, spare_u, u_new]
        self.iterations = iteration
