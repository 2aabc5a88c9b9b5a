"""Errors and observed orders of convergence, in NumPy.

The solutions are P1 functions on uniform meshes of [0, 1]. A coarse run is compared with a finer
reference run on a nested mesh (its cell count a multiple of the coarse one) and with time steps
that divide the coarse one:

* in space, at the end time: ‖u_c − u_f‖_{L²(0,1)}, exact for nested P1 (the coarse function,
  interpolated at the fine nodes, is itself; the difference is P1 on the fine mesh, whose square
  integrates to h/3 (a² + ab + b²) per cell of end values a, b);
* in time, u(1, ·) over [0, T]: the largest difference at the coarse run's times, and its discrete
  L¹ and L² norms over them, Σₙ Δtₙ |eₙ| and (Σₙ Δtₙ eₙ²)^½, n ≥ 1 (the L¹ norm is GetFEM's
  measure of its dynamic contact benchmark, :mod:`rodfem.model.impact`, kept for every scene so
  that its figures compare with rodfem's on any of them);
* the observed order: the least-squares slope of log error against log h (or log Δt).

A coarse run of uneven steps (``time.adaptive``) is compared at its own times, the reference
interpolated linearly between its steps where a time is not one of them.

:func:`run_ladder` runs a ladder of (cells, Δt) refinements of a scene against a reference run.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from rodfem.output.columns import INDEX

if TYPE_CHECKING:
    from rodfem.run import RunResult
    from rodfem.scene import Scene

# The error measures of a ladder point: u(1, ·) over [0, T] (max, L¹ and L² in time), u and θ at T
# (L²).
MEASURES = ("u1_max", "u1_l1", "u1_l2", "u_T", "theta_T")
# A coarse node (time) must lie on a fine one to this fraction of the span: x = i h and t = n Δt
# are rounded in binary.
MATCH = 1e-9


def l2_difference(x_coarse: np.ndarray, f_coarse: np.ndarray, x_fine: np.ndarray,
                  f_fine: np.ndarray) -> float:
    """‖f_c − f_f‖_{L²} of two P1 functions given at the nodes of nested meshes, exactly.

    Args:
        x_coarse, f_coarse: the coarse mesh's nodes (increasing) and the coarse function's values.
        x_fine, f_fine: the fine mesh's nodes, which include the coarse ones, and values.

    Raises:
        ValueError: the meshes are not nested (a coarse node is not a fine node).
    """
    x_coarse, x_fine = np.asarray(x_coarse, float), np.asarray(x_fine, float)
    f_coarse, f_fine = np.asarray(f_coarse, float), np.asarray(f_fine, float)
    if x_coarse.shape != f_coarse.shape or x_fine.shape != f_fine.shape:
        raise ValueError("nodes and values differ in length")
    if np.any(np.diff(x_coarse) <= 0) or np.any(np.diff(x_fine) <= 0):
        raise ValueError("nodes must be increasing")
    span = x_fine[-1] - x_fine[0]
    at = np.clip(np.searchsorted(x_fine, x_coarse), 0, x_fine.size - 1)
    left = np.clip(at - 1, 0, x_fine.size - 1)
    nearest = np.where(np.abs(x_fine[left] - x_coarse) < np.abs(x_fine[at] - x_coarse), left, at)
    if np.any(np.abs(x_fine[nearest] - x_coarse) > MATCH * span):
        raise ValueError("the meshes are not nested: a coarse node is not a fine node")
    d = np.interp(x_fine, x_coarse, f_coarse) - f_fine  # P1 interpolation is exact here
    a, b, h = d[:-1], d[1:], np.diff(x_fine)
    return math.sqrt(float(np.sum(h / 3.0 * (a * a + a * b + b * b))))


def sample_indices(t_coarse: np.ndarray, t_fine: np.ndarray) -> np.ndarray:
    """The indices of the fine run's times at the coarse run's times.

    Raises:
        ValueError: a coarse time is not one of the fine run's (Δt_f must divide Δt_c, and the
            runs must cover the same interval).
    """
    t_coarse, t_fine = np.asarray(t_coarse, float), np.asarray(t_fine, float)
    scale = MATCH * max(1.0, float(np.max(np.abs(t_fine))) if t_fine.size else 1.0)
    at = np.clip(np.searchsorted(t_fine, t_coarse - scale), 0, max(t_fine.size - 1, 0))
    if t_fine.size == 0 or np.any(np.abs(t_fine[at] - t_coarse) > scale):
        bad = t_coarse[np.argmax(np.abs(t_fine[at] - t_coarse))] if t_fine.size else t_coarse[0]
        raise ValueError(f"the coarse time {bad:g} is not one of the fine run's times: the fine "
                         "time step must divide the coarse one, over the same interval")
    return at


def time_norms(t: np.ndarray, e: np.ndarray) -> tuple[float, float, float]:
    """Norms over [0, T] of an error e sampled at the times t (e₀ at t₀): max_n |eₙ|,
    Σ_{n≥1} (tₙ − tₙ₋₁) |eₙ| and (Σ_{n≥1} (tₙ − tₙ₋₁) eₙ²)^½."""
    t, e = np.asarray(t, float), np.asarray(e, float)
    dt = np.diff(t)
    return (float(np.max(np.abs(e))), float(np.sum(dt * np.abs(e[1:]))),
            math.sqrt(float(np.sum(dt * e[1:] ** 2))))


def uneven(t: np.ndarray) -> bool:
    """Whether the times t are not evenly spaced (an adaptive run's steps): steps that differ
    by more than :data:`MATCH` of the longest (nΔt rounded in binary are even)."""
    steps = np.diff(np.asarray(t, float))
    return bool(steps.size and np.ptp(steps) > MATCH * np.max(np.abs(steps)))


def reference_at(t_coarse: np.ndarray, t_fine: np.ndarray, y_fine: np.ndarray) -> np.ndarray:
    """The fine run's values at the coarse times: its own where a coarse time is one of its
    times (to :data:`MATCH`), else interpolated linearly between its two times around it.

    Raises:
        ValueError: a coarse time is outside the fine run's span.
    """
    t_coarse, t_fine = np.asarray(t_coarse, float), np.asarray(t_fine, float)
    y_fine = np.asarray(y_fine, float)
    scale = MATCH * max(1.0, float(np.max(np.abs(t_fine))) if t_fine.size else 1.0)
    if t_fine.size == 0 or t_coarse.min() < t_fine[0] - scale or \
            t_coarse.max() > t_fine[-1] + scale:
        raise ValueError("the coarse run's times reach outside the fine run's: the fine run must "
                         "cover the same interval")
    at = np.clip(np.searchsorted(t_fine, t_coarse - scale), 0, t_fine.size - 1)
    on = np.abs(t_fine[at] - t_coarse) <= scale
    return np.where(on, y_fine[at], np.interp(t_coarse, t_fine, y_fine))


def time_errors(t_coarse: np.ndarray, y_coarse: np.ndarray, t_fine: np.ndarray,
                y_fine: np.ndarray) -> tuple[float, float, float]:
    """max_n |y_c(tₙ) − y_f(tₙ)|, Σ_{n≥1} (tₙ − tₙ₋₁) |y_c − y_f| and
    (Σ_{n≥1} (tₙ − tₙ₋₁) |y_c − y_f|²)^½ over the coarse times (:func:`time_norms`). A coarse
    run of uneven steps (an adaptive one) is compared with the fine run at its own times
    (:func:`reference_at`); one of even steps with the fine run's values there.

    Raises:
        ValueError: even coarse times that are not a subset of the fine ones
            (:func:`sample_indices`), or coarse times outside the fine run's span.
    """
    t_coarse, y_coarse = np.asarray(t_coarse, float), np.asarray(y_coarse, float)
    if uneven(t_coarse):
        e = y_coarse - reference_at(t_coarse, t_fine, y_fine)
    else:
        e = y_coarse - np.asarray(y_fine, float)[sample_indices(t_coarse, t_fine)]
    return time_norms(t_coarse, e)


def rate(steps: Sequence[float], errors: Sequence[float]) -> float:
    """The observed order: the least-squares slope of log error against log step (h or Δt).

    Points with a non-finite or non-positive error are left out; fewer than two left give nan.
    """
    s, e = np.asarray(steps, float), np.asarray(errors, float)
    keep = np.isfinite(e) & (e > 0) & np.isfinite(s) & (s > 0)
    if np.count_nonzero(keep) < 2 or np.unique(s[keep]).size < 2:
        return math.nan
    return float(np.polyfit(np.log(s[keep]), np.log(e[keep]), 1)[0])


# Differences of a measure between runs within this fraction of its size are round-off (or a
# solver's tolerance): they give no order.
ROUNDOFF = 1e-10


def richardson(values: Sequence[float]) -> tuple[float, float, str]:
    """The observed order and Richardson estimate of a measure from its last three runs, each
    refining the one before by 2: p = log2(|m₁ − m₀| / |m₂ − m₁|) and (m₂ − m₁)/(2^p − 1), the
    estimate of m_∞ − m₂ (the correction the finest run's value needs). Where there is no order
    the note says why (then both are nan): a value not finite, too few runs, an integer
    measure, a value the same in every run, differences (or one) at round-off (:data:`ROUNDOFF`:
    a measure that counts steps, say, can stop changing),
    differences of opposite signs (not monotone) or a difference that does not shrink.

    Returns:
        (order, estimate, note); the note is "" where there is an order.
    """
    if len(values) < 3:
        return math.nan, math.nan, "fewer than three runs"
    m0, m1, m2 = (float(v) for v in values[-3:])
    if not all(math.isfinite(v) for v in (m0, m1, m2)):
        return math.nan, math.nan, "a run without a value"
    if all(isinstance(v, int | np.integer) for v in values[-3:]):
        return math.nan, math.nan, "integer"
    d1, d2 = m1 - m0, m2 - m1
    if d1 == 0.0 and d2 == 0.0:
        return math.nan, math.nan, "the same in every run"
    floor = ROUNDOFF * max(abs(m0), abs(m1), abs(m2))
    if abs(d1) <= floor or abs(d2) <= floor:
        which = "differences" if abs(d1) <= floor and abs(d2) <= floor else \
            "the last difference" if abs(d2) <= floor else "the first difference"
        return math.nan, math.nan, f"{which} at round-off"
    if (d1 > 0) != (d2 > 0):
        return math.nan, math.nan, "not monotone"
    if abs(d2) >= abs(d1):
        return math.nan, math.nan, "not converging"
    p = math.log2(abs(d1) / abs(d2))
    return p, d2 / (2.0 ** p - 1.0), ""


def errors_against(run: RunResult, reference: RunResult,
                   interpolated: bool = False) -> dict[str, float]:
    """The measures (:data:`MEASURES`) of a run against a finer reference run. ``interpolated``:
    the run's times need not be the reference's (an adaptive run's): u(1, ·) of the reference is
    interpolated linearly to them, which adds at most Δt_ref² max|u_tt(1, ·)|/8."""
    t, u_1 = INDEX["t"], INDEX["u_1"]
    if interpolated:
        e = run.history[:, u_1] - np.interp(run.history[:, t], reference.history[:, t],
                                            reference.history[:, u_1])
        u1_max, u1_l1, u1_l2 = time_norms(run.history[:, t], e)
    else:
        u1_max, u1_l1, u1_l2 = time_errors(run.history[:, t], run.history[:, u_1],
                                           reference.history[:, t], reference.history[:, u_1])
    return {"u1_max": u1_max, "u1_l1": u1_l1, "u1_l2": u1_l2,
            "u_T": l2_difference(run.x, run.u, reference.x, reference.u),
            # Θ differs from θ by θ_A r, the same function for both runs (equal k)
            "theta_T": l2_difference(run.x, run.theta, reference.x, reference.theta)}


@dataclasses.dataclass
class Point:
    """One run of a ladder: its sizes, outcome, errors and cost."""

    cells: int
    dt: float
    status: str
    errors: dict[str, float]
    seconds: float  # setup + time loop (the best of the repeats)
    us_per_step: float
    iterations_mean: float
    message: str = ""
    steps: int = 0

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def _nan_errors() -> dict[str, float]:
    return dict.fromkeys(MEASURES, math.nan)


def timed_run(scene: Scene, repeats: int = 1, budget: float = 0.0) -> tuple[RunResult, float]:
    """Run ``scene`` in memory on one rank; the wall time is setup + loop, the best of up to
    ``repeats`` runs, repeated only while the runs so far took less than ``budget`` seconds."""
    from mpi4py import MPI

    from rodfem.run import simulate

    best, spent, result = math.inf, 0.0, None
    for _ in range(max(1, repeats)):
        result = simulate(scene, None, MPI.COMM_SELF, progress=False)
        seconds = result.summary["setup_seconds"] + result.summary["loop_seconds"]
        best, spent = min(best, seconds), spent + seconds
        if result.status != "complete" or spent >= budget:
            break
    return result, best


def point(scene: Scene, errors: Callable[[RunResult], dict[str, float]], repeats: int = 1,
          budget: float = 0.0) -> Point:
    """One ladder point: run ``scene`` and measure its errors (nan if the run did not complete)."""
    result, seconds = timed_run(scene, repeats, budget)
    s = result.summary
    complete = result.status == "complete"
    return Point(cells=scene["mesh.cells"], dt=scene["time.dt"], status=result.status,
                 errors=errors(result) if complete else _nan_errors(), seconds=seconds,
                 us_per_step=s["us_per_step"], iterations_mean=s["iterations_mean"],
                 message=" ".join(str(result.error).split()) if result.error else "",
                 steps=int(s.get("steps", 0)))


def step(refined: str, cells: int, dt: float, tolerance: float | None = None) -> float:
    """The step a ladder refines: h for "h" and "h=dt" (h and Δt together), Δt for "dt", the
    adaptive steps' tolerance for "tol"."""
    if refined == "tol":
        return math.nan if tolerance is None else tolerance
    return dt if refined == "dt" else 1.0 / cells


def rates(points: Sequence[Point], by: str) -> dict[str, float]:
    """The observed order of each measure over the completed points, against ``by`` = "h",
    "dt" or "h=dt"."""
    done = [p for p in points if p.status == "complete"]
    steps = [step(by, p.cells, p.dt) for p in done]
    return {m: rate(steps, [p.errors[m] for p in done]) for m in MEASURES}


@dataclasses.dataclass
class Ladder:
    """A ladder's runs against its reference, and their observed orders."""

    points: list[Point]
    reference: RunResult
    by: str  # "h", "dt" or "h=dt": the step the ladder refines

    @property
    def rates(self) -> dict[str, float]:
        return rates(self.points, self.by)


def run_ladder(make: Callable[[int, float], Scene], ladder: Sequence[tuple[int, float]],
               reference: tuple[int, float] | RunResult, by: str, repeats: int = 1,
               budget: float = 0.0) -> Ladder:
    """Run a ladder of refinements of a scene against a much finer reference run.

    Args:
        make: (cells, Δt) → the scene at those sizes (validated; a SceneError propagates).
        ladder: the (cells, Δt) of each run; every cell count must divide the reference's and
            every Δt be a multiple of the reference's.
        reference: the reference's (cells, Δt), run with ``make``, or a reference run already
            made (to share one among methods).
        by: "h" or "dt", the step whose order :attr:`Ladder.rates` fits.
        repeats, budget: timing repeats of each point (:func:`timed_run`).

    Returns:
        The points in ladder order (errors nan where a run did not complete; the ladder stops at
        an interrupted run), the reference run and the observed orders.

    Raises:
        ValueError: a ladder point's mesh or times are not nested in the reference's.
        RuntimeError: the reference run did not complete.
    """
    if not hasattr(reference, "history"):
        reference, _ = timed_run(make(*reference))
        if reference.status != "complete":
            raise RuntimeError(f"the reference run did not complete ({reference.status})")
    points = []
    for cells, dt in ladder:
        points.append(point(make(cells, dt), lambda r: errors_against(r, reference), repeats,
                            budget))
        if points[-1].status == "interrupted":  # Ctrl-C: stop the ladder there
            break
    return Ladder(points, reference, by)


def time_to_reach(seconds: Sequence[float], errors: Sequence[float], target: float) -> float:
    """The wall time at which a ladder's error first falls to ``target``, interpolating log error
    linearly in log time between the two points around the first crossing; nan if it never does.
    A ladder whose first point already reaches it gives that point's time (an upper bound)."""
    t, e = np.asarray(seconds, float), np.asarray(errors, float)
    for i in range(t.size):
        if not (np.isfinite(e[i]) and e[i] <= target):
            continue
        if i == 0 or not np.isfinite(e[i - 1]) or e[i - 1] <= target:
            return float(t[i])
        s = (math.log(target) - math.log(e[i - 1])) / (math.log(e[i]) - math.log(e[i - 1]))
        return float(math.exp(math.log(t[i - 1]) + s * (math.log(t[i]) - math.log(t[i - 1]))))
    return math.nan
