"""The work–precision chart (``rodfem work-precision``): accuracy against wall time.

For each (method, time scheme), a ladder of (cells, Δt) refinements of paper1 (near-rigid, rough
contact) and paper5 (a soft obstacle, smooth) to the scenes' own end T = 8, each run timed
(set-up + time loop, the best of a few repeats for short runs) and measured against one reference
run, fine in both h and Δt (the direct method, Crank–Nicolson). The first-order scheme refines Δt
by 8 for each halving of h, the second-order one by 2. On paper5 the wall time at which each
choice first reaches an error of 1e-3 in u(1, ·) (max over [0, T]) is interpolated log–log
between its ladder's points, and set against (picard, paper), the paper's own choice.

The impact benchmark (:mod:`rodfem.model.impact`, an elastic bar released against a rigid wall)
is measured against its exact solution instead, over one period T = 3, for each mass matrix as
well (``discretisation.mass``): that is where the choices differ most, since the mass at the
contact node decides how the end behaves while it rests on the wall. Its ladders refine h and Δt
together (h = Δt, the scene's own choice: the solution's kinks move at speed 1, so neither error
falls alone), and its error is GetFEM's measure, the L¹ norm of u(1, ·) − u_exact(1, ·) over the
steps. The choices the scene rejects (Crank–Nicolson with the rigid obstacle needs a
redistributed mass; picard cannot solve the rigid obstacle) are reported as such, with the
scene's reason.

Beside each fixed-step ladder, an adaptive one (``time.adaptive = true``): the tolerances 1e-2 …
1e-6, each on a mesh fine enough for its error (:data:`ADAPTIVE_CELLS`; the impact's h), from the
first step 1e-3 (the impact's: h), with the impact's own mass, by the direct method. Its times
are its own, so the paper scenes' reference is interpolated to them.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from rodfem.model import impact
from rodfem.scene import METHODS, Scene, SceneError
from rodfem.scene.schema import MASSES
from rodfem.studies.common import deal, machine, prepare, write_csv
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification.verify import (
    ERROR_COLUMNS,
    IMPACT,
    TOGETHER,
    impact_errors,
    scene_at,
    schemes,
)

if TYPE_CHECKING:
    from mpi4py import MPI

FILES = ("workprecision.csv", "workprecision.json")
TARGET, TARGET_SCENE = 1e-3, "paper5"
PAPER_CHOICE = ("picard", "paper")
IMPACT_MEASURE = "u1_l1"  # GetFEM's: Σₙ Δt |Uⁿ(1) − u(1, tⁿ)|
# verify's columns, the mass matrix of the run, and an adaptive run's tolerance (empty for fixed
# steps, whose dt is the step; an adaptive run's is its first) and steps
COLUMNS = (*ERROR_COLUMNS[:ERROR_COLUMNS.index("scheme") + 1], "mass",
           *ERROR_COLUMNS[ERROR_COLUMNS.index("scheme") + 1:ERROR_COLUMNS.index("dt") + 1],
           "tolerance", "steps", *ERROR_COLUMNS[ERROR_COLUMNS.index("dt") + 1:])
TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
# the adaptive ladders' meshes, a tolerance each (the last for any beyond): Crank–Nicolson's h
# for about the same error, so that the time error is not hidden under the spatial one
ADAPTIVE_CELLS = (25, 50, 100, 200, 400)
FIRST_STEP = 1e-3
IMPACT_MASS = "redistributed"  # the impact's own, for its adaptive ladders


@dataclasses.dataclass(frozen=True)
class Plan:
    """The ladders per time scheme and the reference, as (cells, n) with Δt = 1/n."""

    end: float
    scenes: tuple[str, ...]
    ladders: dict[str, tuple[tuple[int, int], ...]]
    reference: tuple[int, int]
    reference_scheme: str
    methods: tuple[str, ...] = METHODS
    repeats: int = 3  # timing repeats of a run, while they take less than budget seconds
    budget: float = 1.0
    # the impact, against its exact solution: h = Δt, to impact_end, each mass, scheme and method
    impact_h: tuple[float, ...] = ()
    impact_end: float = 3.0
    impact_masses: tuple[str, ...] = MASSES
    impact_methods: tuple[str, ...] = METHODS
    # the adaptive ladders (none if empty): the tolerances, the mesh of each, and the methods
    # (the direct one: the methods give the same steps, and the fixed ladders show their costs)
    tolerances: tuple[float, ...] = ()
    adaptive_cells: tuple[int, ...] = ()
    adaptive_methods: tuple[str, ...] = ("direct",)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


# Each rung halves Δt. The paper scheme's error in u(1, ·) is its time error (in verify, its
# spatial error is 6e-4 at 25 cells and falls as h², its time error 1.3e-3 at Δt = 1/800 and falls
# as Δt), so it halves h only every third rung, keeping the spatial error below a fifth of the
# time error at no more cost than it needs; Crank–Nicolson's two errors are of a size and fall
# alike, so it halves h on every rung.
FIRST_ORDER = ((25, 50), (25, 100), (25, 200), (50, 400), (50, 800), (50, 1600), (100, 3200),
               (100, 6400), (200, 12800))
SECOND_ORDER = ((25, 25), (50, 50), (100, 100), (200, 200), (400, 400), (800, 800))


def default_plan(quick: bool = False) -> Plan:
    """The default ladders to the paper scenes' own end, T = 8 (or, ``quick``, three short runs
    each, T = 1, the direct method only), and the impact's, h = Δt from 1e-2 to 1e-3 (``quick``:
    three coarse rungs), every method. The reference is Crank–Nicolson where it exists."""
    second = "crank-nicolson" if "crank-nicolson" in schemes() else "paper"
    if quick:
        ladders = {s: ((8, 10), (16, 40), (32, 160)) if s == "paper"
                   else ((8, 10), (16, 20), (32, 40)) for s in schemes()}
        return Plan(end=1.0, scenes=("paper1", "paper5"), ladders=ladders, reference=(128, 640),
                    reference_scheme=second, methods=("direct",), repeats=1,
                    impact_h=(2e-2, 1e-2, 5e-3), tolerances=TOLERANCES[:3],
                    adaptive_cells=(8, 16, 32))
    ladders = {s: FIRST_ORDER if s == "paper" else SECOND_ORDER for s in schemes()}
    return Plan(end=8.0, scenes=("paper1", "paper5"), ladders=ladders, reference=(3200, 25600),
                reference_scheme=second, impact_h=(1e-2, 5e-3, 2e-3, 1e-3),
                tolerances=TOLERANCES, adaptive_cells=ADAPTIVE_CELLS)


@dataclasses.dataclass(frozen=True)
class Task:
    """One ladder: a scene with a (method, time scheme), and for the impact a mass; of fixed steps
    or adaptive ones."""

    scene: str
    method: str
    scheme: str
    mass: str | None = None  # None: the scene's own
    adaptive: bool = False

    def ladder(self, plan: Plan) -> list[tuple[int, float]]:
        """(cells, Δt) of each rung; adaptive, (cells, tolerance)."""
        if self.adaptive:
            cells = [round(1.0 / h) for h in plan.impact_h] if self.scene == IMPACT \
                else list(plan.adaptive_cells)
            return [(cells[min(j, len(cells) - 1)], tolerance)
                    for j, tolerance in enumerate(plan.tolerances)]
        if self.scene == IMPACT:
            return [(round(1.0 / h), 1.0 / round(1.0 / h)) for h in plan.impact_h]
        return [(cells, 1.0 / n) for cells, n in plan.ladders[self.scheme]]

    def make(self, plan: Plan, cells: int, size: float) -> Scene:
        """The rung's scene, ``size`` its Δt or tolerance (validated: a SceneError for a choice
        the scene rejects)."""
        adaptive = ["time.adaptive=true", f"time.tolerance={size!r}"] if self.adaptive else []
        if self.scene == IMPACT:
            return impact.scene(1.0 / cells, end=plan.impact_end, overrides=[
                f"discretisation.mass={self.mass}", f"time.scheme={self.scheme}",
                f"solver.method={self.method}", *adaptive])
        return scene_at(self.scene, cells, FIRST_STEP if self.adaptive else size, plan.end,
                        self.method, self.scheme, adaptive)

    def cost(self, plan: Plan) -> float:
        """Its work in cell-steps (an iterative method's step about thrice the direct one's)."""
        end = plan.impact_end if self.scene == IMPACT else plan.end
        rungs = self.ladder(plan)  # an adaptive run's steps guessed as those of its first step
        return sum(c * end / (FIRST_STEP if self.adaptive else size) for c, size in rungs) \
            * (1 if self.method == "direct" else 3)

    def name(self) -> str:
        return ", ".join(x for x in (self.scene, self.mass, self.method, self.scheme,
                                     "adaptive" if self.adaptive else "") if x)


def tasks(plan: Plan) -> list[Task]:
    """The paper scenes' ladders, then the impact's, mass by mass; then the adaptive ones."""
    adaptive = bool(plan.tolerances)
    return [*(Task(scene, method, scheme) for scene in plan.scenes for scheme in plan.ladders
              for method in plan.methods),
            *(Task(IMPACT, method, scheme, mass) for mass in plan.impact_masses if plan.impact_h
              for scheme in plan.ladders for method in plan.impact_methods),
            *(Task(scene, method, scheme, adaptive=True) for scene in plan.scenes if adaptive
              for scheme in plan.ladders for method in plan.adaptive_methods),
            *(Task(IMPACT, method, scheme, IMPACT_MASS, True) for scheme in plan.ladders
              if adaptive and plan.impact_h for method in plan.adaptive_methods)]


def _reference(scene: str, plan: Plan) -> tuple:
    """The reference run, its wall time, and its own error estimate: max |u(1, t)| difference
    from the same run with h and Δt doubled."""
    cells, n = plan.reference
    run, seconds = cv.timed_run(scene_at(scene, cells, 1.0 / n, plan.end, "direct",
                                         plan.reference_scheme))
    coarser, _ = cv.timed_run(scene_at(scene, cells // 2, 2.0 / n, plan.end, "direct",
                                       plan.reference_scheme))
    if run.status != "complete" or coarser.status != "complete":
        raise RuntimeError(f"the reference run of {scene} did not complete")
    return run, seconds, cv.errors_against(coarser, run)["u1_max"]


def _measure(task: Task, scene: Scene, references: dict):
    """The errors of a run of ``task``: against the impact's exact solution, or the scene's
    reference run."""
    if task.scene == IMPACT:
        return impact_errors(scene)
    reference = references[task.scene][0]
    return lambda run: cv.errors_against(run, reference, interpolated=task.adaptive)


def sweep(plan: Plan, comm: MPI.Comm, report=None) -> tuple[list[dict], list[dict], dict] | None:
    """The references (a scene per rank, then shared), then every ladder (:func:`tasks`), dealt
    among the ranks; the records and the rejected choices on every rank, or None if a run was
    interrupted."""
    references = {}
    for i in range(comm.rank, len(plan.scenes), comm.size):
        references[plan.scenes[i]] = _reference(plan.scenes[i], plan)
    references = {k: v for part in comm.allgather(references) for k, v in part.items()}
    todo = tasks(plan)
    mine, rejected, stopped = [], [], False
    for index in deal([task.cost(plan) for task in todo], comm.size)[comm.rank]:
        task = todo[index]
        ladder = task.ladder(plan)
        try:
            task.make(plan, *ladder[0])
        except SceneError as err:
            rejected.append({"scene": task.scene, "method": task.method, "scheme": task.scheme,
                             "mass": task.mass, "adaptive": task.adaptive,
                             "message": str(err)})
            continue
        started = time.perf_counter()
        for cells, size in ladder:
            scene = task.make(plan, cells, size)
            p = cv.point(scene, _measure(task, scene, references), plan.repeats, plan.budget)
            mine.append((index, {"scene": task.scene,
                                 "refined": TOGETHER if task.scene == IMPACT else "both",
                                 "method": task.method, "scheme": task.scheme,
                                 "mass": scene["discretisation.mass"], "cells": p.cells,
                                 "dt": p.dt, "tolerance": size if task.adaptive else None,
                                 "steps": p.steps, "status": p.status, **p.errors,
                                 "seconds": p.seconds, "us_per_step": p.us_per_step,
                                 "iterations_mean": p.iterations_mean, "message": p.message}))
            stopped = p.status == "interrupted"
            if stopped:
                break
        if stopped:
            break
        if report is not None:
            report(f"[{index + 1}/{len(todo)}] {task.name()}: {len(ladder)} runs in "
                   f"{time.perf_counter() - started:.1f} s")
    gathered = comm.allgather((stopped, mine, rejected))
    if any(s for s, _, _ in gathered):
        return None
    records = [r for _, r in sorted((pair for _, part, _ in gathered for pair in part),
                                    key=lambda p: p[0])]
    order = {(t.scene, t.method, t.scheme, t.mass, t.adaptive): i for i, t in enumerate(todo)}
    rejected = sorted((r for _, _, part in gathered for r in part),
                      key=lambda r: order[r["scene"], r["method"], r["scheme"], r["mass"],
                                          r["adaptive"]])
    info = {s: {"cells": plan.reference[0], "dt": 1.0 / plan.reference[1],
                "scheme": plan.reference_scheme, "seconds": references[s][1],
                "u1_max_against_half_resolution": references[s][2]}
            for s in plan.scenes}
    return records, rejected, info


def choice(record: dict, *keys: str) -> str:
    """A ladder's name in the summaries: its ``keys``' values, and "adaptive" for adaptive steps."""
    return ", ".join([*(record[k] for k in keys), *(["adaptive"] if record.get("tolerance")
                                                    else [])])


def reach(records: list[dict], scene: str = TARGET_SCENE, target: float = TARGET) -> dict:
    """For each (method, scheme), fixed or adaptive, on ``scene``: the wall time at which
    u(1, ·)'s max error first reaches ``target``; the fastest, and its ratio to the paper's
    choice (picard, paper, fixed steps)."""
    times = {}
    for name in dict.fromkeys(choice(r, "method", "scheme") for r in records
                              if r["scene"] == scene):
        mine = [r for r in records if r["scene"] == scene and r["status"] == "complete"
                and choice(r, "method", "scheme") == name]
        times[name] = cv.time_to_reach([r["seconds"] for r in mine],
                                       [r["u1_max"] for r in mine], target)
    reached = {k: v for k, v in times.items() if math.isfinite(v)}
    fastest = min(reached, key=reached.get) if reached else None
    paper = times.get(", ".join(PAPER_CHOICE), math.nan)
    ratio = reached[fastest] / paper if fastest and math.isfinite(paper) else math.nan
    return {"scene": scene, "target": target, "seconds": times, "fastest": fastest,
            "fastest_seconds": reached.get(fastest, math.nan) if fastest else math.nan,
            "paper_choice": ", ".join(PAPER_CHOICE), "paper_choice_seconds": paper,
            "ratio": ratio}


def impact_summary(records: list[dict], rejected: list[dict]) -> dict | None:
    """The impact's choices at their finest h = Δt (adaptive: h and tolerance): the error
    (:data:`IMPACT_MEASURE`) and wall time of each (mass, scheme, method), fixed or adaptive, the
    most accurate, and how many the scene rejects."""
    mine = [r for r in records if r["scene"] == IMPACT]
    if not mine:
        return None
    finest = {}
    for r in mine:
        key = choice(r, "mass", "scheme", "method")
        fineness = (r["dt"], r.get("tolerance") or 0.0)
        if r["status"] == "complete" and math.isfinite(r[IMPACT_MEASURE]) \
                and (key not in finest or fineness < finest[key]["fineness"]):
            finest[key] = {"dt": r["dt"], "tolerance": r.get("tolerance"),
                           "error": r[IMPACT_MEASURE], "seconds": r["seconds"],
                           "steps": r["steps"], "fineness": fineness}
    for kept in finest.values():
        del kept["fineness"]
    best = min(finest, key=lambda k: finest[k]["error"]) if finest else None
    return {"measure": IMPACT_MEASURE, "against": "exact solution (rodfem.model.impact)",
            "finest": finest, "best": best,
            "rejected": len([r for r in rejected if r["scene"] == IMPACT])}


def run_work_precision(out: Path, plan: Plan, force: bool, progress: bool, comm: MPI.Comm
                       ) -> dict | None:
    """Prepare ``out``, run the ladders, write workprecision.csv/json (rank 0); the data, or None
    if interrupted (nothing written). Raises OutputError on a bad ``out``."""
    from rodfem.output.files import write_json
    prepare(out, force, comm, FILES, "work-precision")

    def report(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    started = time.perf_counter()
    swept = sweep(plan, comm, report if progress else None)
    seconds = max(comm.allgather(time.perf_counter() - started))
    if swept is None:
        return None
    records, rejected, references = swept
    data = {"end": plan.end, "plan": plan.as_dict(), "reference_method": "direct",
            "references": references, "target": TARGET, "target_scenes": [TARGET_SCENE],
            "reach": reach(records) if TARGET_SCENE in plan.scenes else None,
            "impact": impact_summary(records, rejected),
            "rejected": rejected, "points": records, "seconds": seconds,
            "machine": machine(comm)}
    if comm.rank == 0:
        write_csv(out / FILES[0], COLUMNS, records)
    write_json(out / FILES[1], data, comm)
    comm.barrier()
    return data


def summary_lines(data: dict, out: Path) -> list[str]:
    lines = [f"work-precision: {len(data['points'])} runs in {data['seconds']:.0f} s -> {out}"]
    r = data.get("reach")
    if r:
        shown = "; ".join(f"{k}: {v:.3g} s" if math.isfinite(v) else f"{k}: not reached"
                          for k, v in r["seconds"].items())
        lines.append(f"{r['scene']}: time to reach max |u(1,t) error| = {r['target']:g}: {shown}")
        if r["fastest"] and math.isfinite(r["ratio"]):
            lines.append(f"fastest: {r['fastest']}, {r['ratio']:.3g} of {r['paper_choice']}'s "
                         "time")
    i = data.get("impact")
    if i and i["best"]:
        b = i["finest"][i["best"]]
        at = f"h = {b['dt']:g}, tolerance {b['tolerance']:g}" if b.get("tolerance") \
            else f"h = Δt = {b['dt']:g}"
        lines.append(f"impact: smallest L¹ error of u(1,·) against the exact solution at "
                     f"{at}: {b['error']:.3g} ({i['best']}, {b['seconds']:.3g} s); "
                     f"{i['rejected']} choices the scene rejects")
    return lines
