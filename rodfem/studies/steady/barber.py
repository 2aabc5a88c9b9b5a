r"""Time runs of thermoelastic contact read against the steady analysis: where a run settles,
how fast, and the period of the contact it keeps making and breaking when no state is stable.

The steady states and their spectra come from :mod:`rodfem.model.steady` and
:mod:`rodfem.solver.spectrum`; this module starts runs at (or near) a state, runs them without
files, and measures what the analysis predicts of them:

* a stable state with growth rate γ < 0 is approached as e^{γt} (the slowest mode), so the
  envelope of the distance to it shrinks by e^{γ(t₁ − t₀)} between two late windows;
* an unstable state whose rightmost eigenvalues are a complex pair γ ± iω (a Hopf bifurcation)
  is left in oscillations of period 2π/ω that grow as e^{γt} while they are small.

Every rank computes the same numbers.
"""

from __future__ import annotations

import dataclasses

import numpy as np

HISTORY = "output.history=['theta_1', 'contact_force']"


@dataclasses.dataclass(frozen=True)
class Run:
    """What a run recorded at every step: the time, u(1), σ(1), θ(1) and the contact force."""

    t: np.ndarray
    u_1: np.ndarray
    sigma_1: np.ndarray
    theta_1: np.ndarray
    p: np.ndarray
    status: str


def run(scene_name: str, overrides: list[str], comm=None) -> Run:
    """Simulate a scene without files (its history kept in memory, on every rank)."""
    from mpi4py import MPI

    import rodfem.scene
    from rodfem.output.columns import for_scene
    from rodfem.run import simulate

    scene = rodfem.scene.load(scene_name, [*overrides, HISTORY])
    result = simulate(scene, None, comm if comm is not None else MPI.COMM_WORLD, progress=False)
    names = [column.name for column in for_scene(scene)]
    column = {name: result.history[:, i] for i, name in enumerate(names)}
    return Run(t=column["t"], u_1=column["u_1"], sigma_1=column["sigma_1"],
               theta_1=column["theta_1"], p=column["contact_force"], status=result.status)


def states(scene) -> list[tuple]:
    """Every steady state of a validated scene with the eigenvalues of its linearisation,
    rightmost first: [(state, eigenvalues), ...] in increasing u(1)."""
    from rodfem.model import steady
    from rodfem.solver.spectrum import Spectra

    problem, spectra = steady.of_scene(scene), Spectra()
    return [(state, spectra.eigenvalues(scene, problem.linearise(state)))
            for state in problem.states()]


def at_rest(state, velocity: str = "0") -> list[str]:
    """Scene overrides that start the rod at a steady state: θ linear, u of
    :meth:`~rodfem.model.steady.SteadyState.displacement`, with the initial velocity
    ``velocity`` (an expression in x: a small one perturbs the state)."""
    theta_A, slope, a = state.theta_A, state.theta_1 - state.theta_A, state.a
    return [f"initial.theta0={theta_A!r} + ({slope!r})*x",
            f"initial.u0=({state.sigma_1!r})*x + {a!r}*({theta_A!r}*x + ({slope!r})*x**2/2)",
            f"initial.u1={velocity}"]


def envelope(t: np.ndarray, x: np.ndarray, start: float, end: float) -> float:
    """max |x| over start ≤ t ≤ end."""
    inside = (t >= start) & (t <= end)
    if not inside.any():
        raise ValueError(f"no step between t = {start:g} and {end:g}")
    return float(np.max(np.abs(x[inside])))


def decay_rate(t: np.ndarray, x: np.ndarray, first: tuple[float, float],
               last: tuple[float, float]) -> float:
    """The rate γ with which the envelope of x changes from the window ``first`` to ``last``:
    ln(envelope(last)/envelope(first)) over the distance between the windows' starts."""
    return float(np.log(envelope(t, x, *last) / envelope(t, x, *first)) / (last[0] - first[0]))


def upward_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The times where x crosses 0 upward, linearly interpolated between steps."""
    i = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    return t[i] + (t[i + 1] - t[i]) * (-x[i]) / (x[i + 1] - x[i])


def period(t: np.ndarray, x: np.ndarray, start: float, end: float) -> float:
    """The mean period of x's upward zero crossings in start ≤ t ≤ end (nan if fewer than 2)."""
    inside = (t >= start) & (t <= end)
    times = upward_crossings(t[inside], x[inside])
    return float((times[-1] - times[0]) / (times.size - 1)) if times.size > 1 else float("nan")


def touches(t: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The step times where contact begins (p = 0 at the step before, p > 0 at this one)."""
    return t[1:][(p[:-1] <= 0.0) & (p[1:] > 0.0)]


@dataclasses.dataclass(frozen=True)
class Cycle:
    """Contact made and broken over a time window: how often, the mean time between touches,
    the fraction of the steps in contact, and the range of u(1)."""

    touches: int
    period: float
    contact_fraction: float
    u_min: float
    u_max: float


def cycle(run_: Run, start: float, end: float | None = None) -> Cycle:
    """The contact cycle of a run over start ≤ t ≤ end (to its end by default)."""
    end = run_.t[-1] if end is None else end
    inside = (run_.t >= start) & (run_.t <= end)
    times = touches(run_.t[inside], run_.p[inside])
    gaps = np.diff(times)
    return Cycle(touches=int(times.size),
                 period=float(gaps.mean()) if gaps.size else float("nan"),
                 contact_fraction=float(np.mean(run_.p[inside] > 0.0)),
                 u_min=float(run_.u_1[inside].min()), u_max=float(run_.u_1[inside].max()))


def step_rate(eigenvalue: complex, dt: float, scheme: str = "paper") -> complex:
    """The eigenvalue a run sees: the rate μ with e^{μΔt} the factor by which a step multiplies
    the mode of ``eigenvalue`` λ. The paper's scheme is backward Euler on (Θ, U, δ) (its
    velocity δⁿ = (Uⁿ − Uⁿ⁻¹)/Δt, the contact and the exchange taken at step n), so a step
    multiplies by 1/(1 − λΔt); Crank–Nicolson by (1 + λΔt/2)/(1 − λΔt/2)."""
    z = eigenvalue * dt
    factor = 1.0 / (1.0 - z) if scheme == "paper" else (1.0 + z / 2.0) / (1.0 - z / 2.0)
    return complex(np.log(factor) / dt)
