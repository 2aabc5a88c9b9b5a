"""What a run records at every step: the rows of ``history.csv``.

Point values are taken on the rank that owns them and kept as per-rank shares; the shares of a
block of steps are summed over ranks in one reduction when the block is handed out, so a parallel
run pays one message per block, not per step.
"""

from __future__ import annotations

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import forms.copetti as copetti
from rodfem.discretisation import Discretisation
from rodfem.probes import PointProbe

COLUMNS = ("t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations")


class Energy:
    """Êⁿ of Remark 4.4 without its contact term, in the norms of the scheme's inner product:
    ½ (cᵀMc + b δᵀMδ + dᵀKd) + a θ_A zᵀd, with δ = (d − d_prev)/Δt."""

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        u, v = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
        self.M = disc.matrix(copetti.mass(u, v, disc.dx_m))
        self.K = disc.matrix(copetti.stiffness(u, v, disc.dx))
        self.z = disc.vector(copetti.thermal_load(disc.r, v, disc.dx))
        self.dt, self.b = scene["time.dt"], scene["model.b"]
        self.a_theta_A = scene["model.a"] * scene["model.theta_A"]
        self._x, self._y = self.M.createVecs()

    def bulk(self, theta: PETSc.Vec, u: PETSc.Vec, u_prev: PETSc.Vec) -> float:
        """Collective: every rank gets the value."""
        x, y = self._x, self._y
        self.M.mult(theta, y)
        thermal = y.dot(theta)
        x.waxpy(-1.0, u_prev, u)
        self.M.mult(x, y)
        kinetic = self.b * y.dot(x) / self.dt**2
        self.K.mult(u, y)
        elastic = y.dot(u)
        return 0.5 * (thermal + kinetic + elastic) + self.a_theta_A * self.z.dot(u)


class History:
    """Collects one row per step n = 0..N and hands them out in blocks (:meth:`take`)."""

    def __init__(self, disc: Discretisation, block: int = 1024):
        scene = disc.scene
        self.comm = disc.comm
        self.dt = scene["time.dt"]
        self.epsilon, self.gap = scene["obstacle.epsilon"], scene["obstacle.gap"]
        self.energy = Energy(disc)
        self.at_1 = PointProbe(disc.V, 1.0)
        self.at_half = PointProbe(disc.V, 0.5)
        # Per step: n, iterations, shares of Uⁿ(1), Uⁿ⁻¹(1), Uⁿ(0.5), and the bulk energy.
        self._rows = np.zeros((block, 6))
        self._count = 0

    @property
    def full(self) -> bool:
        return self._count == len(self._rows)

    def record(self, n: int, iterations: int, theta, u, u_prev) -> None:
        shares = (self.at_1.local(u), self.at_1.local(u_prev), self.at_half.local(u))
        self._rows[self._count] = (n, iterations, *shares, self.energy.bulk(theta, u, u_prev))
        self._count += 1

    def take(self) -> np.ndarray:
        """The recorded rows since the last call, as an array with the columns ``COLUMNS``
        (collective)."""
        rows = self._rows[: self._count].copy()
        self._count = 0
        if self.comm.size > 1:
            shares = np.ascontiguousarray(rows[:, 2:5])
            self.comm.Allreduce(MPI.IN_PLACE, shares)
            rows[:, 2:5] = shares
        n, iterations, u_1, u_1_prev, u_half, bulk = rows.T
        penetration = np.maximum(u_1 - self.gap, 0.0)
        energy = bulk + 0.5 * penetration**2 / self.epsilon
        sigma_1 = -penetration / self.epsilon + 0.0  # no -0 in the file
        ut_1 = (u_1 - u_1_prev) / self.dt
        return np.column_stack([n * self.dt, u_1, u_half, ut_1, sigma_1, energy, iterations])
