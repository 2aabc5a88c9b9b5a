"""The optimiser of ``rodfem fit``: bounded nonlinear least squares of a scene's history against
measured data, its runs dealt to the MPI ranks by the sweep engine, journalled and replayed.

**Method.** Each parameter's study scale (``log10`` of it where log-scaled) is mapped to
``u`` in [0, 1]; ``scipy.optimize.least_squares`` (trust-region reflective, bounds [0, 1]) fits
the residuals ``w (model - data)`` (:mod:`rodfem.studies.fit.data`). The Jacobian is by forward
differences of step ``H`` in ``u`` (backward at the upper bound): the point and its n perturbed
points are one batch of runs, a sweep dealt to the ranks
(:func:`rodfem.studies.sweep.dealing.deal`), each run alone on ``MPI.COMM_SELF``. Every rank runs
the optimiser on the same numbers, so every rank takes the same steps: the fit is bit for bit the
serial one.

**Statistics.** At the optimum, with m residuals (one per value measured: an empty cell of
the data has none) and n parameters, ``s² = |r|² / (m - n)`` and ``cov = s² (JᵀJ)⁻¹`` in ``u``,
mapped to the parameters' values by the delta method (``dv/du``: the range on the study scale,
times ``v ln 10`` where log-scaled); standard errors are its diagonal's roots. A Jacobian of rank
below n (or m <= n) gives none.

**Journal.** Every point run is journalled with its residuals, keyed by the point's exact bits
(:mod:`rodfem.output.journal`). A resumed fit replays the optimiser from its start, taking the
journalled residuals instead of running them again: it ends where an unstopped fit ends.
"""

from __future__ import annotations

import dataclasses
import signal
import sys

import numpy as np
from mpi4py import MPI

from rodfem.output import interrupts, journal
from rodfem.output import results as table
from rodfem.scene import SceneError
from rodfem.studies.common import plural
from rodfem.studies.fit.data import Data
from rodfem.studies.fit.files import FitError
from rodfem.studies.sweep import design
from rodfem.studies.sweep.dealing import Progress, deal
from rodfem.studies.sweep.parameters import Study

H = 1e-6  # the finite differences' step, in u


class WriteError(Exception):
    """The journal could not be written (the line says which file and why)."""


@dataclasses.dataclass(frozen=True)
class Problem:
    """A fit to do: the study, its data, where it starts, how far it may go, and the base scene
    (raw data and source) its runs are made of."""

    study: Study
    data: Data
    start: dict[str, float]
    max_evaluations: int
    tolerance: float
    base: tuple[dict, str]

    def values(self, u: np.ndarray) -> list[float]:
        """The parameters' values at the point ``u`` of [0, 1]ⁿ."""
        return [p.value(lo + x * (hi - lo))
                for p, x, (lo, hi) in zip(self.study.parameters, u,
                                          (p.bounds for p in self.study.parameters), strict=True)]

    def scaled(self, values: dict[str, float]) -> np.ndarray:
        """The point u of the parameters' ``values``."""
        return np.array([(p.scaled(values[p.key]) - p.bounds[0]) / (p.bounds[1] - p.bounds[0])
                         for p in self.study.parameters])

    def derivatives(self, u: np.ndarray) -> np.ndarray:
        """dv/du of each parameter's value at ``u``."""
        values = self.values(u)
        return np.array([(hi - lo) * (v * np.log(10.0) if p.log else 1.0)
                         for p, v, (lo, hi) in zip(self.study.parameters, values,
                                                   (p.bounds for p in self.study.parameters),
                                                   strict=True)])

    def sweep(self, rows) -> design.Sweep:
        """The runs at the parameters' values ``rows``."""
        return design.parse(self.study.sweep_data(rows), self.study.name, base=self.base)

    def scene(self, u: np.ndarray):
        return self.sweep([self.values(u)]).scene(0)


class Evaluations:
    """The residuals of points ``u``, run in batches (journalled into ``log``) or taken from
    ``known`` (a journal's, by the point's bits)."""

    def __init__(self, problem: Problem, comm: MPI.Comm, log: journal.Journal | None = None,
                 known: dict[bytes, np.ndarray] | None = None, progress: bool = False,
                 flagged: frozenset[bytes] = frozenset()):
        self.problem, self.comm, self.log, self.progress = problem, comm, log, progress
        self.cache: dict[bytes, np.ndarray] = {}
        self.known = dict(known or {})
        # the points whose run had a fixed step coarse for its contact (results.csv's coarse;
        # a journal's record says it after the point: "<point> coarse")
        self.flagged = set(flagged)
        self.order: dict[bytes, int] = {}  # each point's place in the replay: its record's
        self.batches = self.ran = 0

    def batch(self, points: list[np.ndarray]) -> list[np.ndarray]:
        """The residuals at ``points``, those not known run as one sweep."""
        self._check_signal()
        keys = [np.ascontiguousarray(p, dtype=float).tobytes() for p in points]
        new = []
        for key in keys:
            if key not in self.order:
                self.order[key] = len(self.order)
            if key not in self.cache:
                if key in self.known:
                    self.cache[key] = self.known[key]
                elif key not in new:
                    new.append(key)
        if new:
            self._run(new)
        return [self.cache[key] for key in keys]

    def _check_signal(self) -> None:
        """A stop signal received by any rank stops every rank here, between batches."""
        got = self.comm.allreduce(interrupts.signal_received() or 0, op=MPI.MAX)
        if got:
            raise interrupts.Interrupted(got)

    def _run(self, new: list[bytes]) -> None:
        problem = self.problem
        points = [np.frombuffer(key) for key in new]
        sweep = problem.sweep([problem.values(u) for u in points])
        for index, point in enumerate(sweep.points):  # on every rank, before any is dealt
            try:
                sweep.scene(index)
            except SceneError as err:
                shown = str(err).removeprefix(f"{sweep.name}: scene {index + 1} of {len(sweep)} "
                                              f"({design.describe(point)}): ")
                raise FitError(f"the scene at {design.describe(point)} is refused: "
                               f"{shown}") from None
        names = None
        mine = []
        coarse_cell = table.header(sweep.axes, sweep.declared).index("coarse")

        def record(outcome) -> None:
            nonlocal names
            if outcome.status == "complete":
                if names is None:
                    from rodfem.output.columns import for_scene

                    names = tuple(c.name for c in for_scene(sweep.scene(outcome.index)))
                t = outcome.history[:, names.index("t")]
                why = problem.data.after(t, sweep.scene(outcome.index))
                if why is not None:
                    mine.append((outcome.index, "failed", why))
                    return
                r = problem.data.residuals(outcome.history, names)
                if not np.all(np.isfinite(r)):
                    mine.append((outcome.index, "failed", "its history is not finite"))
                    return
                with np.errstate(over="ignore"):
                    overflows = not np.isfinite(r @ r)
                if overflows:
                    mine.append((outcome.index, "failed", "the sum of the squares of its "
                                 "weighted residuals overflows (scale the weights)"))
                    return
                coarse = table.cells(outcome.line)[coarse_cell] == "1"
                if self.log is not None:
                    key = new[outcome.index]
                    self.log.append(self.order[key], key.hex() + (" coarse" if coarse else ""),
                                    r[None, :])
                mine.append((outcome.index, "complete", (r, coarse)))
            else:
                mine.append((outcome.index, outcome.status, table.cells(outcome.line)[-1]))

        error, ran = deal(sweep, list(range(len(sweep))), self.comm, record, True,
                          Progress(len(sweep), 0, False))
        every = sorted((o for part in self.comm.allgather(mine) for o in part),
                       key=lambda o: o[0])
        errors = [e for e in self.comm.allgather(error) if e]
        self.ran += self.comm.allreduce(ran)
        self.batches += 1
        for index, status, found in every:
            if status == "complete":
                self.cache[new[index]], coarse = found
                if coarse:
                    self.flagged.add(new[index])
        if errors:
            raise WriteError(errors[0])
        self._check_signal()
        if any(status == "interrupted" for _, status, _ in every) or len(every) < len(new):
            raise interrupts.Interrupted(signal.SIGINT)  # a signal the ranks did not all see
        failed = [(index, found) for index, status, found in every if status != "complete"]
        if failed:
            index, why = failed[0]
            raise FitError(f"the run at {design.describe(sweep.points[index])} failed: "
                           f"{why or 'no reason given'}")
        if self.progress and self.comm.rank == 0:
            norm = float(np.linalg.norm(self.cache[new[0]]))
            print(f"fit: batch {self.batches}: {plural(len(new), 'run')} "
                  f"({plural(len(self.cache), 'point')} in all), |r| = {norm:.6g} at "
                  f"{design.describe(sweep.points[0])}", file=sys.stderr, flush=True)


def coarse_line(evaluations: Evaluations) -> tuple[int, str | None]:
    """How many of the points run had a fixed step coarse for their contact, and the line that
    says so with the fix (:func:`rodfem.model.timescales.study_line`; None: none had)."""
    from rodfem.model.timescales import coarse_step, study_line

    problem = evaluations.problem
    judged = [coarse_step(problem.scene(np.frombuffer(key))) for key in evaluations.cache
              if key in evaluations.flagged]
    judged = [j for j in judged if j is not None]
    return len(judged), study_line(judged, len(evaluations.cache), "fit.json's coarse_runs")


def jacobian(evaluations: Evaluations, u: np.ndarray) -> np.ndarray:
    """dr/du at ``u`` by forward differences (backward at the upper bound): one batch."""
    points = [u]
    for i in range(len(u)):
        p = u.copy()
        p[i] = u[i] + H if u[i] + H <= 1.0 else u[i] - H
        points.append(p)
    found = evaluations.batch(points)
    return np.column_stack([(found[i + 1] - found[0]) / (points[i + 1][i] - u[i])
                            for i in range(len(u))])


def optimise(problem: Problem, evaluations: Evaluations):
    """``scipy.optimize.least_squares`` of the residuals from the start point."""
    from scipy.optimize import least_squares

    return least_squares(lambda u: evaluations.batch([u])[0], problem.scaled(problem.start),
                         jac=lambda u, *_: jacobian(evaluations, u), bounds=(0.0, 1.0),
                         method="trf", ftol=problem.tolerance, xtol=problem.tolerance,
                         gtol=problem.tolerance, max_nfev=problem.max_evaluations)


def statistics(problem: Problem, u: np.ndarray, r: np.ndarray, J: np.ndarray):
    """The parameters' standard errors and correlation matrix at the optimum ``u`` (residuals
    ``r``, Jacobian ``J`` in u), or (None, None, why) where the data cannot give them."""
    m, n = J.shape
    if m <= n:
        return None, None, (f"{plural(m, 'value')} to fit for {plural(n, 'parameter')}: no "
                            "standard errors")
    _, s, vt = np.linalg.svd(J, full_matrices=False)
    if s[-1] <= s[0] * max(m, n) * np.finfo(float).eps:
        return None, None, ("the residuals do not depend on every parameter at the optimum "
                            "(its Jacobian is of rank below their number): no standard errors")
    variance = float(r @ r) / (m - n)
    with np.errstate(all="ignore"):  # a Jacobian or residuals at the ends of float64
        covariance_u = variance * (vt.T / s**2) @ vt
        d = problem.derivatives(u)
        covariance = covariance_u * np.outer(d, d)
        stderr = np.sqrt(np.diag(covariance))
        correlation = covariance / np.outer(stderr, stderr)
    if not np.all(np.isfinite(stderr)):
        return None, None, ("the residuals or their Jacobian at the optimum are too small or "
                            "too large for float64 (scale the weights): no standard errors")
    # |r| = 0: standard errors 0 and no correlations
    return stderr, correlation if np.all(np.isfinite(correlation)) else None, None


def at_bounds(problem: Problem, u: np.ndarray, active: np.ndarray) -> str | None:
    """The parameters whose optimum ``u`` is held at an end of its range (the optimiser's
    ``active_mask``), said in one line, or None: there the data may be fitted better beyond
    it, and a standard error, which takes the optimum for a free one, says nothing of that."""
    held = [f"{p.key} = {v:.6g} at the {'low' if a < 0 else 'high'} end of its range "
            f"[{p.low:g}, {p.high:g}]"
            for p, v, a in zip(problem.study.parameters, problem.values(u), active, strict=True)
            if a != 0]
    if not held:
        return None
    return (f"{', '.join(held)}: the data may be fitted better beyond it, which its standard "
            "error does not say; widen the range")
