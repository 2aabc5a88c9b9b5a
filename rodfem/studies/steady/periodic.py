r"""``rodfem periodic``: the periodic orbit a scene's runs settle on where its steady state has
lost stability at a Hopf bifurcation, found by shooting with the scene's own scheme
(:mod:`rodfem.studies.steady.orbit`), at one scene or at each value of a continuation, each
value's search started from the orbit of the value before (and, where that fails, from a time
run of its own); and the command's files: ``periodic.csv`` (a row per value), ``orbit.csv``
(one period of the first orbit found) and ``settled.csv`` (the time run it was started from).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rodfem.scene import load
from rodfem.studies.steady.orbit import NoOrbit, Orbit, Start, find, settle, trace
from rodfem.studies.steady.ranges import parse_range

PERIODIC = "periodic.csv"
ORBIT = "orbit.csv"
COLUMNS = ("parameter", "period", "u_min", "u_max", "amplitude", "contact_fraction",
           "multiplier_1", "multiplier_2", "trivial_multiplier", "multiplier_error", "stable",
           "residual", "u_star", "steps", "iterations", "found", "key")
ORBIT_COLUMNS = ("t", "u_1", "theta_1", "p", "sigma_1")
KICK = "1e-2*x"  # the start's initial velocity
MAX_CELLS = 400  # a dense monodromy matrix of 3 × cells unknowns, one shot per column
# The scene values a continuation may not run over: they change no orbit.
INERT = {"output": "what a run writes", "initial": "a run's initial state",
         "accuracy": "an accuracy target"}
MAX_POINTS = 1000


class PeriodicError(ValueError):
    """Bad input to ``rodfem periodic`` (exit code 2, nothing written)."""


# -- the scene's map ----------------------------------------------------------------------------

def check(scene) -> None:
    """PeriodicError for a scene the shooting does not take: adaptive steps, a method without a
    compiled loop, a mesh too fine for a dense monodromy matrix."""
    from rodfem.solver.compiled import compiled_kind

    if scene["time.adaptive"]:
        raise PeriodicError("the periodic orbit is found with fixed steps: --set "
                            "time.adaptive=false (its step is time.dt at most)")
    if scene["mesh.cells"] > MAX_CELLS:
        raise PeriodicError(f"mesh.cells = {scene['mesh.cells']}: the monodromy matrix is dense "
                            f"in 3 × cells unknowns; --set mesh.cells={MAX_CELLS} or fewer")
    if compiled_kind(scene) is None:
        raise PeriodicError("the periodic orbit needs the compiled time loop: solver.method = "
                            f"direct or picard (not {scene['solver.method']}), no sources, and "
                            "RODFEM_KERNEL not 0")


def steady_state(scene):
    """The steady state the orbit winds about, and its eigenvalues (rightmost first): the one
    state, or of several the one whose rightmost eigenvalue is complex with the largest real
    part."""
    from rodfem.studies.steady.barber import states

    found = states(scene)
    if not found:
        raise NoOrbit("the scene has no steady state to wind about")
    oscillatory = [f for f in found if abs(f[1][0].imag) > 0.0]
    return max(oscillatory or found, key=lambda f: f[1][0].real)


def flow_of(scene, comm):
    """The :class:`~rodfem.solver.shooting.Flow` of a scene (its discretisation, method,
    compiled loop and step family made once)."""
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.output.history import History
    from rodfem.solver.compiled import compiled_loop
    from rodfem.solver.compiled.families import step_family
    from rodfem.solver.methods import make_method
    from rodfem.solver.shooting import Flow

    disc = Discretisation(scene, comm, cache=True)
    method = make_method(disc)
    history = History(disc)
    kernel = compiled_loop(method, history)
    return Flow(method, kernel, step_family(method, history, kernel))


def row(orbit: Orbit | None, parameter, key: str, u_star: float, why: str = "") -> dict:
    """periodic.csv's row of an orbit, or of none (``why``): empty cells, never a number made
    up."""
    empty = {c: None for c in COLUMNS}
    empty.update(parameter=parameter, key=key, u_star=u_star)
    if orbit is None:
        return {**empty, "found": f"no: {why}"}
    moduli = np.abs(orbit.multipliers)
    return {**empty, "period": orbit.period, "u_min": orbit.u_min, "u_max": orbit.u_max,
            "amplitude": orbit.amplitude, "contact_fraction": orbit.contact_fraction,
            "multiplier_1": float(moduli[0]) if moduli.size else None,
            "multiplier_2": float(moduli[1]) if moduli.size > 1 else None,
            "trivial_multiplier": float(abs(orbit.trivial)),
            "multiplier_error": orbit.multiplier_error, "stable": orbit.stable,
            "residual": orbit.residual, "steps": orbit.steps, "iterations": orbit.iterations,
            "found": "yes"}


# -- a scene, and a continuation --------------------------------------------------------------

@dataclasses.dataclass
class Point:
    """One value's outcome: its scene, u*, the orbit (or None, and why), the start's run
    (None where the orbit was continued from the value before)."""

    parameter: float | None
    scene: object
    u_star: float
    orbit: Orbit | None
    why: str
    start: Start | None
    trace: dict | None = None  # one period of the orbit (:func:`trace`)


def analyse(scene_name: str, overrides: list[str], comm, previous: Orbit | None = None,
            parameter: float | None = None) -> Point:
    """The orbit of one scene: from ``previous`` (a continuation's last orbit) where given,
    else (and where that fails) from a time run settled near it."""
    from rodfem.studies.steady.barber import at_rest

    scene = load(scene_name, overrides)
    state, eigenvalues = steady_state(scene)
    u_star = float(state.u_1)
    kicked = load(scene_name, [*overrides, *at_rest(state, KICK)])
    flow = flow_of(kicked, comm)
    why = ""
    if previous is not None:
        try:
            orbit = find(flow, scene, u_star, previous.state, previous.period, comm)
            return Point(parameter, scene, u_star, orbit, "", None,
                         trace(flow, scene, orbit))
        except NoOrbit as error:
            why = str(error)
    rightmost = eigenvalues[0]
    period = 2 * math.pi / abs(rightmost.imag) if rightmost.imag != 0.0 else 1.0
    try:
        start = settle(flow, flow.initial(), u_star, period)
    except NoOrbit as error:
        return Point(parameter, scene, u_star, None, str(error), None)
    try:
        orbit = find(flow, scene, u_star, start.state, start.period, comm)
    except NoOrbit as error:
        return Point(parameter, scene, u_star, None, str(error) if not why else why, start)
    return Point(parameter, scene, u_star, orbit, "", start, trace(flow, scene, orbit))


def parse_continuation(texts: list[str] | None) -> tuple[str, np.ndarray] | tuple[None, None]:
    """``KEY=a:b:n`` (once) → the key and its n values from a to b: a real scene value that can
    change the orbit. PeriodicError otherwise."""
    if not texts:
        return None, None
    if len(texts) != 1:
        raise PeriodicError(f"--continue is given {len(texts)} times; give it once")
    key, found, a, b, n = parse_range(texts[0], "--continue", PeriodicError, counted=True,
                                      example="model.zeta", maximum=MAX_POINTS)
    section = key.partition(".")[0]
    if section in INERT or key in ("time.end", "mesh.cells"):
        raise PeriodicError(f"--continue: {key} does not change the orbit (or its unknowns); "
                            "continue over a model, obstacle or heat_exchange value")
    if found.kind != "real":
        raise PeriodicError(f"--continue: {key} is not a real value ({found.kind})")
    return key, np.linspace(a, b, n)


def continuation(scene_name: str, overrides: list[str], key: str | None,
                 values: np.ndarray | None, comm, report=None) -> list[Point]:
    """The orbit at each value of ``key`` (each started from the one before), or of the scene
    alone (``key`` None)."""
    if key is None:
        return [analyse(scene_name, overrides, comm)]
    points, previous = [], None
    for value in values:
        point = analyse(scene_name, [*overrides, f"{key}={float(value)!r}"], comm, previous,
                        float(value))
        points.append(point)
        previous = point.orbit or previous
        if report is not None:
            report(point)
    return points


def rows_of(points: list[Point], key: str | None) -> list[dict]:
    return [row(p.orbit, p.parameter, key or "", p.u_star, p.why) for p in points]


def table_lines(points: list[Point], key: str | None) -> list[str]:
    """The orbits as a short table."""
    head = f"{key:>14} " if key else ""
    lines = [head + f"{'period':>10} {'u_min':>10} {'u_max':>10} {'max|u-u*|':>10} "
             f"{'contact':>8} {'|mu|':>9} {'stable':>7} {'residual':>9}"]
    for p in points:
        lead = f"{p.parameter:14.6g} " if key else ""
        o = p.orbit
        if o is None:
            lines.append(lead + "no orbit")
            continue
        largest = abs(o.multipliers[0]) if o.multipliers.size else math.nan
        verdict = {True: "yes", False: "NO", None: "?"}[o.stable]
        lines.append(lead + f"{o.period:10.6f} {o.u_min:10.6f} {o.u_max:10.6f} "
                     f"{o.amplitude:10.3e} {100 * o.contact_fraction:7.1f}% {largest:9.5f} "
                     f"{verdict:>7} {o.residual:9.2e}")
    return lines


def warning_lines(points: list[Point], key: str | None) -> list[str]:
    return [f"rodfem: warning: no periodic orbit"
            + (f" at {key} = {p.parameter:g}" if key else "") + f": {p.why}"
            for p in points if p.orbit is None]


# -- files --------------------------------------------------------------------------------------

SETTLED = "settled.csv"  # the start's time run over its last period: t, u_1, p
SETTLED_COLUMNS = ("t", "u_1", "p")


def first_found(points: list[Point]) -> Point | None:
    """The first value's point that has an orbit (orbit.csv's)."""
    return next((p for p in points if p.orbit is not None), None)


def prepare_out(out, force: bool, comm) -> None:
    """Create ``out`` for the command's files, before anything is computed (OutputError: one
    line, nothing written)."""
    from rodfem.studies.common import prepare

    prepare(out, force, comm, (PERIODIC, ORBIT, SETTLED), "periodic")


def write(out, comm, points: list[Point], key: str | None) -> list:
    """periodic.csv, orbit.csv (one period of the first orbit found) and settled.csv (the time
    run it was started from, over its last period) into ``out`` (:func:`prepare_out`); rank 0
    writes. Returns the files written."""
    from rodfem.studies.common import write_csv

    first = first_found(points)
    files = [PERIODIC]
    if comm.rank == 0:
        write_csv(out / PERIODIC, COLUMNS, rows_of(points, key))
    if first is not None:
        files.append(ORBIT)
        traced = first.trace
        if comm.rank == 0:
            write_csv(out / ORBIT, ORBIT_COLUMNS,
                      [{c: float(traced[c][k]) for c in ORBIT_COLUMNS}
                       for k in range(traced["t"].size)])
    if first is not None and first.start is not None:
        files.append(SETTLED)
        s = first.start
        if comm.rank == 0:
            write_csv(out / SETTLED, SETTLED_COLUMNS,
                      [{"t": float(s.t[k]), "u_1": float(s.u_1[k]),
                        "p": float(s.p[k]) if k else math.nan} for k in range(s.t.size)])
    return [out / name for name in files]
