"""Convergence of a user's own scene (``rodfem verify --scenes FILE.toml``), and the run of
every verify ladder, the built-in scenes' (:mod:`rodfem.studies.verification.verify`) and the
user's.

A scene file (its ``--set`` values applied) gets ladders of its own sizes, refined by 2 from them,
with the scene's own method and time scheme:

* in h: cells c, 2c, 4c (… with more rungs) at the scene's Δt (adaptive steps: the tolerance
  ladder's finest tolerance, whose time error that ladder measures, :func:`flag_time_errors`),
  against a run on :attr:`Ladders.h_reference` times the finest rung's cells;
* in Δt: Δt, Δt/2, Δt/4 … on the scene's cells, against a run with the finest Δt over
  :attr:`Ladders.dt_reference`; with adaptive steps (``time.adaptive``) the tolerance is refined
  in its place (the scheme's default where the scene gives 0), against a run at the finest
  tolerance over the same factor.

Each rung's errors against the reference are those of the built-in scenes
(:data:`rodfem.studies.verification.convergence.MEASURES`; adaptive runs compared at their own
times), and every run's measures (:func:`rodfem.output.measures.measures`, but the wall time) are
kept: the order of each measure from the last three rungs and its Richardson estimate
(:func:`rodfem.studies.verification.convergence.richardson`) need no reference at all.

Each order is checked against the expected one (:mod:`.asymptotic`). A sweep file in
``--scenes`` gives a scene file of each of its scenes (or those ``--select`` names), named
<file's name>-<index>.

Each scene's ladders are tasks dealt with the built-in ones to the MPI ranks, the costliest first,
each run on ``MPI.COMM_SELF``: the tables do not depend on the number of ranks, but the timings.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from rodfem.scene import Scene, SceneError, load
from rodfem.scene.files import read_file
from rodfem.scene.loading import _parse_override
from rodfem.scene.schema import TOLERANCES
from rodfem.studies.common import deal, machine, prepare, write_csv
from rodfem.studies.sweep import design
from rodfem.studies import asymptotic
from rodfem.studies.verification import verify
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification.orders import markdown, summary_lines  # noqa: F401 (the command prints them)

if TYPE_CHECKING:
    from mpi4py import MPI


@dataclasses.dataclass(frozen=True)
class Ladders:
    """The ladders of a user's scene."""

    rungs: int  # runs per ladder, each refining the one before by 2 (3 at least: an order)
    h_reference: int  # the h reference: this many times the finest rung's cells
    dt_reference: int  # the Δt (tolerance) reference: the finest rung's over this


# The reference's own error, relative to the finest rung's, is 8⁻² (order 2 in h) and 16⁻¹ (order
# 1 in Δt): it moves the errors' slopes by 0.035 at most (Δt, three rungs; the measures' orders
# need no reference). Three rungs cost 1 + 2 + 4 runs of the scene a ladder, and the references
# 32 (h) and 64 (Δt): about 110 runs of the scene in all (paper5's file, T = 8: 13 s; four
# rungs, 26 s; docs/accuracy.md).
QUICK = Ladders(rungs=3, h_reference=8, dt_reference=16)
DEFAULT = Ladders(rungs=4, h_reference=8, dt_reference=16)
FILES = (*verify.FILES, "measures.csv", "measure_orders.csv")
# errors.csv: verify's columns, and the tolerance of an adaptive run (empty for fixed steps)
ERROR_COLUMNS = (*verify.ERROR_COLUMNS[:verify.ERROR_COLUMNS.index("dt") + 1], "tolerance",
                 *verify.ERROR_COLUMNS[verify.ERROR_COLUMNS.index("dt") + 1:])
MEASURE_COLUMNS = ("scene", "refined", "method", "scheme", "cells", "dt", "tolerance", "status",
                   "measure", "value")
MEASURE_ORDER_COLUMNS = ("scene", "refined", "method", "scheme", "measure", "runs", "finest",
                         "expected", "order", "richardson", "note")


@dataclasses.dataclass(frozen=True)
class UserScene:
    """A scene file to verify (or a scene of a sweep file: ``member``, its index), its ``--set``
    values and its name in the tables."""

    key: str
    path: str
    overrides: tuple[str, ...]
    member: int | None = None

    def at(self, cells: int | None = None, dt: float | None = None,
           tolerance: float | None = None) -> Scene:
        """The scene, with other cells, Δt or tolerance where given, keeping the row of every
        step (the errors and measures are of every step, whatever rows the scene keeps)."""
        sizes = ["output.history_every=1", *([f"mesh.cells={cells}"] if cells else []),
                 *([f"time.dt={dt!r}"] if dt else []),
                 *([f"time.tolerance={tolerance!r}"] if tolerance else [])]
        if self.member is None:
            return load(self.path, [*self.overrides, *sizes])
        extra = {f"{section}.{key}": value for section, key, value
                 in map(_parse_override, [*self.overrides, *sizes])}
        return design.load(self.path).scene(self.member, extra)


# The sections only a sweep file has: a TOML file in --scenes with one of them is a sweep, each
# of its scenes (or those --select names) verified as a scene file is.
SWEEP_SECTIONS = ("set", "grid", "zip", "sample")


def is_sweep(path: str) -> bool:
    """Whether the TOML file ``path`` is a sweep file (SceneError if it cannot be read)."""
    data = read_file(path, f"scene '{path}'")
    return any(section in data for section in SWEEP_SECTIONS)


def parse_select(text: str | None) -> tuple[int, ...] | None:
    """``"1,3"`` → the indices of a sweep's scenes to verify (results.csv's index, from 0);
    None for every scene.

    Raises:
        VerifyError: an item that is not an index (one line).
    """
    if text is None:
        return None
    indices = []
    for item in (i.strip() for i in text.split(",")):
        if not item.isdigit():
            raise verify.VerifyError(f"--select: {item!r} is not the index of a scene; give "
                                     "indices of the sweep's scenes from 0 (results.csv's "
                                     "index), comma-separated, e.g. 1,3")
        indices.append(int(item))
    return tuple(sorted(set(indices)))


def members(path: str, overrides: tuple[str, ...], select: tuple[int, ...] | None
            ) -> list[UserScene]:
    """The scenes of the sweep file ``path`` to verify, each named <file's name>-<index>.

    Raises:
        VerifyError: a mistake in the sweep, a value a scene refuses, or an index it does not
            have (one line).
    """
    try:
        spec = design.load(path)
    except SceneError as err:
        raise verify.VerifyError(f"--scenes: {err}") from None
    if select is not None and select[-1] >= len(spec):
        raise verify.VerifyError(f"--select: {Path(path).name} has {len(spec)} scenes, indices "
                                 f"0 to {len(spec) - 1}; got {select[-1]}")
    chosen = select if select is not None else range(len(spec))
    users = [UserScene(f"{Path(path).stem}-{i}", path, tuple(overrides), i) for i in chosen]
    for user in users:
        try:
            user.at()
        except SceneError as err:
            raise verify.VerifyError(f"--scenes: {err}") from None
    return users


def parse_scenes(text: str | None, overrides: list[str] | tuple[str, ...] = (),
                 ladders: Ladders | None = None, select: str | None = None
                 ) -> tuple[tuple[str, ...], tuple[UserScene, ...]]:
    """``"paper1,my.toml,study.toml"`` → the built-in scenes (in their standard order) and the
    scene files and sweeps' scenes (in the given order; a sweep's, those of ``select`` or all),
    each loaded with ``overrides`` to check it, and every run of its ``ladders`` (default
    :data:`DEFAULT`).

    Raises:
        VerifyError: an unknown name, a file that cannot be read or a bad value (one line),
            ``--set`` without a scene file, or ``--select`` without a sweep file.
    """
    allowed = verify.available_scenes()
    chosen = parse_select(select)
    if text is None:
        if overrides:
            raise verify.VerifyError("--set: applies to a scene file given in --scenes; the "
                                     "built-in scenes are verified as they are")
        if chosen is not None:
            raise verify.VerifyError("--select: applies to a sweep file given in --scenes")
        return allowed, ()
    names = [item.strip() for item in text.split(",")]
    users, sweeps = [], 0
    for name in names:
        if name in allowed:
            continue
        if not name.endswith(".toml"):
            raise verify.VerifyError(f"--scenes: unknown scene {name!r}; allowed: "
                                     f"{', '.join(allowed)}, or a scene or sweep file (.toml)")
        try:
            sweep = is_sweep(name)
        except SceneError as err:
            raise verify.VerifyError(f"--scenes: {name}: {str(err).split(': ', 1)[-1]}") \
                from None
        if sweep:
            found = members(name, tuple(overrides), chosen)
            sweeps += 1
        else:
            try:
                load(name, overrides)
            except SceneError as err:
                raise verify.VerifyError(f"--scenes: {name}: {err}") from None
            found = [UserScene(Path(name).stem, name, tuple(overrides))]
        for user in found:
            if user.key in allowed or user.key in (u.key for u in users):
                raise verify.VerifyError(f"--scenes: the scene file {name!r} has the name "
                                         f"{user.key!r} of another scene; rename the file")
            users.append(user)
            _check_ladders(user, ladders or DEFAULT)
    if overrides and not users:
        raise verify.VerifyError("--set: applies to a scene file given in --scenes; the "
                                 "built-in scenes are verified as they are")
    if chosen is not None and not sweeps:
        raise verify.VerifyError("--select: applies to a sweep file given in --scenes")
    return tuple(a for a in allowed if a in names), tuple(users)


def _check_ladders(user: UserScene, ladders: Ladders) -> None:
    """Every run of a scene file's ladders is a valid scene."""
    for group in user_groups((user,)):
        for sizes in ladder(user, group.refined, ladders):
            try:
                user.at(**sizes)
            except SceneError as err:
                told = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                                 for k, v in sizes.items() if v is not None)
                where = user.path if user.member is None else f"{user.path}, scene {user.key}"
                raise verify.VerifyError(f"--scenes: {where}: its {group.refined} ladder's "
                                         f"run at {told}: {err}") from None


def tolerance(scene: Scene) -> float:
    """The adaptive steps' tolerance of a scene: its own, or its scheme's default (0)."""
    return scene["time.tolerance"] or TOLERANCES[scene["time.scheme"]]


def ladder(user: UserScene, refined: str, ladders: Ladders) -> list[dict]:
    """The sizes of each rung of a ladder (cells, dt, tolerance), then the reference's."""
    scene = user.at()
    cells, dt = scene["mesh.cells"], scene["time.dt"]
    tol = tolerance(scene) if scene.adaptive else None
    halves = [2 ** k for k in range(ladders.rungs)]
    if refined == "h":  # adaptive: at the tolerance ladder's finest (asymptotic.POLLUTION)
        tol_h = tol / halves[-1] if tol is not None else None
        rungs = [dict(cells=cells * k, dt=dt, tolerance=tol_h) for k in halves]
        return [*rungs, dict(cells=rungs[-1]["cells"] * ladders.h_reference, dt=dt,
                             tolerance=tol_h)]
    if refined == "tol":
        rungs = [dict(cells=cells, dt=dt, tolerance=tol / k) for k in halves]
        return [*rungs, dict(cells=cells, dt=dt, tolerance=tol / halves[-1] / ladders.dt_reference)]
    rungs = [dict(cells=cells, dt=dt / k, tolerance=None) for k in halves]
    return [*rungs, dict(cells=cells, dt=dt / halves[-1] / ladders.dt_reference, tolerance=None)]


@dataclasses.dataclass(frozen=True)
class UserGroup:
    """One ladder of a user's scene: in h, in Δt, or in the adaptive steps' tolerance."""

    user: UserScene
    refined: str

    @property
    def scene(self) -> str:
        return self.user.key


def user_groups(users: tuple[UserScene, ...]) -> list[UserGroup]:
    return [UserGroup(u, d) for u in users for d in ("h", "tol" if u.at().adaptive else "dt")]


def cost(group: UserGroup, ladders: Ladders) -> float:
    """The work of a ladder in cell-steps (adaptive steps counted at the first step)."""
    end = group.user.at()["time.end"]
    return sum(s["cells"] * end / s["dt"] for s in ladder(group.user, group.refined, ladders))


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
