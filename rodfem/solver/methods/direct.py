"""The exact method: each step of (3.1)–(3.2) in one solve and a scalar equation.

Without its contact term the step is linear, with a constant operator: the coupled operator
C = [[A_h, −N_U], [−N_Θ, A_m]] acting on [ΔΘⁿ; ΔUⁿ] (:meth:`Method.coupled_operator`), factored
once per run. Its response to a unit force at x = 1, q = C⁻¹[0; −e], is computed once too, and
w = −q_U(1) > 0 is the rod's compliance at x = 1 over one step. A step then solves

    C z = [h; m]                     (the step without contact; U(1) would be s = Uⁿ⁻¹(1) + z_U(1))
    [ΔΘⁿ; ΔUⁿ] = z + p q,            Uⁿ(1) = s − p w,

where the contact force p is the one scalar unknown left:

y + w p(y) = s for y = Uⁿ(1), with p the obstacle's force at the time scheme's rule (the law at
the new step, or Crank–Nicolson's discrete gradient from Uⁿ⁻¹(1)), or Signorini's multiplier of
the rigid obstacle, p = (s − g)/w where s > g. Each law solves it (:mod:`rodfem.model.contact`):
the paper's linear law in closed form (p = (s − g)/(ε + w) for s > g; a linear or quadratic
equation for Crank–Nicolson), any other to round-off.

Each is the unique solution, since y ↦ y + w p(y) is strictly increasing: this is the exact
solution of the step, with no tolerance to choose. Steps without contact (s ≤ g, and for
Crank–Nicolson Uⁿ⁻¹(1) ≤ g too) cost one comparison. With a = 0, C is block diagonal and the heat
and momentum operators are factored and solved apart.

A heat exchange that depends on the contact (``heat_exchange.law`` other than constant) adds a
flux φ at x = 1 and its response q_h = C⁻¹[−e; 0], made once; the step stays exact, with one
scalar equation in place of the contact's (:mod:`.exchange_step`). The constant law takes the
step above, untouched.
"""

from __future__ import annotations

from rodfem.discrete.arrays import Vector, petsc_vector
from rodfem.discrete.cache import conforms
from rodfem.discrete.discretisation import Discretisation
from rodfem.solver.errors import NoUniqueStep
from rodfem.solver.linalg import lu_factor, stacked
from rodfem.solver.methods.base import Method
from rodfem.solver.methods.exchange_step import ExchangeStep, NoUniqueRoot


class DirectMethod(Method):
    name = "direct"

    def __init__(self, disc: Discretisation, dt: float | None = None):
        super().__init__(disc, dt)
        n = disc.nodes.size
        self.x, (self.x_heat, self.x_momentum) = stacked(2, n, disc.petsc)
        self.rhs, (self.rhs_heat, self.rhs_momentum) = stacked(2, n, disc.petsc)
        self._x_values, self._u_1 = self.x.array, 3 * n - 1  # NumPy views; U(1) in the state
        self._solver = None  # the factored operator (_factored), on the first solve
        # The response to a unit contact force: q = C⁻¹[0; −e], and the compliance w = −q_U(1).
        # NumPy operators take it from the operator cache where it is (made by the same solve).
        if disc.petsc:
            self.response = self._unit_response()
        else:
            self.response = Vector(disc.arrays(
                repr(("direct response", self.time_scheme.weight, self.coupled)),
                lambda: {"values": self._unit_response().array_r.copy()},
                lambda found: conforms(found, {"values": ("f8", (2 * n,))}))["values"].copy())
        self.compliance = -self.response.getValue(self._index)
        if self.massless is not None:  # the response of the end's free position y
            self.compliance = -self.massless.moved(self.response.array_r)
        if not self.compliance > 0.0:
            raise RuntimeError(f"the compliance at x = 1 is {self.compliance:g}, not positive")
        self.exchange_step = None
        if self.exchange.variable:  # the response to a unit heat loss at x = 1: q_h = C⁻¹[−e; 0]
            # rhs was written through its part rhs_momentum, which PETSc does not see: its state
            # still says zero, and PETSc ≥ 3.20 skips zeroing a vector it knows to be zero
            self.rhs.stateIncrease()
            self.rhs.zeroEntries()
            self.contact_load.copy(self.rhs_heat)
            self.rhs_heat.scale(-1.0)
            self._solve(self.rhs, self.x)
            self.heat_response = self.x.copy()
            h, q = self.heat_response.array_r, self.response.array_r
            self.exchange_step = ExchangeStep(self, h[self._index], q[self.last], h[self.last])
        self.x.zeroEntries()

    def _factored(self):
        """``solve(rhs, x)``: C⁻¹ by PETSc's LU in reverse Cuthill–McKee order, or for a = 0
        A_h⁻¹ and A_m⁻¹ apart (factored here)."""
        wrap = (lambda v: v) if self.disc.petsc else petsc_vector
        if self.coupled:
            self.ksp, factor = lu_factor(self.coupled_operator(), "rodfem_direct_", "rcm")
            return lambda rhs, x: factor.solve(wrap(rhs), wrap(x))
        self.momentum_ksp, momentum_factor = lu_factor(self.momentum.A, "rodfem_momentum_")
        solve_heat, solve_momentum = self.solve_heat, momentum_factor.solve

        def solve(rhs, x):
            solve_heat(self.rhs_heat, self.x_heat)
            solve_momentum(wrap(self.rhs_momentum), wrap(self.x_momentum))

        return solve

    def _solve(self, rhs, x) -> None:
        if self._solver is None:
            self._solver = self._factored()
        self._solver(rhs, x)

    def _unit_response(self):
        """q = C⁻¹[0; −e], solved."""
        self.rhs.zeroEntries()
        self.contact_load.copy(self.rhs_momentum)
        self.rhs_momentum.scale(-1.0)
        response = self.x.duplicate()
        self._solve(self.rhs, self.x)
        self.x.copy(response)
        return response

    def _step(self) -> None:
        self._fixed_parts(self.rhs)
        self._solve(self.rhs, self.x)
        end = self.massless
        if end is None:  # the end's place Uⁿ(1) = s − w p, from c = Uⁿ⁻¹(1), under the law
            law, c = self.law, self.values[self._u_1]
            s = c + self._x_values[self._index]
        else:  # its free position yⁿ = s − w p, from c = yⁿ⁻¹, under the law in series
            law, c = end.law, end.position(self.values)
            s = c + end.moved(self._x_values)
        if self.exchange_step is not None:
            self._exchange(law, s, c)
            return
        pressure = 0.0
        if self.time_scheme.contact_needed(law, s, c):
            pressure = self.time_scheme.contact_solve(law, s, self.compliance, c)
            self.x.axpy(pressure, self.response)
        self.pressure = pressure
        self._accept(self.x_heat, self.x_momentum)
        self.iterations = 1

    def _exchange(self, law, s: float, c: float) -> None:
        """The step with the exchange's flux φ: x = z + p q_c + φ q_h (:mod:`.exchange_step`).
        An eliminated end (a = 0: the exchange does not move the rod) takes q at its settled
        place, once the step has put it there."""
        step, last = self.exchange_step, self.last
        T0 = (self.values[last] + self.offset) + step.weight * self._x_values[last]
        if self.massless is None:
            try:
                pressure, phi = step.solve(s, c, T0)
            except NoUniqueRoot as error:
                time = (self.n + 1) * self.dt if self.clock is None else self.clock + self.dt
                raise NoUniqueStep(self.name, self.n + 1, time, str(error)) from None
        else:
            pressure = (self.time_scheme.contact_solve(law, s, self.compliance, c)
                        if self.time_scheme.contact_needed(law, s, c) else 0.0)
        if pressure != 0.0:
            self.x.axpy(pressure, self.response)
        if self.massless is None and phi != 0.0:
            self.x.axpy(phi, self.heat_response)
        u_prev_1 = self.values[self._u_1]
        self._accept(self.x_heat, self.x_momentum)
        if self.massless is not None:
            phi = step.flux(self.values[self._u_1], u_prev_1, pressure, T0)[1]
            if phi != 0.0:
                n = self.disc.nodes.size
                self.values[:n] += phi * self.heat_response.array_r[:n]
                self.theta.stateIncrease()
                self.state.stateIncrease()
        if self.massless is None:  # an eliminated end's is its settled force (_accept)
            self.pressure = pressure
        self.iterations = 1


def compliance(scene, comm, with_law: bool = False):
    """w of a scene: the response of Uⁿ(1) to a unit contact force over one step (of the free
    position y of an eliminated end). Picard's iteration contracts by about w/ε while the rod
    touches the obstacle (``rodfem stability``). ``with_law``: (w, the law the step sees: the
    obstacle's, or the obstacle in series with the last cell for an eliminated end)."""
    from rodfem.scene import validate

    values = scene.data()
    values["solver"]["method"] = "direct"
    values["obstacle"]["kind"] = "elastic"
    method = DirectMethod(Discretisation(validate(values, scene.source), comm))
    if not with_law:
        return method.compliance
    law = method.law if method.massless is None else method.massless.law
    return method.compliance, law
