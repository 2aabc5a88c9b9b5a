"""The time schemes: where in a step (3.1)–(3.2) are taken, and what each scheme keeps.

Both schemes advance the same state [Θⁿ; Dⁿ; Uⁿ], Dⁿ the displacement the velocity makes over a
step, through the increments ΔΘⁿ, ΔUⁿ; each is one object, chosen by ``time.scheme``:

* ``paper``: (3.1)–(3.2) as printed, first order. The equations are taken at tⁿ (weight 1:
  Θ = Θⁿ⁻¹ + ΔΘⁿ), Dⁿ = ΔUⁿ (δⁿ = Dⁿ/Δt), the contact force at the new step, φ'(Uⁿ(1)), sources
  at tⁿ, and a first step of its own with inertia (U¹ = U⁰ + Δt P u₁, Θ¹ from (3.1)).
* ``crank-nicolson``: the implicit midpoint rule on the first-order system, second order. The
  equations are taken at t^{n−½} (weight ½), Dⁿ = 2ΔUⁿ − Dⁿ⁻¹ (the midpoint rule for the
  velocity, Dⁿ = Δt Vⁿ), the contact force is the discrete gradient of the obstacle's energy,
  sources at t^{n−½}, no special first step (docs/time-schemes.md).

The weight w enters the forms (``forms.copetti.heat_increment``, ``momentum_increment``): the
mass term of the momentum equation is b (ΔUⁿ − Dⁿ⁻¹)/(w Δt²) and every other term is taken at
Θⁿ⁻¹ + w ΔΘⁿ, Uⁿ⁻¹ + w ΔUⁿ.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class TimeScheme:
    name: str
    weight: float  # (3.1)–(3.2) taken at tⁿ⁻¹ + weight Δt
    midpoint_velocity: bool  # Dⁿ = 2ΔUⁿ − Dⁿ⁻¹ (with inertia), else Dⁿ = ΔUⁿ
    gradient_contact: bool  # the contact force is the discrete gradient, else φ'(Uⁿ(1))
    starts_with_velocity: bool  # with inertia, step 1 is U¹ = U⁰ + Δt P u₁ (the paper's)

    @property
    def order(self) -> int:
        """The order of accuracy in Δt: 1 taken at tⁿ (backward Euler), 2 at the midpoint
        (what the adaptive steps' error estimate and ``rodfem verify`` expect)."""
        return 1 if self.weight == 1.0 else 2

    def special_first_step(self, inertia: bool) -> bool:
        """Whether the step n = 0 → 1 is the paper's U¹ = U⁰ + Δt P u₁ (with inertia only)."""
        return self.starts_with_velocity and inertia

    def source_time(self, n: int, dt: float) -> float:
        """The time at which the step n → n + 1 takes the body sources."""
        return (n + self.weight) * dt

    def velocity_update(self, inertia: bool) -> bool:
        """Whether Dⁿ = 2ΔUⁿ − Dⁿ⁻¹ (the midpoint rule; without inertia D is not used)."""
        return self.midpoint_velocity and inertia

    def contact_force(self, law, y: float, c: float) -> float:
        """The elastic obstacle's force for Uⁿ(1) = y and Uⁿ⁻¹(1) = c."""
        return law.gradient(y, c) if self.gradient_contact else law.force(y)

    def contact_slope(self, law, y: float, c: float) -> float:
        """∂/∂y of :meth:`contact_force` (Newton's Jacobian entry)."""
        return law.gradient_slope(y, c) if self.gradient_contact else law.slope(y)

    def contact_solve(self, law, s: float, w: float, c: float) -> float:
        """The step's force p, with Uⁿ(1) = s − w p (rigid obstacle: the multiplier)."""
        if law.rigid:
            return law.solve(s, w)
        return law.solve_gradient(s, w, c) if self.gradient_contact else law.solve(s, w)

    def exchange_place(self, y: float, c: float) -> float:
        """The end displacement at which the step takes the heat exchange's q (a function of
        u(1) and the contact force, rodfem.model.exchange): Uⁿ(1) = y in the paper's scheme,
        the midpoint (y + c)/2 in Crank–Nicolson's, c = Uⁿ⁻¹(1)."""
        return y if self.weight == 1.0 else c + self.weight * (y - c)

    def contact_needed(self, law, s: float, c: float) -> bool:
        """Whether a step whose free end would reach s from c can meet the obstacle at all."""
        return s > law.gap or (self.gradient_contact and c > law.gap)


PAPER = TimeScheme("paper", 1.0, midpoint_velocity=False, gradient_contact=False,
                   starts_with_velocity=True)
CRANK_NICOLSON = TimeScheme("crank-nicolson", 0.5, midpoint_velocity=True,
                            gradient_contact=True, starts_with_velocity=False)
TIME_SCHEMES = {scheme.name: scheme for scheme in (PAPER, CRANK_NICOLSON)}
