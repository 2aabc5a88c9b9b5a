"""What a run records at every step: the rows of ``history.h5``.

The state is held whole, in node order, on every rank (:mod:`rodfem.discrete.nodes`), so every
rank computes the same rows; rank 0 writes them. A method keeps Θⁿ, ΔUⁿ = Uⁿ − Uⁿ⁻¹ and Uⁿ in one
stacked vector s, whose energy is a single product with a block-diagonal matrix, and whose point
values are read off its array.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.arrays import Vector
from rodfem.discrete.discretisation import Discretisation
from rodfem.discrete.nodes import block_diagonal
from rodfem.model import contact, exchange
from rodfem.output.columns import RAW, RAW_INDEX, Context, columns_of, for_scene, readings

if TYPE_CHECKING:
    from petsc4py import PETSc


class Energy:
    """Êⁿ of Remark 4.4 in the norms of the scheme's inner product, without its contact term:

        ½ (ΘᵀMΘ + b ΔUᵀMΔU/Δt² + UᵀKU) + a θ_A zᵀU − a θ_O z_sᵀU
            = ½ sᵀ diag(M, bM/Δt², K) s + (a θ_A z − a θ_O z_s)ᵀU

    for s = [Θ; ΔU; U], with M, K, z = (r, η_i') and z_s = (s, η_i') from ``forms.copetti.mass``,
    ``stiffness``, ``thermal_load``: the last two are −a (L, U_x) for the lifting
    L = −θ_A r + θ_O s (docs/model.md). The contact term needs only U(1) and is added per
    block in :meth:`History.take`."""

    def __init__(self, disc: Discretisation):
        scene = disc.scene
        def form(make):
            """``make(copetti, u, v)`` for P1's trial and test functions u, v, made when called:
            only where the operator is not cached (Discretisation.arrays)."""
            def made():
                import ufl

                import forms.copetti as copetti

                return make(copetti, ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V))
            return made

        M = disc.matrix(form(lambda c, u, v: c.mass(u, v, disc.dx_m)), key=("mass",))
        K = disc.matrix(form(lambda c, u, v: c.stiffness(u, v, disc.dx)), key=("stiffness",))
        kinetic = M.copy() if not disc.redistributed else disc.matrix(
            form(lambda c, u, v: c.inertia(u, v, disc.dx_b)), key=("inertia",))
        kinetic.scale(scene["model.b"] / scene["time.dt"] ** 2)
        self.E = block_diagonal([M, kinetic, K])
        self.z = disc.vector(form(lambda c, u, v: c.thermal_load(disc.r, v, disc.dx)),
                             key=("thermal load",))
        self.a_theta_A = scene["model.a"] * scene["model.theta_A"]
        n = disc.nodes.size
        # ½ sᵀE s + wᵀU = ½ (E s + 2w)ᵀs with w = [0; 0; a θ_A z − a θ_O z_s]: one product, one
        # dot (z_s only for an obstacle whose temperature is not 0)
        if disc.petsc:
            from petsc4py import PETSc

            self.two_w = PETSc.Vec().createSeq(3 * n, comm=PETSc.COMM_SELF)
        else:
            self.two_w = Vector.zeros(3 * n)
        self.two_w.array[2 * n:] = 2.0 * self.a_theta_A * self.z.array_r
        a_theta_O = scene["model.a"] * scene["obstacle.temperature"]
        if a_theta_O != 0.0:
            z_s = disc.vector(form(lambda c, u, v: c.thermal_load(disc.s, v, disc.dx)),
                              key=("obstacle thermal load",))
            self.two_w.array[2 * n:] -= 2.0 * a_theta_O * z_s.array_r
        self._y = self.two_w.duplicate()

    def __call__(self, s: PETSc.Vec) -> float:
        """The bulk energy of the state s = [Θ; ΔU; U]."""
        self.E.multAdd(s, self.two_w, self._y)
        return 0.5 * self._y.dot(s)


class Readings:
    """The readings of a run (:func:`rodfem.output.columns.readings`): each the value of a field
    at a point, an affine functional c + Σ_t w_t s[i_t] of the state s = [Θ; D; U], as a table
    padded with zero weights (``count`` × ``terms``), summed in the order of t from c: as
    ``record.h``'s ``rr_read`` does, bit for bit."""

    def __init__(self, pointwise, reads):
        self.reads = reads
        functionals = [pointwise.reading(field, x) for field, x in reads]
        self.count = len(functionals)
        self.terms = max((len(w) for w, _ in functionals), default=0)
        self.index = np.zeros((self.count, self.terms), dtype=np.intc)
        self.weight = np.zeros((self.count, self.terms))
        self.constant = np.array([c for _, c in functionals], dtype=float)
        for r, (weights, _) in enumerate(functionals):
            for t, (i, w) in enumerate(sorted(weights.items())):
                self.index[r, t], self.weight[r, t] = i, w

    def __call__(self, s: np.ndarray, out: np.ndarray) -> None:
        value = self.constant.copy()
        for t in range(self.terms):
            value += self.weight[:, t] * s[self.index[:, t]]
        out[:] = value


class History:
    """Collects one row per step n = 0..N and hands them out in blocks (:meth:`take`): the raw
    slots of :data:`RAW`, then the readings the scene's columns need."""

    def __init__(self, disc: Discretisation, block: int = 1024, pointwise=None):
        scene = disc.scene
        self.context = Context(scene["time.dt"], contact.of_scene(scene),
                               exchange.of_scene(scene))
        self.columns = for_scene(scene)
        reads = readings(self.columns)
        if reads and pointwise is None:
            from rodfem.output.pointwise import Pointwise

            pointwise = Pointwise(disc)
        self.readings = Readings(pointwise, reads) if reads else None
        self.width = len(RAW) + len(reads)
        self.energy = Energy(disc)
        # Positions in the state [Θ; ΔU; U] of ΔU(1), U(1) and the nodes around x = 0.5.
        n = disc.nodes.size
        self.du_1, self.u_1 = 2 * n - 1, 3 * n - 1
        (i, *rest), (w, *rest_w) = disc.nodes.interpolation(0.5)
        self.half = (2 * n + int(i), float(w), 2 * n + (int(rest[0]) if rest else int(i)),
                     rest_w[0] if rest else 0.0)
        # Per step, the raw row of rodfem.solver.record.RAW, then the readings.
        self._rows = np.zeros((block, self.width))
        self._slots = tuple(RAW_INDEX[name] for name in ("n", "iterations", "u_1", "d_1",
                                                         "u_half", "bulk_energy", "pressure"))
        self._count = 0
        # Adaptive steps: per row the time, the step and whether it ended at a contact event.
        self.adaptive = bool(scene["time.adaptive"])
        self._clock = np.zeros((block, 3)) if self.adaptive else None
        self.steps = np.zeros(0, dtype=int)  # the steps n of the rows of the last take()

    @property
    def full(self) -> bool:
        return self._count == len(self._rows)

    def record(self, state, clock: tuple[float, float, bool] | None = None) -> None:
        """Record the step ``state.n`` of a method (:class:`rodfem.solver.methods.base.Method`):
        its state [Θⁿ; ΔUⁿ; Uⁿ] (``state``, its array ``values``), its count of ``iterations`` and
        its contact force ``pressure``; with adaptive steps, ``clock`` = (tⁿ, Δtⁿ, event)."""
        if self._clock is not None:
            self._clock[self._count] = clock
        bulk = self.energy(state.state)
        s = state.values
        i, w, j, v = self.half
        row = self._rows[self._count]
        n, iterations, u_1, d_1, u_half, bulk_energy, pressure = self._slots
        row[n], row[iterations], row[pressure] = state.n, state.iterations, state.pressure
        row[u_1], row[d_1], row[u_half] = s[self.u_1], s[self.du_1], w * s[i] + v * s[j]
        row[bulk_energy] = bulk
        if self.readings is not None:
            self.readings(s, row[len(RAW):])
        self._count += 1

    @property
    def count(self) -> int:
        """How many rows the block holds."""
        return self._count

    @property
    def free(self) -> int:
        """How many rows fit before the block is full."""
        return len(self._rows) - self._count

    def reserve(self, steps: int) -> np.ndarray:
        """The next ``steps`` rows, for a compiled loop to fill with what :meth:`record` stores;
        :meth:`commit` counts them in."""
        return self._rows[self._count:self._count + steps]

    def reserve_clock(self, steps: int) -> np.ndarray:
        """With adaptive steps, the (t, Δt, event) of the rows :meth:`reserve` gives."""
        return self._clock[self._count:self._count + steps]

    def commit(self, steps: int) -> None:
        self._count += steps

    # Checked for finiteness, most telling first; every value of the state enters the bulk
    # energy, so a non-finite Θ, D or U anywhere makes it non-finite.
    CHECKED = {"u_1": "u(1)", "pressure": "the contact force", "d_1": "the velocity at x = 1",
               "u_half": "u(0.5)", "bulk_energy": "the energy (so Θ, U or the velocity)"}

    def first_non_finite(self, since: int) -> tuple[int, str] | None:
        """The first of the rows recorded since the ``since``-th (of the block) with a value that
        is not finite, and that value's meaning; those rows are dropped from the block."""
        slots = [RAW_INDEX[name] for name in self.CHECKED]
        rows = self._rows[since:self._count, slots]
        bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
        if bad.size == 0:
            return None
        first = int(bad[0])
        quantity = list(self.CHECKED.values())[int(np.flatnonzero(~np.isfinite(rows[first]))[0])]
        step = int(self._rows[since + first, RAW_INDEX["n"]])
        self._count = since + first
        return step, quantity

    def take(self) -> np.ndarray:
        """The rows recorded since the last call, with the scene's columns (``columns``)."""
        rows = self._rows[: self._count].copy()
        clock = None
        if self._clock is not None:
            t, dt, event = self._clock[: self._count].T.copy()
            clock = {"t": t, "dt": dt, "event": event}
        self.steps = rows[:, RAW_INDEX["n"]].astype(int)
        self._count = 0
        return columns_of(rows, self.context, self.columns,
                          self.readings.reads if self.readings else (), clock)
