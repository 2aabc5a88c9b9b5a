"""``rodfem steady --continue KEY=a:b``: the bifurcation diagram over a scene value. Every branch
through a state at either end of the range, followed by pseudo-arclength continuation
(:mod:`.continuation`), each of its points with its stability (:mod:`.states`'s rows), and the
points located on it (:mod:`.points`): folds, grazing points and Hopf points, written to
``points.csv`` beside ``branches.csv``.

Under MPI the branches are followed on every rank (a scalar equation: milliseconds), the
spectra of their points and the Hopf points are dealt to the ranks and gathered: every rank holds
the serial tables, and rank 0 writes them.
"""

from __future__ import annotations

import dataclasses
import math

from rodfem.studies.common import deal
from rodfem.studies.steady import continuation as ct
from rodfem.studies.steady import points as pt


@dataclasses.dataclass
class Diagram:
    """The rows of branches.csv (in order along each branch) and of points.csv."""

    key: str
    branch_rows: list[dict]
    point_rows: list[dict]


def _stability(row: dict) -> str:
    if row["trust"] != "ok":
        return row["trust"]
    return "stable" if row["stable"] else "unstable"


def compute(scene, key: str, lo: float, hi: float, spectra, extrapolate: bool = False) -> Diagram:
    """The diagram of ``scene`` over ``key`` in [lo, hi], its work dealt to the ranks of
    ``spectra.comm``. Each rank takes the spectra of its share on its own (a mesh on one process,
    as a serial run's): a share needs operators that no other rank does (a finer mesh's, a
    time step's dispersion-free mass), and the serial answer is the one assembled on one
    process."""
    from rodfem.studies.steady.states import state_row

    comm = spectra.comm
    if comm.size > 1:
        from mpi4py import MPI

        spectra = type(spectra)(MPI.COMM_SELF, spectra.dense_cells)

    def row_of(at, problem, state):
        return state_row(at, problem, state, spectra)

    curve = ct.Curve(scene, key, lo, hi)
    found = ct.branches(scene, key, lo, hi)
    spectral = pt.Spectral(curve, spectra)
    tasks = [(b, i) for b, branch in enumerate(found) for i in range(len(branch))]
    mine = deal([1.0] * len(tasks), comm.size)[comm.rank]
    solved = {}
    for j in mine:
        b, i = tasks[j]
        point = found[b][i]
        problem, state = spectral.state(point)
        row = row_of(curve.scene_at(point.value), problem, state)
        solved[j] = (row, spectral.test(point) if state.resolved else math.nan)
    for part in comm.allgather(solved):
        solved.update(part)
    rows = {tasks[j]: solved[j] for j in range(len(tasks))}
    # Hopf points: ψ changes sign between two neighbours of a branch
    pairs = [(b, i) for b, branch in enumerate(found) for i in range(len(branch) - 1)
             if _changes(rows[b, i][1], rows[b, i + 1][1])]
    mine = deal([1.0] * len(pairs), comm.size)[comm.rank]
    located = {j: _hopf(spectral, found, pairs[j], extrapolate, scene) for j in mine}
    for part in comm.allgather(located):
        located.update(part)
    branch_rows, point_rows = [], []
    for b, branch in enumerate(found):
        along = []
        for i, point in enumerate(branch):
            along.append((point, rows[b, i][0]))
            hit = next((located[j] for j, pair in enumerate(pairs) if pair == (b, i)), None)
            if hit is not None:
                problem, state = spectral.state(hit[0].point)
                along.append((hit[0].point, row_of(curve.scene_at(hit[0].point.value),
                                                   problem, state), hit))
        for n, item in enumerate(along):
            point, row = item[0], item[1]
            branch_rows.append({"parameter": point.value, **row, "branch": b, "point": n,
                                "key": key, "located": point.kind})
            if point.kind in ("fold", "grazing", "hopf"):
                before = along[n - 1][1] if n > 0 else None
                after = along[n + 1][1] if n + 1 < len(along) else None
                point_rows.append(_point_row(point, row, b, key, before, after,
                                             item[2] if len(item) > 2 else None))
    return Diagram(key, branch_rows, point_rows)


def _changes(a: float, b: float) -> bool:
    return math.isfinite(a) and math.isfinite(b) and (a < 0.0) != (b < 0.0)


def _hopf(spectral: pt.Spectral, found, pair, extrapolate: bool, scene):
    """The Hopf point between a branch's points i and i + 1 (None: a jump, no crossing), with
    its continuum's value and period where ``extrapolate``."""
    b, i = pair
    before, after = found[b][i], found[b][i + 1]
    hopf = spectral.hopf(before, after)
    if hopf is None:
        return None
    hopf = Located(hopf, spectral.lyapunov(hopf))
    if not extrapolate:
        return hopf, None, None
    values, periods = [hopf.point.value], [2.0 * math.pi / hopf.omega]
    for factor in pt.REFINED:
        finer = pt.Spectral(spectral.curve, spectral.spectra, factor * scene["mesh.cells"])
        again = _near(finer, found[b], i)
        if again is None:
            return hopf, None, None
        values.append(again.point.value)
        periods.append(2.0 * math.pi / again.omega)
    return hopf, pt.extrapolated(values), pt.extrapolated(periods)


@dataclasses.dataclass(frozen=True)
class Located:
    """A Hopf point (:class:`~.points.Hopf`) with its first Lyapunov coefficient
    (:class:`~rodfem.solver.lyapunov.Lyapunov`), on the scene's mesh."""

    hopf: pt.Hopf
    lyapunov: object

    @property
    def point(self):
        return self.hopf.point

    @property
    def omega(self) -> float:
        return self.hopf.omega


def _near(spectral: pt.Spectral, branch, i: int, reach: int = 8):
    """The Hopf point on a finer mesh nearest the chord i of a branch: that chord's, else the
    nearest chord within ``reach`` either way where ψ changes sign."""
    for offset in range(reach + 1):
        for j in sorted({i - offset, i + offset}):
            if 0 <= j < len(branch) - 1:
                found = spectral.hopf(branch[j], branch[j + 1])
                if found is not None:
                    return found
    return None


def _point_row(point, row: dict, branch: int, key: str, before, after, hopf) -> dict:
    nan = math.nan
    found = {"kind": point.kind, "parameter": point.value, "u_1": row["u_1"],
             "theta_1": row["theta_1"], "p": -row["sigma_1"] + 0.0,
             "sigma_1": row["sigma_1"], "branch": branch, "turns": point.turns,
             "before": _stability(before) if before else "",
             "after": _stability(after) if after else "", "omega": nan, "period": nan,
             "growth_rate": row["growth_rate"], "parameter_continuum": nan,
             "parameter_error": nan, "period_continuum": nan, "period_error": nan,
             "asymptotic": "", "key": key, "lyapunov": nan, "lyapunov_error": nan,
             "criticality": ""}
    if point.kind in ("fold", "grazing"):  # the states are exact: so are these points
        found.update(parameter_continuum=point.value, parameter_error=0.0)
    if hopf is not None:
        located, value, period = hopf
        found.update(omega=located.omega, period=2.0 * math.pi / located.omega,
                     lyapunov=located.lyapunov.value, lyapunov_error=located.lyapunov.error,
                     criticality=located.lyapunov.criticality)
        if value is not None:
            found.update(parameter_continuum=value.value, parameter_error=value.error,
                         period_continuum=period.value, period_error=period.error,
                         asymptotic=value.asymptotic and period.asymptotic)
    return found


def point_lines(rows: list[dict], key: str) -> list[str]:
    """One line per located point."""
    lines = []
    for row in rows:
        where = f"{key} = {row['parameter']:.12g}"
        text = {"fold": "fold", "grazing": "grazing", "hopf": "Hopf point"}[row["kind"]]
        extra = " (the branch turns back there)" if row["turns"] else ""
        if row["kind"] == "hopf":
            extra = f", period {row['period']:.6g}"
            if row["criticality"]:
                extra += (f", {row['criticality']} (l1 = {row['lyapunov']:.4g} ± "
                          f"{row['lyapunov_error']:.1g})")
            if math.isfinite(row["parameter_continuum"]):
                extra += (f"; continuum {row['parameter_continuum']:.8g} ± "
                          f"{row['parameter_error']:.2g}, period "
                          f"{row['period_continuum']:.8g} ± {row['period_error']:.2g}")
            elif row["asymptotic"] is False:
                extra += "; continuum not extrapolated: pre-asymptotic, refine the mesh"
        lines.append(f"{text} at {where}: u(1) = {row['u_1']:.6g}, p = {row['p']:.6g}, "
                     f"theta(1) = {row['theta_1']:.6g}, {row['before'] or '-'} to "
                     f"{row['after'] or '-'}{extra}")
    return lines
