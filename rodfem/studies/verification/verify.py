"""The verification harness (``rodfem verify``): observed orders of convergence in h and in Δt.

For each scene (paper1: near-rigid, rough contact; paper5: a soft obstacle, smooth; and paper1
with the obstacle out of reach), each time scheme and each method, two ladders of runs:

* in h: cells 25 … 400 at a fixed Δt, against a run on 3200 cells at the same Δt;
* in Δt: Δt = T/25 … T/800 on 250 cells, against a run with Δt = T/25600 on the same cells.

Each reference is solved by the direct method with the ladder's time scheme. Sharing the other
step with its ladder, it has the same error in that step to first order, so the differences
measure the refined step's error alone, and the orders are those of the refined step.
The errors are those of :mod:`rodfem.studies.verification.convergence`: u(1, ·) over [0, T] (max, L¹
and L² in time), u and θ at T (L² in space). The scenes of :mod:`rodfem.model.manufactured` (with
known exact solutions, one with a heat exchange across the gap) are measured against their exact
solutions.

The impact benchmark (:mod:`rodfem.model.impact`: an elastic bar released against a rigid wall,
the scene's own redistributed mass) has an exact solution too, but not a smooth one: its fronts
and the contact's start and end are kinks that move at speed 1, so an error in h and one in Δt do
not separate, and its one ladder refines both together, h = Δt (the direction "h=dt"), over one
period, T = 3; every run is measured against the exact u(1, ·) and u(·, T), with no reference run.

Ladders (a scene, a direction, a time scheme: the reference and every method's runs) are dealt
to the MPI ranks with those of the user's scene files by :mod:`rodfem.studies.verification.refine`,
the costliest first, each run on ``MPI.COMM_SELF``; the records do not depend on the number of
ranks, except the timings.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
from collections.abc import Callable

import numpy as np

from rodfem.model import impact
from rodfem.scene import METHODS, SCHEMA, Scene, SceneError, load
from rodfem.studies.common import parse_choices
from rodfem.studies import asymptotic
from rodfem.studies.verification import convergence as cv

# Scene keys → (built-in scene, overrides). T is set by the plan.
SCENES: dict[str, tuple[str, tuple[str, ...]]] = {
    "paper1": ("paper1", ()),
    "paper5": ("paper5", ()),
    "no-contact": ("paper1", ("obstacle.gap=10",)),
}
MANUFACTURED = "manufactured"
# the manufactured solutions (rodfem.model.manufactured), on the same ladders
MANUFACTURED_SCENES = (MANUFACTURED, "manufactured-gap")
IMPACT = "impact"
# the scenes measured against an exact solution: no reference runs
EXACT = (*MANUFACTURED_SCENES, IMPACT)
DIRECTIONS = ("h", "dt")
TOGETHER = "h=dt"  # the impact's ladder: h and Δt refined together
FILES = ("orders.csv", "orders.md", "orders.json", "errors.csv")
ERROR_COLUMNS = ("scene", "refined", "method", "scheme", "cells", "dt", "status", *cv.MEASURES,
                 "seconds", "us_per_step", "iterations_mean", "message")
# check_<measure>: "" (within the band of the expected order, or nothing to check),
# "pre-asymptotic" or "time error" (rodfem.studies.asymptotic)
ORDER_COLUMNS = ("scene", "refined", "method", "scheme", "points",
                 *(f"rate_{m}" for m in cv.MEASURES), *(f"finest_{m}" for m in cv.MEASURES),
                 "expected", *(f"check_{m}" for m in cv.MEASURES))


def schemes() -> tuple[str, ...]:
    """The time schemes this rodfem has ("paper" always)."""
    spec = SCHEMA["time"].get("scheme")
    return tuple(spec.choices) if spec is not None else ("paper",)


def manufactured():
    """:mod:`rodfem.model.manufactured`, or None where it does not exist."""
    if importlib.util.find_spec("rodfem.model.manufactured") is None:
        return None
    import rodfem.model.manufactured

    return rodfem.model.manufactured


def scheme_overrides(scheme: str) -> list[str]:
    return [f"time.scheme={scheme}"] if "scheme" in SCHEMA["time"] else []


def scene_at(key: str, cells: int, dt: float, end: float, method: str, scheme: str,
             overrides=()) -> Scene:
    """One of :data:`SCENES` at the given sizes, method and time scheme, and ``overrides``
    (validated)."""
    base, extra = SCENES[key]
    return load(base, [*extra, f"mesh.cells={cells}", f"time.dt={dt!r}", f"time.end={end!r}",
                       f"solver.method={method}", *scheme_overrides(scheme), *overrides])


@dataclasses.dataclass(frozen=True)
class Plan:
    """The ladders: sizes of every run and of the references."""

    end: float
    h_cells: tuple[int, ...]  # the h ladder, at Δt = h_dt
    h_dt: float
    h_reference: int  # its reference's cells, at the same Δt
    dt_cells: int  # the Δt ladder's cells
    dt_steps: tuple[int, ...]  # its steps N (Δt = T/N)
    dt_reference: int  # its reference's steps, on the same cells
    methods: tuple[str, ...]
    # the manufactured solution's ladders, against its exact solution
    mms_end: float
    mms_h_cells: tuple[int, ...]
    mms_h_dt: float
    mms_dt_cells: int
    mms_dt_steps: tuple[int, ...]
    # the impact's ladder h = Δt (1/h cells), to T = impact_end
    impact_end: float
    impact_h: tuple[float, ...]

    def ladder(self, direction: str, manufactured: bool = False) -> list[tuple[int, float]]:
        if direction == TOGETHER:
            return [(round(1.0 / h), 1.0 / round(1.0 / h)) for h in self.impact_h]
        if manufactured:
            if direction == "h":
                return [(c, self.mms_h_dt) for c in self.mms_h_cells]
            return [(self.mms_dt_cells, self.mms_end / n) for n in self.mms_dt_steps]
        if direction == "h":
            return [(c, self.h_dt) for c in self.h_cells]
        return [(self.dt_cells, self.end / n) for n in self.dt_steps]

    def reference(self, direction: str) -> tuple[int, float]:
        if direction == "h":
            return self.h_reference, self.h_dt
        return self.dt_cells, self.end / self.dt_reference

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


# T = 1 covers the first contact of paper1 and paper5 (t ≈ 0.19) and the first separation. The
# manufactured solution: h ladder at Δt = T/5000 (the paper's time error stays below a tenth of
# the spatial one up to 64 cells), Δt ladder on 4096 cells (the spatial error below a tenth of
# Crank–Nicolson's time error down to Δt = T/80). The impact: one period, h = Δt from 1e-2 to
# 5e-4, the sizes at which tests/test_redistributed.py compares its errors with GetFEM's.
DEFAULT = Plan(end=1.0, h_cells=(25, 50, 100, 200, 400), h_dt=1e-4, h_reference=3200,
               dt_cells=250, dt_steps=(25, 50, 100, 200, 400, 800), dt_reference=25600,
               methods=METHODS, mms_end=0.5, mms_h_cells=(8, 16, 32, 64), mms_h_dt=1e-4,
               mms_dt_cells=4096, mms_dt_steps=(10, 20, 40, 80), impact_end=3.0,
               impact_h=(1e-2, 2e-3, 1e-3, 5e-4))
# Seconds: the direct method only, three runs per ladder. At these sizes the paper scheme's
# errors on the scene without contact already fall at order 1 in Δt to within 0.05, and
# Crank–Nicolson's L¹ error of u(1, ·) on the impact at its order, 0.7.
QUICK = Plan(end=1.0, h_cells=(8, 16, 32), h_dt=1e-3, h_reference=256, dt_cells=16,
             dt_steps=(25, 50, 100), dt_reference=3200, methods=("direct",), mms_end=0.5,
             mms_h_cells=(8, 16, 32), mms_h_dt=1e-3, mms_dt_cells=1024, mms_dt_steps=(10, 20, 40),
             impact_end=3.0, impact_h=(2e-2, 1e-2, 5e-3))


class VerifyError(ValueError):
    """A bad option of ``rodfem verify`` (one line, naming the option)."""


def available_scenes() -> tuple[str, ...]:
    return (*SCENES, *(MANUFACTURED_SCENES if manufactured() is not None else ()), IMPACT)


def parse_scenes(text: str | None) -> tuple[str, ...]:
    """``"paper1,no-contact"`` → the scenes, in their standard order; None gives all."""
    allowed = available_scenes()
    if text is None:
        return allowed
    return parse_choices(text, "--scenes", allowed, "scene", VerifyError)


@dataclasses.dataclass(frozen=True)
class Group:
    """A ladder of one scene in one direction with one time scheme, for every method."""

    scene: str
    refined: str
    scheme: str


def directions(scene: str) -> tuple[str, ...]:
    """The ladders of a scene: in h and in Δt, or for the impact in h = Δt."""
    return (TOGETHER,) if scene == IMPACT else DIRECTIONS


def groups(scenes: tuple[str, ...]) -> list[Group]:
    return [Group(k, d, s) for k in scenes for s in schemes() for d in directions(k)]


def _end(scene: str, plan: Plan) -> float:
    ends = {**dict.fromkeys(MANUFACTURED_SCENES, plan.mms_end), IMPACT: plan.impact_end}
    return ends.get(scene, plan.end)


def cost(group: Group, plan: Plan) -> float:
    """The work of a group, in cell-steps: its ladder for each method, and its reference."""
    ladder = plan.ladder(group.refined, group.scene in MANUFACTURED_SCENES)
    end = _end(group.scene, plan)
    work = len(plan.methods) * sum(c * end / dt for c, dt in ladder)
    if group.scene not in EXACT:
        c, dt = plan.reference(group.refined)
        work += c * end / dt
    return work


def _record(group: Group, method: str, p: cv.Point) -> dict:
    return {"scene": group.scene, "refined": group.refined, "method": method,
            "scheme": group.scheme, "cells": p.cells, "dt": p.dt, "status": p.status,
            **p.errors, "seconds": p.seconds, "us_per_step": p.us_per_step,
            "iterations_mean": p.iterations_mean, "message": p.message}


def _maker(group: Group, plan: Plan, method: str) -> Callable[[int, float], Scene]:
    if group.scene == IMPACT:  # Δt = h = 1/cells
        return lambda c, dt: impact.scene(1.0 / c, end=plan.impact_end, overrides=[
            f"solver.method={method}", *scheme_overrides(group.scheme)])
    if group.scene in MANUFACTURED_SCENES:
        mms = manufactured()
        return lambda c, dt: mms.scene(c, dt, end=plan.mms_end, overrides=[
            f"solver.method={method}", *scheme_overrides(group.scheme)], name=group.scene)
    return lambda c, dt: scene_at(group.scene, c, dt, plan.end, method, group.scheme)


def run_group(group: Group, plan: Plan) -> tuple[list[dict], list[dict], dict]:
    """The reference (direct) and every method's ladder of one group.

    Returns:
        The records of the runs, the (method, scheme) choices the scene rejects (with the
        message), and the reference's sizes and wall time.
    """
    records, rejected, reference = [], [], {}
    ladder = plan.ladder(group.refined, group.scene in MANUFACTURED_SCENES)
    if group.scene not in EXACT:
        cells, dt = plan.reference(group.refined)
        run, seconds = cv.timed_run(_maker(group, plan, "direct")(cells, dt))
        if run.status == "interrupted":
            return [{"status": "interrupted"}], rejected, reference
        if run.status != "complete":
            raise RuntimeError(f"{group}: the reference run did not complete: {run.error}")
        reference = {"cells": cells, "dt": dt, "seconds": seconds}
    for method in plan.methods:
        make = _maker(group, plan, method)
        try:
            make(*ladder[0])
        except SceneError as err:
            rejected.append({"scene": group.scene, "method": method, "scheme": group.scheme,
                             "message": str(err)})
            continue
        if group.scene in EXACT:
            measure = impact_errors if group.scene == IMPACT else _manufactured_errors
            points = []
            for cells, dt in ladder:
                scene = make(cells, dt)
                points.append(cv.point(scene, measure(scene)))
                if points[-1].status == "interrupted":
                    break
        else:
            points = cv.run_ladder(make, ladder, run, group.refined).points
        records += [_record(group, method, p) for p in points]
        if any(p.status == "interrupted" for p in points):
            break
    return records, rejected, reference


def _manufactured_errors(scene: Scene) -> Callable:
    def errors(result) -> dict[str, float]:
        e = manufactured().errors(result, scene)
        return {"u1_max": math.nan, "u1_l1": math.nan, "u1_l2": math.nan, "u_T": e["u"],
                "theta_T": e["theta"]}

    return errors


def impact_errors(scene: Scene) -> Callable:
    """The measures of a run of the impact scene against its exact solution: u(1, ·) over the
    steps n ≥ 1 (the max as :func:`rodfem.model.impact.errors` takes it, without the start,
    where a redistributed mass puts the end off the exact one by construction; L¹ and L² as for
    every scene), u(·, T) in L² by quadrature (the exact u has kinks inside cells); no heat, so
    no θ."""
    from rodfem.model.manufactured import l2_error
    from rodfem.output.columns import INDEX

    def errors(result) -> dict[str, float]:
        t, u_1 = result.history[:, INDEX["t"]], result.history[:, INDEX["u_1"]]
        e = u_1 - impact.end_displacement(t)
        _, u1_l1, u1_l2 = cv.time_norms(t, e)
        end = float(t[-1])
        return {"u1_max": float(np.max(np.abs(e[1:]))), "u1_l1": u1_l1, "u1_l2": u1_l2,
                "u_T": l2_error(result.x, result.u, lambda x: impact.displacement(x, end)),
                "theta_T": math.nan}

    return errors


def orders(records: list[dict]) -> list[dict]:
    """The observed orders of each (scene, direction, method, scheme), its finest errors, the
    expected order and each order's check against it (:mod:`.asymptotic`)."""
    keys = list(dict.fromkeys((r["scene"], r["refined"], r["method"], r["scheme"])
                              for r in records))
    rows = []
    for scene, refined, method, scheme in keys:
        mine = [r for r in records if (r["scene"], r["refined"], r["method"], r["scheme"])
                == (scene, refined, method, scheme)]
        done = [r for r in mine if r["status"] == "complete"]
        steps = [cv.step(refined, r["cells"], r["dt"], r.get("tolerance")) for r in done]
        row = {"scene": scene, "refined": refined, "method": method, "scheme": scheme,
               "points": f"{len(done)}/{len(mine)}"}
        for m in cv.MEASURES:
            row[f"rate_{m}"] = cv.rate(steps, [r[m] for r in done])
            row[f"finest_{m}"] = done[-1][m] if done else math.nan
        row["expected"] = asymptotic.expected(refined, scheme)
        for m in cv.MEASURES:
            row[f"check_{m}"] = asymptotic.check(row[f"rate_{m}"], row["expected"])
        rows.append(row)
    return rows


def method_spread(records: list[dict]) -> dict[str, float]:
    """For each measure, the largest relative difference of a method's error from the direct
    method's at the same point: how far the methods' answers differ, seen through the errors."""
    direct = {(r["scene"], r["refined"], r["scheme"], r["cells"], r["dt"]): r for r in records
              if r["method"] == "direct" and r["status"] == "complete"}
    spread = dict.fromkeys(cv.MEASURES, 0.0)
    for r in records:
        d = direct.get((r["scene"], r["refined"], r["scheme"], r["cells"], r["dt"]))
        if d is None or r["status"] != "complete":
            continue
        for m in cv.MEASURES:
            if math.isfinite(d[m]) and d[m] > 0:
                spread[m] = max(spread[m], abs(r[m] - d[m]) / d[m])
    return spread
