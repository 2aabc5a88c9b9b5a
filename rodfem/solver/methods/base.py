"""What every method shares: the scheme's state, its operators, its first step.

A method (``solver.method``, :mod:`rodfem.solver.methods`) is a way of solving one step of the
time scheme (:mod:`rodfem.solver.time_schemes`): :mod:`.picard` (the paper's iteration),
:mod:`.direct` (exact, one solve) and :mod:`.newton` (PETSc SNES). All of them advance the same
state through the increments over a step, ΔΘⁿ = Θⁿ − Θⁿ⁻¹ and ΔUⁿ = Uⁿ − Uⁿ⁻¹, with (3.1)–(3.2)
written for them (``forms.copetti.heat_increment`` and ``momentum_increment``, at the time
scheme's weight): solved for Uⁿ itself, (3.2) loses |U| ε_mach/Δt² of the acceleration every step
(2e-10 at Δt = 1e-3).

Each equation is affine in its unknown once the other unknown and the contact force are known, so
its operators are read off its form once per run (:meth:`Discretisation.affine_operator`):

    heat      A_h ΔΘ − N_U ΔU = h,      h = N_Θ' Θⁿ⁻¹ + b_h
    momentum  A_m ΔU − N_Θ ΔΘ = m − p e, m = N_U' Uⁿ⁻¹ + N_D' Dⁿ⁻¹ + N_Θ Θⁿ⁻¹ + b_m

with e the load of a unit force at x = 1 and p the contact force there: the obstacle's law
(:mod:`rodfem.model.contact`) at the time scheme's rule, or the multiplier of Signorini's
condition Uⁿ(1) ≤ g for the rigid obstacle. σ(1) = −p. Vectors are sequential, in node order
(:mod:`rodfem.discrete.nodes`); x = 1 is the last node.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.discretisation import Discretisation
from rodfem.discrete.nodes import block_diagonal, block_matrix
from rodfem.model import contact, exchange
from rodfem.model.robin import shifted
from rodfem.solver.errors import SourceNotFinite
from rodfem.solver.linalg import lu_solver, stacked
from rodfem.solver.methods import massless
from rodfem.solver.time_schemes import TIME_SCHEMES

if TYPE_CHECKING:
    from petsc4py import PETSc


class Residuals:
    """(3.1) and (3.2) for the increments, and the contact term, as UFL forms made when called:
    a run whose operators are cached makes none (nor imports UFL)."""

    def __init__(self, disc: Discretisation, weight: float, heat_y: dict[str, str],
                 momentum_y: dict[str, str]):
        self.disc, self.weight, self.heat_y, self.momentum_y = disc, weight, heat_y, momentum_y

    def heat(self):
        """(3.1) for ΔΘⁿ, given the displacement increment (ΔU_other: ΔUⁿ, or in Picard's (3.3)
        the previous iterate's)."""
        import ufl

        import forms.copetti as copetti

        disc, f, c = self.disc, self.disc.symbol, self.disc.const
        w = ufl.TestFunction(disc.V)
        F = copetti.heat_increment(f("ΔΘ"), f("Θ_prev"), f("ΔU_other"), w, c.dt, c.a, c.k,
                                   disc.dx_m, disc.dx, disc.ds_1, self.weight)
        if "source" in self.heat_y:
            F += copetti.source(f(self.heat_y["source"]), w, disc.dx)
        return F

    def momentum(self):
        """(3.2) for ΔUⁿ, given the temperature increment ΔΘⁿ, less its contact term (a load,
        :meth:`contact`). Dⁿ⁻¹ is the velocity's displacement over a step: ΔUⁿ⁻¹ in the paper's
        scheme (δⁿ⁻¹ = ΔUⁿ⁻¹/Δt), Δt Vⁿ⁻¹ in Crank–Nicolson's."""
        import ufl

        import forms.copetti as copetti

        disc, f, c = self.disc, self.disc.symbol, self.disc.const
        w = ufl.TestFunction(disc.V)
        F = copetti.momentum_increment(f("ΔU"), f("D_prev"), f("U_prev"),
                                       f("Θ_prev") + self.weight * f("ΔΘ_other"), w, c.dt, c.b,
                                       c.zeta, c.a, c.theta_A, disc.r, disc.dx_m, disc.dx,
                                       self.weight, disc.dx_b, c.theta_O, disc.s)
        if "source" in self.momentum_y:
            F += copetti.source(f(self.momentum_y["source"]), w, disc.dx)
        return F

    def contact(self):
        """The contact term p v(1) for p = 1."""
        import ufl

        import forms.copetti as copetti

        return copetti.contact(1.0, ufl.TestFunction(self.disc.V), self.disc.ds_1)


class Method:
    """Θⁿ, Uⁿ of (3.1)–(3.2), from n = 0 on, one step per call of :meth:`advance`.

    After each call, ``theta`` holds Θⁿ, ``u`` holds Uⁿ, ``du`` the increment Uⁿ − Uⁿ⁻¹,
    ``u_prev`` holds Uⁿ⁻¹ and ``pressure`` the contact force p at x = 1 (σ(1) = −p). For n = 0,
    ``du`` = Δt P u₁, so that δ⁰ = P u₁ (0 when b = 0: no inertia, no initial velocity).

    Subclasses solve a step in :meth:`_step`.
    """

    name = ""

    def __init__(self, disc: Discretisation, dt: float | None = None):
        scene = disc.scene
        self.disc = disc
        # Δt: the scene's, or another step's of an adaptive run (made inside disc.at_step(dt))
        self.dt = scene["time.dt"] if dt is None else dt
        self.clock = None  # the state's time where steps differ (adaptive), else n Δt
        self.law = contact.of_scene(scene)  # the obstacle's law, or the rigid obstacle
        # The heat exchange at x = 1: the constant law's k is in the operators; a variable law's
        # q adds the flux q (Θ(1) + offset) to the heat row of x = 1 (forms.copetti.exchange)
        self.exchange = exchange.of_scene(scene)
        self.offset = self.exchange.offset(scene["model.theta_A"])
        self.time_scheme = TIME_SCHEMES[scene["time.scheme"]]
        self.coupled = scene["model.a"] != 0.0  # a = 0: heat does not see motion, nor motion heat
        self.inertia = scene["model.b"] != 0.0
        self.tol, self.max_iterations = scene["solver.tol"], scene["solver.max_iterations"]
        weight = self.time_scheme.weight
        # Sources only where the scene has them (a manufactured solution): their loads are
        # N_f f with f interpolated at the nodes at the scheme's time of the step.
        self.sources = {name: scene.source_term(name) for name in ("heat", "momentum")}
        # The functions of the residuals beyond the unknown, by the names of their symbols
        # (Discretisation.symbol).
        heat_y = {"theta_prev": "Θ_prev", "du": "ΔU_other"}
        momentum_y = {"du_prev": "D_prev", "u_prev": "U_prev", "theta_prev": "Θ_prev",
                      "dtheta": "ΔΘ_other"}
        for name, F_y in (("heat", heat_y), ("momentum", momentum_y)):
            if self.sources[name] is not None:
                F_y["source"] = f"f_{name}"
        self._residuals = Residuals(disc, weight, heat_y, momentum_y)
        self.heat, self.momentum, self.contact_load = self.operators()
        self._coupled = None  # coupled_operator(), once made
        self.last = disc.nodes.size - 1  # the node x = 1
        self._index = disc.nodes.size + self.last  # of ΔU(1) in the unknowns [ΔΘ; ΔU]

        self.solve_heat = lu_solver(self.heat.A, "rodfem_heat_")

        # The state s = [Θⁿ; ΔUⁿ; Uⁿ] in one array (History reads its energy off it at once);
        # theta, du and u are views of its thirds. Both right-hand sides of a step, [h; m], are
        # one product with it: [h; m] = R s + [b_h; b_m].
        n = disc.nodes.size
        # PETSc's vectors, or NumPy's where the operators are (disc.petsc False)
        self.state, (self.theta, self.du, self.u) = stacked(3, n, disc.petsc)
        self.values = self.state.array  # the same memory, as a NumPy array
        self.u_prev = self.u.duplicate()
        self.R = block_matrix([[self.heat.N["theta_prev"], None, None],
                               [self.momentum.N["theta_prev"], self.momentum.N["du_prev"],
                                self.momentum.N["u_prev"]]])
        self.b, (b_h, b_m) = stacked(2, n, disc.petsc)
        self.heat.b.copy(b_h)
        self.momentum.b.copy(b_m)
        if any(f is not None for f in self.sources.values()):
            self._source_values, self._source_parts = stacked(2, n, disc.petsc)
            zero = self.heat.N["theta_prev"].duplicate()  # the same pattern, values zero
            zero.zeroEntries()
            self._source_matrix = block_diagonal(
                [self.heat.N["source"] if self.sources["heat"] else zero,
                 self.momentum.N["source"] if self.sources["momentum"] else zero])
        self.n = 0
        self.iterations = 0
        self.pressure = 0.0
        # The end x = 1 without mass nor viscosity, eliminated in Crank–Nicolson's steps
        self.massless = massless.MasslessEnd(self) if massless.needed(self) else None
        self._set_initial_state()

    def operators(self):
        """(heat, momentum, contact_load): the affine operators of (3.1) and (3.2) and the load
        e of a unit force at x = 1, read off the residuals at the forms' present constants (the
        run's Δt, or another's inside ``disc.at_step``).

        The residuals are named by all they depend on beyond the discretisation's own symbols
        and constants: a scene of the same discretisation, time scheme and sources reuses their
        compiled forms (Discretisation.load), and a run of the same constants their operators
        (the cache of Discretisation.arrays), without making the forms."""
        disc, residuals = self.disc, self._residuals
        weight = residuals.weight
        sourced = tuple(self.sources[name] is not None for name in ("heat", "momentum"))
        heat = disc.affine_operator(residuals.heat, "ΔΘ", residuals.heat_y, loads=("source",),
                                    key=("heat", weight, sourced))
        momentum = disc.affine_operator(residuals.momentum, "ΔU", residuals.momentum_y,
                                        loads=("source",), key=("momentum", weight, sourced))
        # The contact term p v(1) for p = 1: the load e of a unit force at x = 1.
        contact_load = disc.vector(residuals.contact, key=("contact",))
        return heat, momentum, contact_load

    def saved_state(self) -> dict[str, np.ndarray]:
        """Everything the next steps depend on, as arrays (a checkpoint): the state [Θ; D; U],
        Uⁿ⁻¹, and the step n, the contact force and the last count of iterations."""
        return {"state": self.values.copy(), "u_prev": self.u_prev.array_r.copy(),
                "step": np.array([self.n, self.iterations], dtype=np.int64),
                "pressure": np.array([self.pressure])}

    def restore(self, saved: dict[str, np.ndarray]) -> None:
        """Go back to the step of :meth:`saved_state` (of a method of the same scene)."""
        if saved["state"].shape != self.values.shape:
            raise ValueError("the saved state is of another mesh")
        self.values[:] = saved["state"]
        self.u_prev.array[:] = saved["u_prev"]
        for vector in (self.state, self.theta, self.du, self.u, self.u_prev):
            vector.stateIncrease()
        self.n, self.iterations = (int(v) for v in saved["step"])
        self.pressure = float(saved["pressure"][0])

    def take_state(self, other: Method) -> None:
        """:meth:`restore` of ``other``'s :meth:`saved_state` (a method of the same scene, of
        another step: an adaptive run's), without copying it twice."""
        self.values[:] = other.values
        self.u_prev.array[:] = other.u_prev.array_r
        for vector in (self.state, self.theta, self.du, self.u, self.u_prev):
            vector.stateIncrease()
        self.n, self.iterations = int(other.n), int(other.iterations)
        self.pressure = float(other.pressure)

    def coupled_operator(self) -> PETSc.Mat:
        """[[A_h, −N_U], [−N_Θ, A_m]]: (3.1)–(3.2) for [ΔΘⁿ; ΔUⁿ] without the contact term
        (made once; not to be changed)."""
        if self._coupled is None:
            N_u, N_theta = self.heat.N["du"].copy(), self.momentum.N["dtheta"].copy()
            N_u.scale(-1.0)
            N_theta.scale(-1.0)
            self._coupled = block_matrix([[self.heat.A, N_u], [N_theta, self.momentum.A]])
        return self._coupled

    def _set_initial_state(self) -> None:
        """Θ⁰ = P(θ₀ − L) (P(θ₀ + θ_A r) for θ_O = 0), U⁰ = P u₀ and P u₁, P the H¹_E
        projection: in 1D with P1, nodal interpolation. The node x = 0 is set to exactly 0 (the
        scene checked compatibility)."""
        scene = self.disc.scene
        x = self.disc.nodes.x
        clamped = x == 0.0
        params = scene.parameters
        theta0 = shifted(scene.initial("theta0")(x, params), x, scene)
        u0 = scene.initial("u0")(x, params)
        u1 = scene.initial("u1")(x, params) if self.inertia else np.zeros_like(x)
        for values in (theta0, u0, u1):
            values[clamped] = 0.0
        self.theta.array[:] = theta0
        self.u.array[:] = u0
        self.du.array[:] = self.dt * u1
        if self.massless is not None:  # the end where its equation puts it
            self.pressure = self.massless.settle(self.values, 0.0)
            self.du.array[-1] = self.dt * u1[-1]  # D⁰ = Δt P u₁ still
        self.u_prev.waxpy(-1.0, self.du, self.u)

    @property
    def first_step_special(self) -> bool:
        """Whether the next step is the paper scheme's first, U¹ = U⁰ + Δt P u₁."""
        return self.n == 0 and self.time_scheme.special_first_step(self.inertia)

    @property
    def velocity_back(self) -> PETSc.Vec:
        """The U at which σ's u_t ≈ (Uⁿ − back)/Δt is taken: Uⁿ⁻¹ in the paper's scheme; in
        Crank–Nicolson's, Uⁿ − Dⁿ, so that u_t is the velocity Vⁿ, not the half step's δⁿ."""
        if not self.time_scheme.midpoint_velocity:
            return self.u_prev
        back = self.u.copy()
        back.axpy(-1.0, self.du)
        return back

    def advance(self) -> int:
        """Go from step n to n + 1; return the iterations it took (the method's count)."""
        if self.first_step_special:
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
            self._source_load(rhs, None, self.dt if self.clock is None else self.clock + self.dt)
        self.solve_heat(rhs, dtheta)
        if self.exchange.variable:
            self._first_exchange(dtheta)
        self._accept(dtheta, self.du)
        self.iterations = 0
        self.pressure = 0.0

    def _first_exchange(self, dtheta: PETSc.Vec) -> None:
        """The exchange's flux φ = q (Θ¹(1) + offset) in the first step's (3.1), q at U¹(1)
        without contact force: a rank-one change of the heat operator, (A_h + q e eᵀ) ΔΘ¹ =
        rhs − q (Θ⁰(1) + offset) e, solved by Sherman–Morrison from ``dtheta`` = A_h⁻¹ rhs and
        v = A_h⁻¹(−e): ΔΘ¹ = dtheta + φ v, φ = q (Θ⁰(1) + offset + dtheta(1))/(1 − q v(1))."""
        last = self.last
        q = self.exchange.extra(self.u.getValue(last) + self.du.getValue(last), 0.0)
        if q == 0.0:
            return
        load, v = self.contact_load.copy(), dtheta.duplicate()
        load.scale(-1.0)
        self.solve_heat(load, v)
        T = (self.theta.getValue(last) + self.offset) + dtheta.getValue(last)
        dtheta.axpy(q * T / (1.0 - q * v.getValue(last)), v)

    def _step(self) -> None:
        raise NotImplementedError

    def _fixed_parts(self, rhs: PETSc.Vec) -> None:
        """The right-hand sides [h; m] of a step: what Θⁿ⁻¹, Dⁿ⁻¹ and Uⁿ⁻¹ contribute, and the
        sources at the time scheme's time of the step."""
        self.R.multAdd(self.state, self.b, rhs)
        if self.sources["heat"] is not None or self.sources["momentum"] is not None:
            t = (self.time_scheme.source_time(self.n, self.dt) if self.clock is None
                 else self.clock + self.time_scheme.weight * self.dt)
            self._source_load(None, rhs, t)

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
            raise SourceNotFinite(self.name, self.n + 1, (self.n + 1) * self.dt, name, t)
        if rhs is not None:
            self._source_matrix.multAdd(self._source_values, rhs, rhs)
        else:
            self.heat.N["source"].multAdd(self._source_parts[0], heat_rhs, heat_rhs)

    def _accept(self, dtheta: PETSc.Vec, du: PETSc.Vec) -> None:
        """Θⁿ = Θⁿ⁻¹ + ΔΘⁿ, Uⁿ = Uⁿ⁻¹ + ΔUⁿ, and Dⁿ: ΔUⁿ in the paper's scheme, Dⁿ = 2ΔUⁿ − Dⁿ⁻¹
        (the midpoint rule for the velocity) in Crank–Nicolson's. An end without mass has
        Dⁿ(1) = ΔUⁿ(1); one eliminated (:mod:`.massless`) is settled, and its force replaces
        ``pressure``."""
        self.theta.axpy(1.0, dtheta)
        self.u.copy(self.u_prev)
        self.u.axpy(1.0, du)
        if self.time_scheme.velocity_update(self.inertia):
            self.du.aypx(-1.0, du)
            self.du.axpy(1.0, du)
        elif du is not self.du:
            du.copy(self.du)
        if self.massless is not None:  # the end settled; its force is the step's
            self.pressure = self.massless.settle(self.values, self.u_prev.getValue(self.last))
        elif self.disc.redistributed:  # the end has no velocity of its own: Dⁿ(1) = ΔUⁿ(1)
            n = self.disc.nodes.size
            self.values[2 * n - 1] = self.values[3 * n - 1] - self.u_prev.getValue(self.last)

    def contact_force(self, y: float, c: float) -> float:
        """The elastic obstacle's force for Uⁿ(1) = y and Uⁿ⁻¹(1) = c, at the time scheme's
        rule (:mod:`rodfem.solver.time_schemes`)."""
        return self.time_scheme.contact_force(self.law, y, c)

    def exchange_extra(self, y: float, c: float, pressure: float) -> float:
        """A variable exchange law's q for Uⁿ(1) = y, Uⁿ⁻¹(1) = c and the step's contact force:
        the law at the time scheme's place of the end (``TimeScheme.exchange_place``)."""
        return self.exchange.extra(self.time_scheme.exchange_place(y, c), pressure)
