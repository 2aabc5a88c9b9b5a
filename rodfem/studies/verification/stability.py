"""The stability map: where each method solves the scheme (3.1)–(3.2), over (Δt, ε, ζ, a).

Every point of a log grid of Δt, ε, ζ and a is one run of a base scene (``paper1`` unless another
is given) with each method. Each run records whether it converged (or where and why it failed),
its iterations, its energy behaviour (Remark 4.4) and its cost, next to the two predictions for
Picard's iteration (3.3)–(3.4):

* the paper's sufficient condition, Δt < εζ and a < 1 (never true for ζ = 0);
* the compliance condition w/ε < 1 (for another law, its contraction w φ''(u(1)) < 1 at the
  largest u(1) of the run: :meth:`rodfem.model.contact.ContactLaw.contraction`),
  w = :attr:`rodfem.solver.methods.direct.DirectMethod.compliance` the response of Uⁿ(1) to a unit
  contact force over one step: while the contact is active, Picard maps the contact force p ↦
  (1/ε)[s − w p − g]_+ (exactly so for a = 0), which contracts iff w < ε and otherwise ends in a
  2-cycle.

Points are dealt round-robin to the MPI ranks, each run on ``MPI.COMM_SELF``; the records are
gathered in grid order, so they do not depend on the number of ranks (except the timings).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rodfem.model import contact
from rodfem.output.columns import INDEX
from rodfem.scene import METHODS, Scene, SceneError, load, validate
from rodfem.studies.common import machine, parse_choices, prepare, write_csv

if TYPE_CHECKING:
    from mpi4py import MPI

# Δt must divide the end time: 1, 2, 5 per decade; ε at half decades. Chosen so that the default
# map takes about 6 minutes under mpirun -n 2 on a 2-core machine (3,120 runs of 10 to 10⁴ steps).
DEFAULT_DT = tuple(float(f"{m}e{e}") for e in range(-4, -1) for m in (1, 2, 5)) + (0.1,)
DEFAULT_EPSILON = tuple(float(f"{m}e{e}") for e in range(-6, 0) for m in (1, 3)) + (1.0,)
DEFAULT_ZETA = (0.0, 0.02, 0.2, 2.0)
DEFAULT_A = (0.017, 1.0)  # the paper's, and one where its condition a < 1 fails
DEFAULT_END = 1.0  # the rod first touches the obstacle at t ≈ 0.1-0.5 over the default grid
FILES = ("stability.csv", "stability.json")
# One row per point and method. The timings (last two) are the only columns that depend on the
# number of ranks.
COLUMNS = ("method", "a", "zeta", "dt", "epsilon", "status", "converged", "steps",
           "steps_planned", "fail_step", "fail_time", "iterations_mean", "iterations_max",
           "energy_non_increasing", "energy_max_increase", "contact_steps", "first_contact",
           "min_sigma_1", "w", "paper_ratio", "paper_predicts", "w_ratio", "w_predicts",
           "error", "us_per_step", "loop_seconds")
TIMING = ("us_per_step", "loop_seconds")


class GridError(ValueError):
    """A bad grid option: the message is one line naming the option."""


@dataclasses.dataclass(frozen=True)
class Grid:
    """The values swept; each tuple sorted and without repeats."""

    dt: tuple[float, ...] = DEFAULT_DT
    epsilon: tuple[float, ...] = DEFAULT_EPSILON
    zeta: tuple[float, ...] = DEFAULT_ZETA
    a: tuple[float, ...] = DEFAULT_A
    methods: tuple[str, ...] = METHODS
    end: float = DEFAULT_END

    def points(self) -> list[dict]:
        """Every (method, a, ζ, Δt, ε), smallest Δt (most steps) first, so that a round-robin deal
        gives every rank a like share of the work."""
        return [dict(method=m, a=a, zeta=z, dt=dt, epsilon=e)
                for dt in self.dt for z in self.zeta for a in self.a for e in self.epsilon
                for m in self.methods]

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def parse_list(text: str | None, option: str, default: tuple[float, ...]) -> tuple[float, ...]:
    """``"1e-3,1e-2"`` → (0.001, 0.01), sorted, repeats dropped; None gives ``default``."""
    if text is None:
        return default
    items = [item.strip() for item in text.split(",")]
    values = []
    for item in items:
        try:
            value = float(item)
        except ValueError:
            raise GridError(f"{option}: {item!r} is not a number (give a comma-separated list, "
                            f"e.g. {option} 1e-3,1e-2)") from None
        if not math.isfinite(value):
            raise GridError(f"{option}: {item!r} is not a finite number")
        values.append(value)
    return tuple(sorted(set(values)))


def parse_number(text: str | None, option: str, default: float) -> float:
    values = parse_list(text, option, (default,))
    if len(values) != 1:
        raise GridError(f"{option}: expected one number, got {text!r}")
    return values[0]


def parse_methods(text: str | None) -> tuple[str, ...]:
    if text is None:
        return METHODS
    return parse_choices(text, "--methods", METHODS, "method", GridError)


def _with(base: Scene, point: dict, end: float) -> Scene:
    """The base scene at one point of the grid (validated)."""
    data = base.data()
    data["time"].update(dt=point["dt"], end=end)
    data["obstacle"]["epsilon"] = point["epsilon"]
    data["model"].update(zeta=point["zeta"], a=point["a"])
    data["solver"]["method"] = point["method"]
    if base.description:
        data["description"] = base.description
    return validate(data, base.source)


def check(scene: str, overrides: list[str], grid: Grid) -> Scene:
    """Load the base scene and check every value of the grid against it, before anything runs.

    Raises:
        SceneError: the scene, or a value of the grid, is wrong (the message names the option).
    """
    base = load(scene, overrides)
    if base["obstacle.kind"] != "elastic":
        raise SceneError(f"scene '{scene}': the stability map sweeps the elastic obstacle's "
                         'epsilon; it needs obstacle.kind = "elastic"')
    # One value changed at a time from the base scene's, over one step (Δt = end). An end time
    # out of range fails as Δt first: then it is checked with the base scene's Δt, which names it.
    first = dict(method=base["solver.method"], a=base["model.a"], zeta=base["model.zeta"],
                 dt=grid.end, epsilon=base["obstacle.epsilon"])
    try:
        _with(base, first, grid.end)
    except SceneError:
        changes = [("--end", grid.end, {"dt": base["time.dt"]})]
    else:
        changes = []
    changes += [("--dt", v, {"dt": v}) for v in grid.dt]
    changes += [("--epsilon", v, {"epsilon": v}) for v in grid.epsilon]
    changes += [("--zeta", v, {"zeta": v}) for v in grid.zeta]
    changes += [("--a", v, {"a": v}) for v in grid.a]
    changes += [("--methods", m, {"method": m}) for m in grid.methods]
    for option, value, change in changes:
        try:
            _with(base, {**first, **change}, grid.end)
        except SceneError as err:
            shown = value if isinstance(value, str) else f"{value:g}"
            raise SceneError(f"{option} {shown}: {err}") from None
    return base


class Compliance:
    """w(Δt, ζ, a) of the base scene, computed once per rank for each (Δt, ζ, a) it meets."""

    def __init__(self, base: Scene, end: float):
        self.base, self.end, self._cache = base, end, {}

    def __call__(self, dt: float, zeta: float, a: float) -> float:
        key = (dt, zeta, a)
        if key not in self._cache:
            from mpi4py import MPI

            from rodfem.discrete.discretisation import Discretisation
            from rodfem.solver.methods.direct import DirectMethod

            point = dict(method="direct", a=a, zeta=zeta, dt=dt, epsilon=1.0)
            scene = _with(self.base, point, self.end)
            self._cache[key] = DirectMethod(Discretisation(scene, MPI.COMM_SELF)).compliance
        return self._cache[key]


def run_point(scene: Scene, w: float) -> dict:
    """One run (no files, one rank) and what the map records of it."""
    from mpi4py import MPI

    from rodfem.run import simulate

    result = simulate(scene, None, MPI.COMM_SELF, progress=False)
    s, error = result.summary, result.error
    sigma = result.history[:, INDEX["sigma_1"]]
    touching = np.flatnonzero(sigma < 0.0)
    # Picard's contraction where the rod presses hardest (w/ε for the paper's law, wherever)
    u_1 = result.history[:, INDEX["u_1"]]
    rate = contact.of_scene(scene).contraction(w, float(u_1.max()))
    dt, eps, zeta, a = (scene[k] for k in ("time.dt", "obstacle.epsilon", "model.zeta",
                                           "model.a"))
    paper_ratio = dt / (eps * zeta) if zeta > 0 else math.inf
    increase = s["energy_max_increase"]
    return {
        "method": scene["solver.method"], "a": a, "zeta": zeta, "dt": dt, "epsilon": eps,
        "status": result.status, "converged": result.status == "complete",
        "steps": s["steps"], "steps_planned": s["steps_planned"],
        "fail_step": error.step if error else None, "fail_time": error.time if error else None,
        "iterations_mean": s["iterations_mean"], "iterations_max": s["iterations_max"],
        "energy_non_increasing": s["energy_non_increasing"],
        "energy_max_increase": increase,
        "contact_steps": int(touching.size),
        "first_contact": (float(result.history[touching[0], INDEX["t"]]) if touching.size
                          else None),
        "min_sigma_1": float(sigma.min()),
        "w": w, "paper_ratio": paper_ratio, "paper_predicts": bool(paper_ratio < 1 and a < 1),
        "w_ratio": rate, "w_predicts": bool(rate < 1),
        "error": str(error) if error else "",
        "us_per_step": s["us_per_step"], "loop_seconds": s["loop_seconds"],
    }


def sweep(base: Scene, grid: Grid, comm: MPI.Comm,
          report=None) -> list[dict] | None:
    """Run every point of the grid, dealt round-robin over ``comm``'s ranks.

    Args:
        base: the base scene (from :func:`check`).
        grid: the values swept.
        comm: the ranks that share the work; each point runs on one rank (``COMM_SELF``).
        report: called on the rank that ran it with (index, total, record), e.g. a progress line.

    Returns:
        The records, one per point, in the order of :meth:`Grid.points`, on every rank; None if a
        run was interrupted (Ctrl-C, or SIGUSR1 to mpirun), on every rank.
    """
    points = grid.points()
    w = Compliance(base, grid.end)
    mine, interrupted = [], False
    for index in range(comm.rank, len(points), comm.size):
        point = points[index]
        record = run_point(_with(base, point, grid.end),
                           w(point["dt"], point["zeta"], point["a"]))
        if record["status"] == "interrupted":
            interrupted = True
            break
        mine.append((index, record))
        if report is not None:
            report(index, len(points), record)
    gathered = comm.allgather((interrupted, mine))
    if any(stopped for stopped, _ in gathered):
        return None
    records = sorted((pair for _, part in gathered for pair in part), key=lambda p: p[0])
    return [record for _, record in records]


def _fraction(hits: int, total: int) -> float | None:
    return hits / total if total else None


def boundary(rows: list[dict]) -> dict:
    """Picard's measured boundary against both predictions, over rows of one (ζ, a) or more."""
    rows = [r for r in rows if r["method"] == "picard"]
    ok = [r["converged"] for r in rows]
    out = {"points": len(rows), "converged": sum(ok)}
    for name, key, ratio in (("paper", "paper_predicts", "paper_ratio"),
                             ("compliance", "w_predicts", "w_ratio")):
        predicted = [r[key] for r in rows]
        out[name] = {
            "agree": _fraction(sum(p == c for p, c in zip(predicted, ok, strict=True)), len(rows)),
            "predicted_converge": sum(predicted),
            # the prediction says it converges, but it failed (for the paper: a counter-example
            # to its sufficient condition)
            "predicted_but_failed": sum(p and not c for p, c in zip(predicted, ok, strict=True)),
            # it converged where the prediction does not say so
            "converged_unpredicted": sum(c and not p for p, c in zip(predicted, ok, strict=True)),
            # the largest ratio at which Picard converged, the smallest at which it failed
            # (finite ratios only: the paper's is infinite for ζ = 0)
            "max_ratio_converged": max((r[ratio] for r in rows
                                        if r["converged"] and math.isfinite(r[ratio])),
                                       default=None),
            "min_ratio_failed": min((r[ratio] for r in rows
                                     if not r["converged"] and math.isfinite(r[ratio])),
                                    default=None),
        }
    return out


def per_dt(rows: list[dict]) -> list[dict]:
    """For each Δt of one (ζ, a): Picard's smallest converging and largest failing ε, next to
    w(Δt) and the paper's ε = Δt/ζ."""
    rows = [r for r in rows if r["method"] == "picard"]
    out = []
    for dt in sorted({r["dt"] for r in rows}):
        at = [r for r in rows if r["dt"] == dt]
        good = [r["epsilon"] for r in at if r["converged"]]
        bad = [r["epsilon"] for r in at if not r["converged"]]
        out.append({
            "dt": dt, "w": at[0]["w"],
            "paper_epsilon": dt / at[0]["zeta"] if at[0]["zeta"] > 0 else None,
            "smallest_converged_epsilon": min(good, default=None),
            "largest_failed_epsilon": max(bad, default=None),
            # every ε above the smallest converging one converges too
            "monotone": not bad or not good or max(bad) < min(good),
        })
    return out


def summarise(records: list[dict], grid: Grid) -> dict:
    """The JSON summary: per method, and Picard's boundary per (ζ, a) and over all."""
    methods = {}
    for method in grid.methods:
        rows = [r for r in records if r["method"] == method]
        methods[method] = {
            "points": len(rows),
            "converged": sum(r["converged"] for r in rows),
            "converged_energy_increase": sum(r["converged"] and not r["energy_non_increasing"]
                                             for r in rows),
            "converged_without_contact": sum(r["converged"] and r["contact_steps"] == 0
                                             for r in rows),
            "iterations_mean": float(np.mean([r["iterations_mean"] for r in rows
                                              if r["converged"]] or [np.nan])),
            "us_per_step_median": float(np.median([r["us_per_step"] for r in rows])),
            "failed": [{k: r[k] for k in ("a", "zeta", "dt", "epsilon", "error")}
                       for r in rows if not r["converged"]] if method != "picard" else None,
        }
    summary = {"methods": methods}
    if "picard" in grid.methods:
        summary["picard"] = boundary(records)
        summary["picard_by_zeta_a"] = []
        for z in grid.zeta:
            for a in grid.a:
                rows = [r for r in records if r["zeta"] == z and r["a"] == a]
                summary["picard_by_zeta_a"].append(
                    {"zeta": z, "a": a, **boundary(rows), "per_dt": per_dt(rows)})
    return summary


def write(out: Path, records: list[dict], grid: Grid, base: Scene, overrides: list[str],
          seconds: float, comm: MPI.Comm) -> None:
    """stability.csv and stability.json into ``out`` (rank 0)."""
    from rodfem.output.files import write_json

    data = {
        "scene": base.source, "overrides": list(overrides), "grid": grid.as_dict(),
        "tol": base["solver.tol"], "max_iterations": base["solver.max_iterations"],
        "cells": base["mesh.cells"], "mass": base["discretisation.mass"],
        "gap": base["obstacle.gap"],
        "points": len(records), "seconds": seconds, "machine": machine(comm),
        "summary": summarise(records, grid),
    }
    if comm.rank == 0:
        write_csv(out / FILES[0], COLUMNS, records)
    write_json(out / FILES[1], data, comm)


def progress_line(index: int, total: int, r: dict) -> str:
    what = (f"{r['iterations_mean']:.2f} it/step" if r["converged"]
            else f"failed at t = {r['fail_time']:g}")
    return (f"[{index + 1:>{len(str(total))}}/{total}] {r['method']:<6} a={r['a']:g} "
            f"ζ={r['zeta']:g} Δt={r['dt']:g} ε={r['epsilon']:g} (w/ε={r['w_ratio']:.3g}): "
            f"{r['status']}, {what}")


def run_map(out: Path, scene: str, overrides: list[str], grid: Grid, force: bool,
         progress: bool, comm: MPI.Comm) -> tuple[list[dict] | None, float]:
    """Check, prepare ``out``, sweep and write; returns the records (None if interrupted) and
    the wall time. Raises SceneError or OutputError (nothing written) on bad input."""
    base = check(scene, overrides, grid)
    prepare(out, force, comm, FILES, "stability")

    def report(index, total, record):
        print(progress_line(index, total, record), file=sys.stderr, flush=True)

    started = time.perf_counter()
    records = sweep(base, grid, comm, report if progress else None)
    seconds = max(comm.allgather(time.perf_counter() - started))
    if records is not None:
        write(out, records, grid, base, overrides, seconds, comm)
    comm.barrier()
    return records, seconds


def report_lines(records: list[dict], grid: Grid, seconds: float, out: Path,
                 ranks: int) -> list[str]:
    """What ``rodfem stability`` prints: the run, then each method's result."""
    points = len(records) // max(1, len(grid.methods))
    lines = [f"stability: {points} points x {len(grid.methods)} methods in {seconds:.0f} s on "
             f"{ranks} rank{'s' if ranks > 1 else ''} -> {out}"]
    summary = summarise(records, grid)
    for method, m in summary["methods"].items():
        line = (f"{method}: converged at {m['converged']} of {m['points']} points, "
                f"{m['converged_energy_increase']} of them with an energy increase")
        if method == "picard":
            b = summary["picard"]
            c, p = b["compliance"], b["paper"]
            line += (f"; w/eps < 1 predicts it at {100 * (c['agree'] or 0):.1f}% of points "
                     f"(converged up to w/eps = {c['max_ratio_converged'] or 0:.3g}, failed from "
                     f"{c['min_ratio_failed'] or math.inf:.3g}); dt < eps*zeta, a < 1 at "
                     f"{100 * (p['agree'] or 0):.1f}% ({p['predicted_but_failed']} failures "
                     f"inside it, {p['converged_unpredicted']} convergences outside it)")
        lines.append(line)
    return lines
