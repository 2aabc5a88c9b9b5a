"""The end x = 1 without mass (``discretisation.mass = "redistributed"``), in Crank–Nicolson's
scheme without viscosity: its equation is static, and it is eliminated.

With the redistributed mass the row of x = 1 in the momentum equation has no inertia; with ζ = 0
nothing else in it has a time derivative either, so it says that the end is in equilibrium:

    K_NN Uⁿ(1) + Σ_{j≠N} K_Nj U_j + p = 0     (a = 0: the scene's validation refuses a > 0,
                                               whose coupling would tie the end's temperature,
                                               and so its equation, to its own motion).

Crank–Nicolson takes every row at the half step, and for an equation without time derivative the
midpoint rule makes the end alternate about its equilibrium from step to step, and the contact
force with it. So the end is eliminated (:mod:`rodfem.model.contact.series`): the rest of the rod
pushes on the obstacle through the last cell from the end's free position

    y = Uⁿ(1) − (its residual without contact)/K_NN,

a linear function of the state that does not depend on Uⁿ(1) itself, with the obstacle in series
with the last cell's compliance 1/K_NN. The step takes the contact force as the discrete gradient
of that law between yⁿ⁻¹ and yⁿ (the rigid obstacle included: it becomes the linear law of
compliance 1/K_NN), which makes the step conserve the energy exactly where a = ζ = 0; then the
end is put where its equation at tⁿ holds, Uⁿ(1) = yⁿ − ψ'(yⁿ)/K_NN (= min(yⁿ, g) for the rigid
obstacle), with the contact stress σ(1) = −ψ'(yⁿ), and its displacement over the step is
Dⁿ(1) = Uⁿ(1) − Uⁿ⁻¹(1): no velocity of its own. The row of x = 1 in the step's linear system is
the same; only what is read off it changes.
"""

from __future__ import annotations

import numpy as np

from rodfem.model.contact.series import in_series


def needed(method) -> bool:
    """Whether a method's end x = 1 is eliminated (:func:`eliminated` of its scene)."""
    return eliminated(method.disc.scene)


def eliminated(scene) -> bool:
    """Whether a scene's end x = 1 is eliminated: redistributed mass, Crank–Nicolson, inertia,
    ζ = 0 (with ζ > 0 the end has the viscosity's time derivative and stays an unknown)."""
    from rodfem.scene.schema import REDISTRIBUTED
    from rodfem.solver.time_schemes import TIME_SCHEMES

    return (scene["discretisation.mass"] in REDISTRIBUTED
            and TIME_SCHEMES[scene["time.scheme"]].weight != 1.0 and scene["model.b"] != 0.0
            and scene["model.zeta"] == 0.0)


class MasslessEnd:
    """y, the end's free position, as a row on the state [Θ; D; U] (and on the unknowns
    [ΔΘ; ΔU] of a step), and the obstacle in series with the last cell."""

    def __init__(self, method):
        if method.sources["momentum"] is not None or method.coupled:
            raise ValueError("the end is eliminated only without a momentum source and with "
                             "a = 0 (the scene's validation refuses the others)")
        n, last = method.disc.nodes.size, method.last
        N_u, N_theta = method.momentum.N["u_prev"], method.momentum.N["theta_prev"]
        stiffness = -N_u.getValue(last, last)  # K_NN
        if not stiffness > 0.0:
            raise RuntimeError(f"the stiffness of the last cell is {stiffness:g}, not positive")
        row = np.zeros(3 * n)
        for block, matrix in ((0, N_theta), (2, N_u)):
            columns, values = matrix.getRow(last)
            row[block * n + columns] = values / stiffness
        row[2 * n + last] = 0.0  # 1 − K_NN/K_NN: y does not depend on U(1)
        self.row = row
        self.constant = method.momentum.b.getValue(last) / stiffness
        self.step_row = np.concatenate([row[:n], row[2 * n:]])  # on [ΔΘ; ΔU]
        self.spring = 1.0 / stiffness  # the last cell's compliance
        self.law = in_series(method.law, self.spring)
        # Where the end sits for a force p > 0: g + ε p for the linear law, exactly g for the
        # rigid obstacle; y − p/K_NN for any other law.
        self._closed = method.law.rigid or method.law.name == "linear"
        self._epsilon = method.law.epsilon
        self.u_1, self.d_1 = 3 * n - 1, 2 * n - 1

    def position(self, values: np.ndarray) -> float:
        """y of the state ``values`` = [Θ; D; U]."""
        return float(self.row @ values) + self.constant

    def moved(self, x: np.ndarray) -> float:
        """How far a step's increments ``x`` = [ΔΘ; ΔU] move y."""
        return float(self.step_row @ x)

    def moved_by(self, dtheta: np.ndarray, du: np.ndarray) -> float:
        """:meth:`moved` for the increments given apart."""
        n = du.size
        return float(self.step_row[:n] @ dtheta) + float(self.step_row[n:] @ du)

    def settle(self, values: np.ndarray, u_prev_1: float) -> float:
        """Put the end where its equation holds for the state ``values`` (Uⁿ(1), and Dⁿ(1) from
        Uⁿ⁻¹(1) = ``u_prev_1``); return the contact force there, ψ'(y)."""
        y = self.position(values)
        values[self.u_1] = self.displacement(y, force := self.law.force(y))
        values[self.d_1] = values[self.u_1] - u_prev_1
        return force

    def displacement(self, y: float, force: float) -> float:
        """U(1) where the end's equation holds at the free position y under the force ψ'(y):
        y where it is free; in contact g + ε ψ'(y) for the linear law (exactly g for the rigid
        obstacle), y − ψ'(y)/K_NN for any other."""
        if not force > 0.0:
            return y
        return self.law.gap + self._epsilon * force if self._closed else y - self.spring * force

    def displacement_slope(self, y: float) -> float:
        """d/dy of :meth:`displacement` at y with ψ'(y) (Newton's Jacobian of a variable heat
        exchange, which takes U(1))."""
        if self.law.force(y) > 0.0:
            slope = self.law.slope(y)
            return self._epsilon * slope if self._closed else 1.0 - self.spring * slope
        return 1.0
