"""Convergence of a user's own scene (``rodfem verify --scenes FILE.toml``), and the run of
every verify ladder, the built-in scenes' (:mod:`rodfem.studies.verification.verify`) and the
user's (:mod:`rodfem.studies.verification.ladders`: which scenes, and their ladders).

Each rung's errors against the reference are those of the built-in scenes
(:data:`rodfem.studies.verification.convergence.MEASURES`; adaptive runs compared at their own
times), and every run's measures (:func:`rodfem.output.measures.measures`, but the wall time) are
kept: the order of each measure from the last three rungs and its Richardson estimate
(:func:`rodfem.studies.verification.convergence.richardson`) need no reference at all.

Each order is checked against the expected one (:mod:`.asymptotic`). With adaptive steps, the
orders in h that the steps' time error may carry are flagged (:func:`flag_time_errors`).

Each scene's ladders are tasks dealt with the built-in ones to the MPI ranks, the costliest first,
each run on ``MPI.COMM_SELF``: the tables do not depend on the number of ranks, but the timings.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from rodfem.scene import Scene
from rodfem.studies.common import deal, machine, prepare, write_csv
from rodfem.studies.sweep import design
from rodfem.studies import asymptotic
from rodfem.studies.verification import verify
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification.ladders import (DEFAULT, Ladders, UserGroup, UserScene, cost,
                                                 ladder, tolerance, user_groups)
from rodfem.studies.verification.orders import markdown, summary_lines  # noqa: F401 (the command prints them)

if TYPE_CHECKING:
    from mpi4py import MPI


FILES = (*verify.FILES, "measures.csv", "measure_orders.csv")
# errors.csv: verify's columns, and the tolerance of an adaptive run (empty for fixed steps)
ERROR_COLUMNS = (*verify.ERROR_COLUMNS[:verify.ERROR_COLUMNS.index("dt") + 1], "tolerance",
                 *verify.ERROR_COLUMNS[verify.ERROR_COLUMNS.index("dt") + 1:])
MEASURE_COLUMNS = ("scene", "refined", "method", "scheme", "cells", "dt", "tolerance", "status",
                   "measure", "value")
MEASURE_ORDER_COLUMNS = ("scene", "refined", "method", "scheme", "measure", "runs", "finest",
                         "expected", "order", "richardson", "note")


def run_measures(result, scene: Scene) -> dict[str, float | int]:
    """A run's measures by name, but its wall time (:data:`rodfem.output.measures.TIMINGS`)."""
    from rodfem.output.columns import for_scene
    from rodfem.output.measures import TIMINGS, measures

    names = (column.name for column in for_scene(scene))
    values = measures({n: result.history[:, j] for j, n in enumerate(names)}, scene,
                      result.summary)
    return {k: v for k, v in values.items() if k not in TIMINGS}


def run_user_group(group: UserGroup, ladders: Ladders) -> tuple[list[dict], list[dict], dict]:
    """A ladder of a user's scene against its reference: the rungs' records (verify's, with
    the tolerance), their measures (a record per run and measure), the reference's sizes."""
    *rungs, ref = ladder(group.user, group.refined, ladders)
    reference, seconds = cv.timed_run(group.user.at(**ref))
    if reference.status == "interrupted":
        return [{"status": "interrupted"}], [], {}
    if reference.status != "complete":
        raise RuntimeError(f"{group.scene}, {group.refined} ladder: the reference run "
                           f"{ref} did not complete: {reference.error}")
    records, measured = [], []
    for sizes in rungs:
        scene = group.user.at(**sizes)
        kept = {}

        def errors(result, scene=scene, kept=kept):
            kept.update(run_measures(result, scene))
            return cv.errors_against(result, reference, interpolated=scene.adaptive)

        p = cv.point(scene, errors)
        head = {"scene": group.scene, "refined": group.refined,
                "method": scene["solver.method"], "scheme": scene["time.scheme"],
                "cells": p.cells, "dt": p.dt, "tolerance": sizes["tolerance"]}
        records.append({**head, "status": p.status, **p.errors, "seconds": p.seconds,
                        "us_per_step": p.us_per_step, "iterations_mean": p.iterations_mean,
                        "message": p.message})
        measured += [{**head, "status": p.status, "measure": k, "value": v}
                     for k, v in kept.items()]
        if p.status == "interrupted":
            break
    return records, measured, {**ref, "seconds": seconds,
                               "measures": run_measures(reference, group.user.at(**ref))}


def measure_orders(measured: list[dict], records: list[dict],
                   stepped: dict[str, tuple[str, ...]] | None = None) -> list[dict]:
    """Each ladder's measures: the order from the last three rungs, checked against the expected
    one, and the Richardson estimate with the expected order
    (:mod:`rodfem.studies.asymptotic`), or the note that says why there is none: a
    measure set by the steps (``stepped``: by scene, :func:`asymptotic.stepped`), an order
    outside the band (pre-asymptotic; the order is kept), or
    :func:`rodfem.studies.verification.convergence.richardson`'s. A rung that did not complete
    has no measures: nan in its place (``records``, the rungs)."""
    rows = []
    key = lambda r: (r["scene"], r["refined"], r["method"], r["scheme"], r["measure"])  # noqa: E731
    rung = lambda r: (r["cells"], r["dt"], r["tolerance"])  # noqa: E731
    for k in dict.fromkeys(map(key, measured)):
        found = {rung(r): r["value"] for r in measured if key(r) == k}
        values = [found.get(rung(r), math.nan) for r in records
                  if (r["scene"], r["refined"], r["method"], r["scheme"]) == k[:4]]
        expect = asymptotic.expected(k[1], k[3])
        if k[4] in (stepped or {}).get(k[0], ()):
            order, estimate, note = math.nan, math.nan, asymptotic.STEPPED
        else:
            order, estimate, note = cv.richardson(values)
            if note == "" and asymptotic.within(order, expect):
                estimate = asymptotic.estimate(values, expect)
            elif note == "":
                estimate, note = math.nan, asymptotic.PRE_ASYMPTOTIC
        rows.append({**dict(zip(("scene", "refined", "method", "scheme", "measure"), k,
                                strict=True)), "runs": len(values),
                     "finest": values[-1] if values else math.nan, "expected": expect,
                     "order": order, "richardson": estimate, "note": note})
    return rows


def _last(rows: list[dict], scene: str, refined: str) -> list[dict]:
    return [r for r in rows if (r["scene"], r["refined"]) == (scene, refined)]


def flag_time_errors(orders: list[dict], measure_rows: list[dict], records: list[dict],
                     measured: list[dict], references: dict, users: tuple[UserScene, ...],
                     ladders: Ladders) -> None:
    """With adaptive steps, flag the orders in h that the steps' time error may carry
    (:data:`asymptotic.POLLUTION`), in place: the h ladder runs at the tolerance ladder's finest
    tolerance, whose time error is that rung's difference from the tolerance ladder's reference
    (over 1 − r^(−p), r the reference's refinement and p the expected order in the tolerance:
    what the reference's own error leaves out). An error's order is flagged where this exceeds
    the fraction of the finest h rung's error; a measure's where it exceeds the fraction of the
    h ladder's last difference (then without a Richardson estimate)."""
    for user in users:
        tol = _last(records, user.key, "tol")
        if not tol or tol[-1].get("status") != "complete":
            continue
        h = _last(records, user.key, "h")
        scheme = tol[-1]["scheme"]
        scale = 1.0 / (1.0 - ladders.dt_reference ** -asymptotic.expected("tol", scheme))
        for row in _last(orders, user.key, "h"):
            for m in cv.MEASURES:
                finest = h[-1][m] if h and h[-1]["status"] == "complete" else math.nan
                if math.isfinite(row[f"rate_{m}"]) and \
                        not scale * tol[-1][m] <= asymptotic.POLLUTION * finest:
                    row[f"check_{m}"] = "time error"
        reference = references.get(f"{user.key}/tol", {}).get("measures", {})
        finest = {r["measure"]: r["value"] for r in measured
                  if (r["scene"], r["refined"]) == (user.key, "tol")
                  and (r["cells"], r["dt"], r["tolerance"]) ==
                  (tol[-1]["cells"], tol[-1]["dt"], tol[-1]["tolerance"])}
        for row in _last(measure_rows, user.key, "h"):
            m = row["measure"]
            if row["note"] not in ("", asymptotic.PRE_ASYMPTOTIC) or m not in reference:
                continue
            values = [r["value"] for r in measured if (r["scene"], r["refined"], r["measure"])
                      == (user.key, "h", m)]
            error = scale * abs(finest.get(m, math.nan) - reference[m])
            if not error <= asymptotic.POLLUTION * abs(values[-1] - values[-2]):
                row["richardson"], row["note"] = math.nan, asymptotic.TIME_ERROR


def _run(task, plan: verify.Plan, ladders: Ladders) -> tuple[list, list, list, dict]:
    if isinstance(task, UserGroup):
        records, measured, reference = run_user_group(task, ladders)
        return records, [], measured, reference
    records, rejected, reference = verify.run_group(task, plan)
    return records, rejected, [], reference


def sweep(plan: verify.Plan, ladders: Ladders, scenes: tuple[str, ...],
          users: tuple[UserScene, ...], comm: MPI.Comm,
          report: Callable[[str], None] | None = None) -> tuple | None:
    """Every ladder of ``scenes`` and ``users``, dealt over ``comm``'s ranks, the costliest
    first; the records, rejections, measures and references on every rank in ladder order
    (None on every rank if a run was interrupted)."""
    todo = [*verify.groups(scenes), *user_groups(users)]
    costs = [cost(g, ladders) if isinstance(g, UserGroup) else verify.cost(g, plan)
             for g in todo]
    mine, stopped = [], False
    for index in deal(costs, comm.size)[comm.rank]:
        g = todo[index]
        started = time.perf_counter()
        part = _run(g, plan, ladders)
        mine.append((index, *part))
        if any(r["status"] == "interrupted" for r in part[0]):
            stopped = True
            break
        if report is not None:
            scheme = f", {g.scheme}" if hasattr(g, "scheme") else ""
            report(f"[{index + 1}/{len(todo)}] {g.scene}, {g.refined} ladder{scheme}: "
                   f"{len(part[0])} runs in {time.perf_counter() - started:.1f} s")
    gathered = comm.allgather((stopped, mine))
    if any(s for s, _ in gathered):
        return None
    parts = sorted((part for _, rank in gathered for part in rank), key=lambda p: p[0])
    records = [r for p in parts for r in p[1]]
    rejected = list({(r["scene"], r["method"], r["scheme"]): r
                     for p in parts for r in p[2]}.values())
    measured = [r for p in parts for r in p[3]]
    references = {f"{todo[p[0]].scene}/{todo[p[0]].refined}"
                  + (f"/{todo[p[0]].scheme}" if hasattr(todo[p[0]], "scheme") else ""): p[4]
                  for p in parts if p[4]}
    return records, rejected, measured, references


def _scenes(scenes: tuple[str, ...], users: tuple[UserScene, ...], ladders: Ladders) -> dict:
    """What each verified scene is: a built-in one and its values, or a file and its ladders."""
    built = {k: {"scene": b, "overrides": list(o)} for k, (b, o) in verify.SCENES.items()
             if k in scenes}
    if verify.IMPACT in scenes:
        built[verify.IMPACT] = {"scene": verify.IMPACT, "overrides": []}
    for u in users:
        scene = u.at()
        sweep = {} if u.member is None else {
            "member": u.member, "values": design.describe(design.load(u.path).points[u.member])}
        built[u.key] = {"scene": u.path, "overrides": list(u.overrides), "user": True, **sweep,
                        "cells": scene["mesh.cells"], "dt": scene["time.dt"],
                        "end": scene["time.end"], "adaptive": scene.adaptive,
                        "tolerance": tolerance(scene) if scene.adaptive else None,
                        "h_tolerance": ladder(u, "h", ladders)[0]["tolerance"],
                        "method": scene["solver.method"], "scheme": scene["time.scheme"],
                        "rungs": ladders.rungs, "h_reference": ladders.h_reference,
                        "dt_reference": ladders.dt_reference}
    return built


def run_verify(out: Path, plan: verify.Plan, scenes: tuple[str, ...], force: bool,
               progress: bool, comm: MPI.Comm, users: tuple[UserScene, ...] = (),
               ladders: Ladders = DEFAULT) -> dict | None:
    """Prepare ``out``, run every ladder, write the tables (rank 0); return the data (None if
    interrupted: then nothing is written). Raises OutputError (nothing written) on a bad
    ``out``."""
    from rodfem.output.files import write_json, write_text
    prepare(out, force, comm, FILES, "verify")

    def report(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    started = time.perf_counter()
    swept = sweep(plan, ladders, scenes, users, comm, report if progress else None)
    seconds = max(comm.allgather(time.perf_counter() - started))
    if swept is None:
        return None
    records, rejected, measured, references = swept
    keys = [u.key for u in users]  # one method each: no spread
    orders = verify.orders(records)
    measure_rows = measure_orders(measured, records,
                                  {u.key: asymptotic.stepped(u.at()) for u in users})
    flag_time_errors(orders, measure_rows, records, measured, references, users, ladders)
    data = {
        "plan": plan.as_dict(), "scenes": _scenes(scenes, users, ladders),
        "schemes": list(verify.schemes()), "methods": list(plan.methods),
        "manufactured": any(k in scenes for k in verify.MANUFACTURED_SCENES),
        "impact": verify.IMPACT in scenes,
        "exact": [k for k in verify.EXACT if k in scenes],  # against an exact solution
        "user": keys,  # scene files, with their own ladders
        "reference_method": "direct", "references": references,
        "orders": orders,
        "method_spread": verify.method_spread([r for r in records if r["scene"] not in keys]),
        "measures": measured, "measure_orders": measure_rows,
        "rejected": rejected, "points": records, "seconds": seconds, "machine": machine(comm),
    }
    if comm.rank == 0:
        write_csv(out / "errors.csv", ERROR_COLUMNS,
                  [{"tolerance": None, **r} for r in records])
        write_csv(out / "orders.csv", verify.ORDER_COLUMNS, data["orders"])
        if users:
            write_csv(out / "measures.csv", MEASURE_COLUMNS, measured)
            write_csv(out / "measure_orders.csv", MEASURE_ORDER_COLUMNS, data["measure_orders"])
    write_text(out / "orders.md", markdown(data), comm)
    write_json(out / "orders.json", data, comm)
    comm.barrier()
    return data
