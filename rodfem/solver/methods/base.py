"""What every method shares: the scheme (3.1)–(3.2), its state, and its first step.

A method (``solver.method``) is a way of solving one step of the scheme: :mod:`rodfem.solver.methods.picard` (the
paper's iteration), :mod:`rodfem.solver.methods.direct` (exact, one solve) and :mod:`rodfem.solver.methods.newton` (PETSc SNES).
All of them advance the same state, through the increments over a step, ΔΘⁿ = Θⁿ − Θⁿ⁻¹ and
ΔUⁿ = Uⁿ − Uⁿ⁻¹, with (3.1)–(3.2) written for them (``forms.copetti.heat_increment`` and
``momentum_increment``): solved for Uⁿ itself, (3.2) loses |U| ε_mach/Δt² of the acceleration
every step (2e-10 at Δt = 1e-3).

Each equation is affine in its unknown once the other unknown and the contact force are known, so
its operators are read off its form once per run (:meth:`Discretisation.affine_operator`):

    heat      A_h ΔΘ − N_U ΔU = h,      h = N_Θ' Θⁿ⁻¹ + b_h
    momentum  A_m ΔU − N_Θ ΔΘ = m − p e, m = N_U' Uⁿ⁻¹ + N_ΔU' ΔUⁿ⁻¹ + N_Θ Θⁿ⁻¹ + b_m

with e the load of a unit force at x = 1 and p the contact force there: p = (1/ε)[Uⁿ(1) − g]_+
for the elastic obstacle, the multiplier of Signorini's condition Uⁿ(1) ≤ g for the rigid one.
σ(1) = −p. Vectors are sequential, in node order (:mod:`rodfem.discrete.nodes`); x = 1 is the last node.
"""

from __future__ import annotations

import numpy as np
import ufl
from petsc4py import PETSc

import forms.copetti as copetti
from rodfem.model import contact
from rodfem.discrete.discretisation import Discretisation
from rodfem.discrete.nodes import block_diagonal, block_matrix

# Default options of every LU factorisation, merged under the user's (PETSC_OPTIONS can override).
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


def stacked(parts: int, n: int) -> tuple[PETSc.Vec, list[PETSc.Vec]]:
    """A sequential vector of ``parts`` blocks of length n, and a vector for each block that
    shares its memory."""
    array = np.zeros(parts * n)
    wrap = lambda a: PETSc.Vec().createWithArray(a, comm=PETSc.COMM_SELF)  # noqa: E731
    return wrap(array), [wrap(array[i * n:(i + 1) * n]) for i in range(parts)]


class NotConverged(RuntimeError):
    """A step that a method could not solve; the state stays at the last step solved."""

    def __init__(self, method: str, step: int, time: float, detail: str, iterations: int):
        self.method, self.step, self.time = method, step, time
        self.detail, self.iterations = detail, iterations
        super().__init__(f"{self.title} did not converge at step {step} (t = {time:g}): {detail}")

    @property
    def title(self) -> str:
        return {"picard": "Picard iteration", "newton": "Newton's method (SNES)"}.get(
            self.method, self.method)


class SourceNotFinite(NotConverged):
    """A source that is not finite at a step's time: the step cannot be taken."""

    def __init__(self, method: str, step: int, time: float, name: str, t: float):
        super().__init__(method, step, time, f"source.{name} is not finite at t = {t:g}", 0)
        RuntimeError.__init__(self, f"step {step} (t = {time:g}) cannot be taken: {self.detail}")


class Scheme:
    """Θⁿ, Uⁿ of (3.1)–(3.2), from n = 0 on, one step per call of :meth:`advance`.

    After each call, ``theta`` holds Θⁿ, ``u`` holds Uⁿ, ``du`` the increment Uⁿ − Uⁿ⁻¹,
    ``u_prev`` holds Uⁿ⁻¹ and ``pressure`` the contact force p at x = 1 (σ(1) = −p). For n = 0,
    ``du`` = Δt P u₁, so that δ⁰ = P u₁ (0 when b = 0: no inertia, no initial velocity).

    Subclasses solve a step in :meth:`_step`.
    """

    method = ""

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        self.disc = disc
        self.dt = scene["time.dt"]
        self.epsilon, self.gap = scene["obstacle.epsilon"], scene["obstacle.gap"]
        self.rigid = scene["obstacle.kind"] == "rigid"
        # Crank–Nicolson (the midpoint rule) or the paper's scheme; the contact force of each
        # (rodfem.model.contact): Signorini's multiplier, the penalty at tⁿ, or its discrete gradient.
        self.midpoint = scene["time.scheme"] == "crank-nicolson"
        self.rule = "rigid" if self.rigid else "gradient" if self.midpoint else "penalty"
        self.coupled = scene["model.a"] != 0.0  # a = 0: heat does not see motion, nor motion heat
        self.inertia = scene["model.b"] != 0.0
        self.tol, self.max_iterations = scene["solver.tol"], scene["solver.max_iterations"]
        c = disc.const
        dt, a, b, zeta, k, theta_A = c.dt, c.a, c.b, c.zeta, c.k, c.theta_A
        f = disc.function
        ΔΘ, Θ_prev, ΔΘ_other = f("ΔΘ"), f("Θ_prev"), f("ΔΘ_other")
        ΔU, D_prev, U_prev, ΔU_other = f("ΔU"), f("D_prev"), f("U_prev"), f("ΔU_other")
        w = ufl.TestFunction(disc.V)
        dx_m, dx, ds_1 = disc.dx_m, disc.dx, disc.ds_1

        # (3.1) for ΔΘⁿ, given the displacement increment (ΔU_other: ΔUⁿ, or in Picard's (3.3)
        # the previous iterate's).
        heat = copetti.heat_midpoint if self.midpoint else copetti.heat_increment
        F_heat = heat(ΔΘ, Θ_prev, ΔU_other, w, dt, a, k, dx_m, dx, ds_1)
        # (3.2) for ΔUⁿ, given the temperature increment ΔΘⁿ, less its contact term (a load,
        # below). Dⁿ⁻¹ is the velocity's displacement over a step: ΔUⁿ⁻¹ in the paper's scheme
        # (δⁿ⁻¹ = ΔUⁿ⁻¹/Δt), Δt Vⁿ⁻¹ in Crank–Nicolson's.
        if self.midpoint:
            F_momentum = copetti.momentum_midpoint(ΔU, D_prev, U_prev, Θ_prev + 0.5 * ΔΘ_other, w,
                                                   dt, b, zeta, a, theta_A, disc.r, dx_m, dx)
        else:
            F_momentum = copetti.momentum_increment(ΔU, D_prev, U_prev, Θ_prev + ΔΘ_other, w, dt,
                                                    b, zeta, a, theta_A, disc.r, dx_m, dx)
        # Sources only where the scene has them (a manufactured solution): their loads are
        # N_f f with f interpolated at the nodes at the scheme's time of the step.
        self.sources = {name: scene.source_term(name) for name in ("heat", "momentum")}
        heat_y = {"theta_prev": Θ_prev, "du": ΔU_other}
        momentum_y = {"du_prev": D_prev, "u_prev": U_prev, "theta_prev": Θ_prev,
                      "dtheta": ΔΘ_other}
        for name, F_y in (("heat", heat_y), ("momentum", momentum_y)):
            if self.sources[name] is not None:
                F_y["source"] = f(f"f_{name}")
        if self.sources["heat"] is not None:
            F_heat += copetti.source(heat_y["source"], w, dx)
        if self.sources["momentum"] is not None:
            F_momentum += copetti.source(momentum_y["source"], w, dx)
        self.heat = disc.affine_operator(F_heat, ΔΘ, heat_y, loads=("source",))
        self.momentum = disc.affine_operator(F_momentum, ΔU, momentum_y, loads=("source",))
        # The contact term p v(1) for p = 1: the load e of a unit force at x = 1.
        self.contact_load = disc.vector(copetti.contact(1.0, w, ds_1))
        self.last = disc.nodes.size - 1  # the node x = 1

        self.heat_ksp, heat_factor = lu_factor(self.heat.A, "rodfem_heat_")
        self.solve_heat = heat_factor.solve

        # The state s = [Θⁿ; ΔUⁿ; Uⁿ] in one array (History reads its energy off it at once);
        # theta, du and u are views of its thirds. Both right-hand sides of a step, [h; m], are
        # one product with it: [h; m] = R s + [b_h; b_m].
        n = disc.nodes.size
        self.state, (self.theta, self.du, self.u) = stacked(3, n)
        self.values = self.state.array  # the same memory, as a NumPy array
        self.u_prev = self.u.duplicate()
        self.R = block_matrix([[self.heat.N["theta_prev"], None, None],
                               [self.momentum.N["theta_prev"], self.momentum.N["du_prev"],
                                self.momentum.N["u_prev"]]])
        self.b, (b_h, b_m) = stacked(2, n)
        self.heat.b.copy(b_h)
        self.momentum.b.copy(b_m)
        if any(f is not None for f in self.sources.values()):
            self._source_values, self._source_parts = stacked(2, n)
            zero = self.heat.N["theta_prev"].duplicate()  # the same pattern, values zero
            zero.zeroEntries()
            self._source_matrix = block_diagonal(
                [self.heat.N["source"] if self.sources["heat"] else zero,
                 self.momentum.N["source"] if self.sources["momentum"] else zero])
        self.n = 0
        self.iterations = 0
        self.pressure = 0.0
        self._set_initial_state()

    def coupled_operator(self) -> PETSc.Mat:
        """[[A_h, −N_U], [−N_Θ, A_m]]: (3.1)–(3.2) for [ΔΘⁿ; ΔUⁿ] without the contact term."""
        N_u, N_theta = self.heat.N["du"].copy(), self.momentum.N["dtheta"].copy()
        N_u.scale(-1.0)
        N_theta.scale(-1.0)
        return block_matrix([[self.heat.A, N_u], [N_theta, self.momentum.A]])

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
        u0 = scene.initial("u0")(x, params)
        u1 = scene.initial("u1")(x, params) if self.inertia else np.zeros_like(x)
        for values in (theta0, u0, u1):
            values[clamped] = 0.0
        self.theta.array[:] = theta0
        self.u.array[:] = u0
        self.du.array[:] = self.dt * u1
        self.u_prev.waxpy(-1.0, self.du, self.u)

    def advance(self) -> int:
        """Go from step n to n + 1; return the iterations it took (the method's count)."""
        if self.n == 0 and self.inertia and not self.midpoint:
            self._first_step()
        else:
            self._step()
        self.n += 1
        return self.iterations

    def _first_step(self) -> None:
        """U¹ = U⁰ + Δt P u₁, and Θ¹ from (3.1) with U¹ and U⁰ known: no iteration. (Without
        inertia, b = 0, there is no initial velocity: step 1 is a step like any other.)"""
        N, rhs, dtheta = self.heat.N, self.theta.duplicate(), self.theta.duplicate()
        N["theta_prev"].multAdd(self.theta, self.heat.b, rhs)
        N["du"].multAdd(self.du, rhs, rhs)  # ΔU¹ = Δt P u₁, as at n = 0
        if self.sources["heat"] is not None:
            self._source_load(rhs, None, self.dt)
        self.solve_heat(rhs, dtheta)
        self._accept(dtheta, self.du)
        self.iterations = 0
        self.pressure = 0.0

    def _step(self) -> None:
        raise NotImplementedError

    def _fixed_parts(self, rhs: PETSc.Vec) -> None:
        """The right-hand sides [h; m] of a step: what Θⁿ⁻¹, Dⁿ⁻¹ and Uⁿ⁻¹ contribute, and the
        sources (at tⁿ in the paper's scheme, at t^{n−½} in Crank–Nicolson's)."""
        self.R.multAdd(self.state, self.b, rhs)
        if self.sources["heat"] is not None or self.sources["momentum"] is not None:
            self._source_load(None, rhs, (self.n + (0.5 if self.midpoint else 1.0)) * self.dt)

    def _source_load(self, heat_rhs: PETSc.Vec | None, rhs: PETSc.Vec | None, t: float) -> None:
        """Add the sources' loads at time t: to the heat right-hand side alone, or to [h; m]."""
        x, values = self.disc.nodes.x, self._source_values.array
        parameters = {**self.disc.scene.parameters, "t": t}
        n = x.size
        for i, name in enumerate(("heat", "momentum")):
            f = self.sources[name]
            values[i * n:(i + 1) * n] = f(x, parameters) if f is not None else 0.0
        if not np.isfinite(values).all():
            name = "heat" if not np.isfinite(values[:n]).all() else "momentum"
            raise SourceNotFinite(self.method, self.n + 1, (self.n + 1) * self.dt, name, t)
        if rhs is not None:
            self._source_matrix.multAdd(self._source_values, rhs, rhs)
        else:
            self.heat.N["source"].multAdd(self._source_parts[0], heat_rhs, heat_rhs)

    def _accept(self, dtheta: PETSc.Vec, du: PETSc.Vec) -> None:
        """Θⁿ = Θⁿ⁻¹ + ΔΘⁿ, Uⁿ = Uⁿ⁻¹ + ΔUⁿ, and Dⁿ: ΔUⁿ in the paper's scheme, Dⁿ = 2ΔUⁿ − Dⁿ⁻¹
        (the midpoint rule for the velocity) in Crank–Nicolson's."""
        self.theta.axpy(1.0, dtheta)
        self.u.copy(self.u_prev)
        self.u.axpy(1.0, du)
        if self.midpoint and self.inertia:
            self.du.aypx(-1.0, du)
            self.du.axpy(1.0, du)
        elif du is not self.du:
            du.copy(self.du)

    def contact_force(self, y: float, c: float) -> float:
        """The elastic obstacle's force for Uⁿ(1) = y and Uⁿ⁻¹(1) = c (:mod:`rodfem.model.contact`)."""
        if self.rule == "gradient":
            return contact.discrete_gradient(y, c, self.gap, self.epsilon)
        return contact.penalty_force(y, self.gap, self.epsilon)


def make_scheme(disc: Discretisation) -> Scheme:
    """The scheme of the scene's ``solver.method``."""
    method = disc.scene["solver.method"]
    if method == "picard":
        from rodfem.solver.methods.picard import PicardScheme as cls
    elif method == "newton":
        from rodfem.solver.methods.newton import NewtonScheme as cls
    else:
        from rodfem.solver.methods.direct import DirectScheme as cls
    return cls(disc)
