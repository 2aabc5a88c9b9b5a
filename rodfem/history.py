"""What a run records at every step: the rows of ``history.csv``.

The state is held whole, in node order, on every rank (:mod:`rodfem.nodes`), so point values and
the energy are read locally and every rank computes the same rows; rank 0 writes them.
"""

from __future__ import annotations

import numpy as np
import ufl
from petsc4py import PETSc

import forms.copetti as copetti
from rodfem.discretisation import Discretisation

COLUMNS = ("t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations")


class Energy:
    """Êⁿ of Remark 4.4 without its contact term, in the norms of the scheme's inner product:
    ½ (cᵀMc + b δᵀMδ + dᵀKd) + a θ_A zᵀd, with δ = Δd/Δt. The contact term needs only
    Uⁿ(1) and is added with the other point values in :meth:`History.take`."""

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        u, v = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
        self.M = disc.matrix(copetti.mass(u, v, disc.dx_m))
        self.K = disc.matrix(copetti.stiffness(u, v, disc.dx))
        self.z = disc.vector(copetti.thermal_load(disc.r, v, disc.dx))
        self.dt, self.b = scene["time.dt"], scene["model.b"]
        self.a_theta_A = scene["model.a"] * scene["model.theta_A"]
        self._y = self.M.createVecLeft()

    def bulk(self, theta: PETSc.Vec, u: PETSc.Vec, du: PETSc.Vec) -> float:
        """The energy of Θⁿ = theta, Uⁿ = u with Uⁿ − Uⁿ⁻¹ = du, less its contact term."""
        y = self._y
        self.M.mult(theta, y)
        thermal = y.dot(theta)
        self.M.mult(du, y)
        kinetic = self.b * y.dot(du) / self.dt**2
        self.K.mult(u, y)
        elastic = y.dot(u)
        return 0.5 * (thermal + kinetic + elastic) + self.a_theta_A * self.z.dot(u)


class History:
    """Collects one row per step n = 0..N and hands them out in blocks (:meth:`take`)."""

    def __init__(self, disc: Discretisation, block: int = 1024):
        scene = disc.scene
        self.dt = scene["time.dt"]
        self.epsilon, self.gap = scene["obstacle.epsilon"], scene["obstacle.gap"]
        self.energy = Energy(disc)
        self.last = disc.nodes.size - 1  # x = 1
        self.half = disc.nodes.interpolation(0.5)
        # Per step: n, iterations, Uⁿ(1), ΔUⁿ(1), Uⁿ(0.5), and the energy but its contact term.
        self._rows = np.zeros((block, 6))
        self._count = 0

    @property
    def full(self) -> bool:
        return self._count == len(self._rows)

    def record(self, state) -> None:
        """Record the step ``state.n`` of a scheme with vectors ``theta``, ``u`` and ``du``
        (Θⁿ, Uⁿ, Uⁿ − Uⁿ⁻¹) and its count of ``iterations``."""
        theta, u, du = state.theta, state.u, state.du
        nodes, weights = self.half
        u_half = float(np.dot(weights, u.getValues(nodes)))
        self._rows[self._count] = (state.n, state.iterations, u.getValue(self.last),
                                   du.getValue(self.last), u_half,
                                   self.energy.bulk(theta, u, du))
        self._count += 1

    def take(self) -> np.ndarray:
        """The rows recorded since the last call, with the columns ``COLUMNS``."""
        rows = self._rows[: self._count].copy()
        self._count = 0
        n, iterations, u_1, du_1, u_half, bulk = rows.T
        penetration = np.maximum(u_1 - self.gap, 0.0)
        energy = bulk + 0.5 * penetration**2 / self.epsilon
        sigma_1 = -penetration / self.epsilon + 0.0  # no -0 in the file
        ut_1 = du_1 / self.dt
        return np.column_stack([n * self.dt, u_1, u_half, ut_1, sigma_1, energy, iterations])
