r"""The time-T map of a scene's own scheme, from any state: what a periodic orbit is a fixed
point of (:mod:`rodfem.studies.steady.orbit`).

A state of the scheme is s = [Θ; D; U] (n nodes each) with D the displacement the velocity makes
over one step: Dⁿ = ΔUⁿ in the paper's scheme, Δt Vⁿ in Crank–Nicolson's. To compare states of
steps of different sizes the map is written in the velocity, x = [Θ; V; U] with V = D/h:

    P_T(x) = the state after N steps of h = T/N from x, its D divided by h.

N is held fixed while T moves, so P_T is as smooth in T as the steps are in h: the operators
of a step are polynomials in 1/h (:mod:`rodfem.solver.compiled.laurent`), and a new size is
formed in microseconds by the compiled loops' step family (:mod:`rodfem.solver.compiled.family`),
bound to one method: no form, no assembly, no factorisation on the PETSc side per shot.

A shot starts the method at step 1 (never the paper scheme's special first step) with Uⁿ⁻¹ =
U − D, and takes its N steps in one compiled call: its end state depends on x, T and N alone,
bit for bit (the loop keeps nothing from one call to the next but the state it is given). Every
rank holds the whole state and steps it alone (the loops are rank-local): every rank gets the
same numbers.
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.record import RAW_INDEX


class ShootingUnavailable(ValueError):
    """A scene whose steps have no compiled loop of any size (the PETSc loop only)."""


class Flow:
    """The time-T map of a method's scheme (the module's docstring). ``method`` is the scene's
    :class:`~rodfem.solver.methods.base.Method`, ``kernel`` its compiled loop and ``family`` the
    loop's :class:`~rodfem.solver.compiled.family.StepFamily`; the method's state is the
    shots' scratch."""

    def __init__(self, method, kernel, family):
        if kernel is None or family is None:
            raise ShootingUnavailable("the scene's steps have no compiled loop of any step size")
        self.method, self.kernel, self.family = method, kernel, family
        self.nodes = n = method.values.size // 3
        self.dt = method.dt
        self._loops: dict[float, object] = {}
        self._rows = np.zeros((1, kernel.width))
        # The clamped node x = 0 keeps Θ = D = U = 0 (its rows are the identity): not unknowns.
        clamped = np.flatnonzero(method.disc.nodes.x == 0.0)
        fixed = np.concatenate([clamped + k * n for k in range(3)])
        self.free = np.setdiff1d(np.arange(3 * n), fixed)
        self.u_1 = 3 * n - 1  # U(1) in x
        self.theta_1 = n - 1  # Θ(1) in x
        self._initial = method.values.copy()  # the scene's initial state, before any shot
        self._initial[n:2 * n] /= self.dt

    def initial(self) -> np.ndarray:
        """The method's initial state x = [Θ⁰; V⁰; U⁰] (the scene's initial values)."""
        return self._initial.copy()

    def loop(self, h: float):
        """The compiled loop of a step h (kept: a Newton solve shoots many times at a few h)."""
        h = float(h)
        if h not in self._loops:
            if len(self._loops) >= 64:
                self._loops.pop(next(iter(self._loops)))
            self._loops[h] = self.family.loop(h)
        return self._loops[h]

    def _load(self, x: np.ndarray, h: float) -> None:
        method, n = self.method, self.nodes
        if x.shape != (3 * n,):
            raise ValueError(f"a state of {3 * n} values, not {x.shape}")
        values = method.values
        values[:] = x
        values[n:2 * n] *= h
        method.u_prev.array[:] = values[2 * n:] - values[n:2 * n]
        for vector in (method.state, method.theta, method.du, method.u, method.u_prev):
            vector.stateIncrease()
        method.n, method.iterations, method.pressure = 1, 0, 0.0

    def _unload(self, h: float) -> np.ndarray:
        n = self.nodes
        x = self.method.values.copy()
        x[n:2 * n] /= h
        return x

    def shoot(self, x: np.ndarray, T: float, N: int) -> np.ndarray:
        """P_T(x): the state N steps of h = T/N after x (NotConverged where a step fails)."""
        h = T / N
        loop = self.loop(h)
        self._load(x, h)
        if len(self._rows) < N:
            self._rows = np.zeros((N, self._rows.shape[1]))
        loop.advance(N, self._rows)
        return self._unload(h)

    def series(self, x: np.ndarray, h: float, steps: int):
        """u(1), Θ(1) and the contact force p at each of ``steps`` steps of h from x (x's own
        first), and the state reached: the compiled loop's raw rows read."""
        loop = self.loop(h)
        self._load(x, h)
        rows = np.zeros((steps, self._rows.shape[1]))
        u_1, theta_1, p = np.empty(steps + 1), np.empty(steps + 1), np.empty(steps + 1)
        u_1[0], theta_1[0], p[0] = x[self.u_1], x[self.theta_1], np.nan
        values = self.method.values
        # one C call per step: Θ(1) is no raw slot; the rest is
        for k in range(steps):
            loop.advance(1, rows[k:k + 1])
            theta_1[k + 1] = values[self.theta_1]
        u_1[1:], p[1:] = rows[:, RAW_INDEX["u_1"]], rows[:, RAW_INDEX["pressure"]]
        return u_1, theta_1, p, self._unload(h)

    def run(self, x: np.ndarray, h: float, steps: int):
        """u(1) and p of each of ``steps`` steps of h from x (no Θ), and the state reached: a
        long time run in blocks of compiled steps."""
        loop = self.loop(h)
        self._load(x, h)
        rows = np.zeros((steps, self._rows.shape[1]))
        loop.advance(steps, rows)
        return (rows[:, RAW_INDEX["u_1"]].copy(), rows[:, RAW_INDEX["pressure"]].copy(),
                self._unload(h))
