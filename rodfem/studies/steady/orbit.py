r"""A periodic orbit of a scene's scheme, found by shooting: the Newton method on the time-T map,
the time run it starts from, and its Floquet multipliers (``rodfem periodic``:
:mod:`rodfem.studies.steady.periodic`).

**The orbit as a fixed point.** With P_T the time-T map of the scheme (N steps of h = T/N,
:mod:`rodfem.solver.shooting`), a periodic orbit through the state x is a solution (x, T) of

    P_T(x) − x = 0,        U(1) − u* = 0,

the second equation (the phase condition) fixing where on the orbit x lies: where u(1) passes
the steady state's u* (the orbit winds about it). N is chosen from the scene's step as the
fewest steps with h ≤ time.dt at the guess of T, and held fixed, so that P_T is smooth in
T; where the period found asks for another N, Newton goes on with that one, so that h is
the largest step ≤ time.dt that divides the period. The unknowns are the 3(n − 1) values of
[Θ; V; U] off the clamped node and T.

**Newton's method.** The Jacobian [[M − I, ∂P/∂T], [e_u(1)ᵀ, 0]] is formed by forward
differences: M = ∂P/∂x, the monodromy matrix, a column per unknown, each column one shot (its
perturbation 10⁻⁷ of its field's size), the columns dealt to the MPI ranks and gathered. The
system is bordered where M − I is singular (M has the trivial multiplier 1, the orbit's own
direction), and its border is not (e_u(1) is not orthogonal to the flow where u(1) moves). A step
that does not lower the residual is halved. The residual is the largest of ‖P_T(x) − x‖∞ over
each field's size ‖x‖∞ (Θ, V, U apart).

**The start.** A time run of the scheme from the steady state with a small velocity (the caller's:
:data:`rodfem.studies.steady.periodic.KICK`), in windows of 20 periods of the critical pair, until
two windows agree on the period to 10⁻³ and the amplitude to 10⁻²; then to the next upward crossing
of u*. A run that returns to the state (its oscillation below 10⁻⁹ of it) has no orbit to find.

**Floquet multipliers.** The eigenvalues of M at the orbit, M by central differences (the mean
of forward and backward ones), the trivial multiplier being the one whose eigenvector is closest
in direction to ∂P/∂T (the flow). Their error is taken as the larger of |trivial − 1| (it is 1
for an exact orbit of a flow) and the difference of the leading moduli between the forward and
the backward matrices (the contact law's kink makes the map only piecewise smooth). The orbit is
stable where every other multiplier is inside the unit circle by more than that error, unstable
where one is outside by more, and undecided otherwise.

Every rank computes the same numbers (the shots are rank-local and bit for bit the same for the
same input; the Jacobian's columns are gathered, not summed).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rodfem.solver.errors import NotConverged

TOLERANCE = 1e-10  # Newton's residual (the module's docstring)
MAX_ITERATIONS = 12
PERTURBATION = 1e-7  # of a field's size, for the differences
SETTLE_PERIODS = 20  # the start's window, in periods of the critical pair
SETTLE_TIME = 2000.0  # the longest start, in time units


class NoOrbit(RuntimeError):
    """No periodic orbit found; the message says why."""


@dataclasses.dataclass
class Orbit:
    """A periodic orbit of the scheme: its period T = N h, its state x at u(1) = u* (x =
    [Θ; V; U]), what it does over one period, its Floquet multipliers (the non-trivial ones by
    decreasing modulus), their error, its stability (None where undecided) and Newton's
    residual and iterations."""

    period: float
    steps: int
    state: np.ndarray
    u_star: float
    residual: float
    iterations: int
    u_min: float = math.nan
    u_max: float = math.nan
    amplitude: float = math.nan
    contact_fraction: float = math.nan
    multipliers: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, complex))
    trivial: complex = complex(math.nan)
    multiplier_error: float = math.nan
    stable: bool | None = None


@dataclasses.dataclass
class Start:
    """A time run settled near the orbit: the state at an upward crossing of u*, the period
    and the last period's time, u(1) and p (for the figure), and whether it settled."""

    state: np.ndarray
    period: float
    t: np.ndarray
    u_1: np.ndarray
    p: np.ndarray
    settled: bool


# -- Newton ---------------------------------------------------------------------------------------

class Shooting:
    """The bordered system of one orbit search on a flow: N fixed, the phase u(1) = u*."""

    def __init__(self, flow, N: int, u_star: float, comm):
        self.flow, self.N, self.u_star, self.comm = flow, int(N), float(u_star), comm
        self.free = flow.free
        self.anchor = int(np.flatnonzero(self.free == flow.u_1)[0])
        n = flow.nodes
        self.fields = [np.flatnonzero((self.free >= k * n) & (self.free < (k + 1) * n))
                       for k in range(3)]

    def sizes(self, x: np.ndarray) -> np.ndarray:
        """Each free unknown's field's size ‖x_field‖∞ (Θ, V, U; 1 where a field is 0)."""
        z, out = x[self.free], np.empty(self.free.size)
        for mine in self.fields:
            size = float(np.max(np.abs(z[mine]))) if mine.size else 1.0
            out[mine] = size if size > 0.0 else 1.0
        return out

    def residual(self, x: np.ndarray, end: np.ndarray, sizes: np.ndarray) -> float:
        """The larger of ‖P_T(x) − x‖∞ over each field's size and |U(1) − u*| over U's."""
        phase = abs(x[self.flow.u_1] - self.u_star) / sizes[self.anchor]
        return max(float(np.max(np.abs(end - x)[self.free] / sizes)), phase)

    def columns(self, x: np.ndarray, T: float, base: np.ndarray, sizes: np.ndarray,
                sign: float = 1.0) -> np.ndarray:
        """[∂P/∂x_free, ∂P/∂T] (free rows) by one-sided differences (``sign`` +1 forward, −1
        backward), the columns dealt to the ranks and gathered."""
        from rodfem.studies.common import deal

        count = self.free.size + 1
        mine = deal([1.0] * count, self.comm.size)[self.comm.rank]
        out = {}
        for j in mine:
            if j < self.free.size:
                step = sign * PERTURBATION * sizes[j]
                shifted = x.copy()
                shifted[self.free[j]] += step
                end = self.flow.shoot(shifted, T, self.N)
            else:
                step = sign * PERTURBATION * T
                end = self.flow.shoot(x, T + step, self.N)
            out[j] = (end[self.free] - base[self.free]) / step
        for part in self.comm.allgather(out):
            out.update(part)
        return np.column_stack([out[j] for j in range(count)])

    def solve(self, x: np.ndarray, T: float, tol: float = TOLERANCE,
              max_iterations: int = MAX_ITERATIONS) -> tuple[np.ndarray, float, float, int]:
        """Newton from (x, T): (x, T, residual, iterations); NoOrbit if it does not reach
        ``tol``."""
        flow, free, N = self.flow, self.free, self.N
        sizes = self.sizes(x)
        x = x.copy()
        end = self._shoot(x, T)
        r = self.residual(x, end, sizes)
        for iteration in range(1, max_iterations + 1):
            if r <= tol:
                return x, T, r, iteration - 1
            J = self.columns(x, T, end, sizes)
            m = free.size
            A = np.zeros((m + 1, m + 1))
            A[:m, :] = J
            A[:m, :m] -= np.eye(m)
            A[m, self.anchor] = 1.0
            rhs = -np.concatenate([(end - x)[free], [x[flow.u_1] - self.u_star]])
            # scaled unknowns: each by its field's size, T by itself
            scale = np.concatenate([sizes, [T]])
            try:
                delta = np.linalg.solve(A * scale, rhs) * scale
            except np.linalg.LinAlgError:
                raise NoOrbit("Newton's system is singular") from None
            for _ in range(8):
                trial = x.copy()
                trial[free] += delta[:m]
                T_trial = T + delta[m]
                if T_trial <= 0.0 or not np.all(np.isfinite(trial)):
                    delta *= 0.5
                    continue
                try:
                    end_trial = self._shoot(trial, T_trial)
                except NoOrbit:
                    delta *= 0.5
                    continue
                r_trial = self.residual(trial, end_trial, sizes)
                if r_trial < r:
                    break
                delta *= 0.5
            else:
                raise NoOrbit(f"Newton's method stalls at residual {r:.3g}")
            x, T, end, r = trial, T_trial, end_trial, r_trial
        if r <= tol:
            return x, T, r, max_iterations
        raise NoOrbit(f"Newton's method did not converge in {max_iterations} iterations "
                      f"(residual {r:.3g})")

    def _shoot(self, x: np.ndarray, T: float) -> np.ndarray:
        try:
            end = self.flow.shoot(x, T, self.N)
        except NotConverged as error:
            raise NoOrbit(f"a step failed: {error}") from None
        if not np.all(np.isfinite(end)):
            raise NoOrbit("a shot's state is not finite")
        return end

    def floquet(self, x: np.ndarray, T: float) -> tuple[np.ndarray, complex, float]:
        """The non-trivial multipliers (by decreasing modulus), the trivial one and their
        error (the module's docstring)."""
        sizes = self.sizes(x)
        base = self.flow.shoot(x, T, self.N)
        m = self.free.size
        forward = self.columns(x, T, base, sizes, 1.0)
        backward = self.columns(x, T, base, sizes, -1.0)
        central = 0.5 * (forward + backward)
        values, vectors = np.linalg.eig(central[:, :m])
        tangent = central[:, m]
        tangent = tangent / np.linalg.norm(tangent)
        alignment = np.abs(vectors.conj().T @ tangent) / np.linalg.norm(vectors, axis=0)
        trivial_index = int(np.argmax(alignment))
        trivial = complex(values[trivial_index])
        others = np.delete(values, trivial_index)
        others = others[np.lexsort((-others.imag, -np.abs(others)))]
        leading = 6
        moduli = [np.sort(np.abs(np.linalg.eigvals(J[:, :m])))[::-1][:leading]
                  for J in (forward, backward)]
        error = max(abs(trivial - 1.0), float(np.max(np.abs(moduli[0] - moduli[1]))))
        return others, trivial, error


# -- the start ----------------------------------------------------------------------------------

def upward(values: np.ndarray) -> np.ndarray:
    """The indices k where values crosses 0 upward between k − 1 and k."""
    return np.flatnonzero((values[:-1] < 0.0) & (values[1:] >= 0.0)) + 1


def settle(flow, x: np.ndarray, u_star: float, period: float,
           max_time: float = SETTLE_TIME) -> Start:
    """A time run of the scheme (its own step) from x until nearly periodic (the module's
    docstring); NoOrbit if it returns to the steady state."""
    dt = flow.dt
    window = max(int(round(SETTLE_PERIODS * period / dt)), 1)
    before, t_run, size = None, 0.0, max(abs(u_star), 1e-300)
    settled = False
    while t_run < max_time:
        u_1, p, x = _run(flow, x, dt, window)
        t_run += window * dt
        distance = u_1 - u_star
        amplitude = float(np.max(np.abs(distance[len(distance) // 2:])))
        if amplitude < 1e-9 * size:
            raise NoOrbit(f"a run from the steady state returns to it (|u(1) - u*| = "
                          f"{amplitude:.2g} by t = {t_run:g}): the state is stable for this "
                          "scheme")
        ups = upward(distance)
        if ups.size < 3:
            before = None
            continue
        now = (float(np.mean(np.diff(ups))) * dt, amplitude)
        if before is not None and abs(now[0] - before[0]) < 1e-3 * now[0] \
                and abs(now[1] - before[1]) < 1e-2 * now[1]:
            settled = True
            break
        before = now
    if before is None and not settled:
        raise NoOrbit(f"a run from the steady state oscillates about it without a period by "
                      f"t = {t_run:g}")
    period = now[0]
    # to the next upward crossing of u*, then one period more (the figure's)
    steps = int(np.ceil(period / dt)) + 2
    u_1, p, x_end = _run(flow, x, dt, steps)
    ups = upward(np.concatenate([[x[flow.u_1]], u_1]) - u_star)
    k = int(ups[0]) if ups.size else 0
    if k:
        _, _, x = _run(flow, x, dt, k)
    u_1, _, p, _ = flow.series(x, dt, int(round(period / dt)))
    t = t_run + k * dt + dt * np.arange(u_1.size)
    return Start(state=x, period=period, t=t, u_1=u_1, p=p, settled=settled)


def _run(flow, x, h, steps):
    try:
        return flow.run(x, h, steps)
    except NotConverged as error:
        raise NoOrbit(f"a step of the start's time run failed: {error}") from None


# -- an orbit found and described ---------------------------------------------------------------

def find(flow, scene, u_star: float, x: np.ndarray, period: float, comm,
         tol: float = TOLERANCE) -> Orbit:
    """The orbit from the guess (x, period): Newton, then the orbit over one period and its
    multipliers. NoOrbit where Newton fails or reaches the steady state."""
    T, iterations = period, 0
    for _ in range(4):  # N from the period found: the fewest steps of h ≤ time.dt
        N = steps_of(T, scene["time.dt"])
        shooting = Shooting(flow, N, u_star, comm)
        x, T, residual, more = shooting.solve(x, T, tol)
        iterations += more
        if steps_of(T, scene["time.dt"]) == N:
            break
    else:
        raise NoOrbit(f"the period {T:.6g} keeps changing its number of steps")
    orbit = Orbit(period=float(T), steps=int(N), state=x, u_star=float(u_star),
                  residual=float(residual), iterations=int(iterations))
    record = trace(flow, scene, orbit)
    u_1, p = record["u_1"], record["p"]
    orbit.u_min, orbit.u_max = float(u_1.min()), float(u_1.max())
    orbit.amplitude = float(np.max(np.abs(u_1 - u_star)))
    if orbit.u_max - orbit.u_min <= 1e-7 * max(abs(u_star), 1e-300):
        raise NoOrbit(f"Newton's method reached the steady state (u(1) varies by "
                      f"{orbit.u_max - orbit.u_min:.2g} over the period), not an orbit")
    orbit.contact_fraction = float(np.mean(p[1:] > 0.0))
    orbit.multipliers, trivial, error = shooting.floquet(x, T)
    orbit.trivial, orbit.multiplier_error = complex(trivial), float(error)
    largest = float(np.abs(orbit.multipliers[0])) if orbit.multipliers.size else 0.0
    error = orbit.multiplier_error
    orbit.stable = True if largest < 1.0 - error else False if largest > 1.0 + error else None
    return orbit


def steps_of(period: float, dt: float) -> int:
    """The fewest steps N of h = period/N ≤ dt."""
    N = max(int(np.ceil(period / dt)), 1)
    return N + 1 if period / N > dt else N


def trace(flow, scene, orbit: Orbit) -> dict[str, np.ndarray]:
    """One period of the orbit, at each of its N + 1 steps: t, u(1), θ(1), p and σ(1) = −p (the
    contact force of the step that reached it; at t = 0 the period's last)."""
    from rodfem.model.robin import temperature

    h = orbit.period / orbit.steps
    u_1, Theta_1, p, _ = flow.series(orbit.state, h, orbit.steps)
    p[0] = p[-1]
    theta_1 = temperature(Theta_1, np.ones_like(Theta_1), scene)
    return {"t": h * np.arange(u_1.size), "u_1": u_1, "theta_1": theta_1, "p": p, "sigma_1": -p}
