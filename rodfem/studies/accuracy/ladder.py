"""A scene with an accuracy target run to it: the mesh and the time step refined until every
targeted measure's estimated error is within its target (``[accuracy]``, docs/accuracy.md).

The runs (each a plain run of the scene, in memory, its mesh and time step set):

1. the scene's own cells c₀ and time step (``time.tolerance``, the scheme's default where 0, or
   ``time.dt``), then 2c₀ at the same step: the error in h; then 2c₀ at the next time level (a
   tenth of the tolerance, or half the step): the error in time;
2. then, while some measure's estimate (its errors in h and in time, each from the latest pair
   of runs that differ in that direction alone, combined: :mod:`.estimates`) exceeds its target
   times |m|, the direction whose estimate is the larger, for the measure furthest from its
   target, is refined once more: cells doubled, or the next time level;
3. until every measure is within its target (met), or ``accuracy.cells_max`` would be passed, or
   ``accuracy.runs_max`` runs are made (not met: said, never hidden);
4. with fixed steps, where a measure met rests on one pair of meshes for its error in h, a run on
   a quarter of the cells gives that error an observed order and a sign (:func:`.estimates.
   combined` then adds the two directions' errors by their signs), and the targets are checked
   again (not where the cells are not a multiple of 4, a quarter of them would be below the
   schema's least mesh, or no run is left: the error in h then rests on one pair); then, once a
   ladder, a direction whose order is outside its band (or has none) for some measure met, and
   so no sign to combine it by, is refined once more where the limits leave room, and the
   targets are checked again at that finer run (and refined on from there if no longer met).

The run reported is the finest in both directions (the last made but a check in h), made again
into the run directory with its files. Each direction's error is measured where the runs differ
in it alone: the error in h at the time level where it was last refined, and the error in time
on the mesh where it was last refined, each taken to hold at the other's refinement (the
adaptive steps hold a relative error whatever the mesh; a mesh's error does not depend on a time
step far smaller than its own scales). Every run is deterministic, so the whole ladder is
reproducible bit for bit from the scene, serially and on any number of ranks (each run uses them
all).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from rodfem.scene import Scene
from rodfem.scene.loading import validate
from rodfem.scene.schema import MAX_STEPS, SCHEMA, TOLERANCES
from rodfem.studies.accuracy.estimates import TOLERANCE_RATIO, Estimate, combined, estimate
from rodfem.studies.asymptotic import SPACE_ORDER, expected

if TYPE_CHECKING:
    from mpi4py import MPI

CELLS_FACTOR, CELLS_CAP = 64, 100_000  # accuracy.cells_max = 0: 64 c₀, at most 100,000
MIN_CELLS = SCHEMA["mesh"]["cells"].minimum  # the coarsest mesh a check in h may run on
COLUMNS = ("run", "cells", "time_step", "steps", "rejected_steps", "seconds")  # accuracy.csv


@dataclasses.dataclass(frozen=True)
class Rung:
    """One run of the ladder: its cells, time level, the targeted measures' values, steps,
    rejected steps and wall time."""

    cells: int
    level: int
    values: dict[str, float]
    steps: int
    rejected: int
    seconds: float


class AccuracyWarning(UserWarning):
    """A run with an accuracy target could not meet it within ``accuracy.cells_max`` and
    ``accuracy.runs_max``: the message names each measure missed, its estimated error, and
    why (the result is that of the finest run made)."""


class LadderFailed(RuntimeError):
    """A run of the ladder did not complete: ``result`` is its :class:`rodfem.run.RunResult`."""

    def __init__(self, rung_scene: Scene, result):
        super().__init__(result.status)
        self.scene, self.result = rung_scene, result


class Ladder:
    """The runs of ``scene`` at its targets (:attr:`Scene.targets`), made by :meth:`climb`."""

    def __init__(self, scene: Scene, comm: MPI.Comm, say: Callable[[str], None] | None = None,
                 setups=None):
        if not scene.targets:
            raise ValueError("the scene has no accuracy target")
        self.scene, self.comm, self.say = scene, comm, say
        self.targets = scene.targets
        scheme = scene["time.scheme"]
        self.adaptive = scene.adaptive
        if self.adaptive:
            self.time_key, self.ratio = "time.tolerance", TOLERANCE_RATIO
            self.first = scene["time.tolerance"] or TOLERANCES[scheme]
        else:
            self.time_key, self.ratio = "time.dt", 2.0
            self.first = scene["time.dt"]
        self.order = expected("tol" if self.adaptive else "dt", scheme)
        self.cells0 = scene["mesh.cells"]
        self.cells_max = scene["accuracy.cells_max"] or max(
            self.cells0, min(CELLS_FACTOR * self.cells0, CELLS_CAP))
        self.runs_max = scene["accuracy.runs_max"]
        self.rungs: dict[tuple[int, int], Rung] = {}
        self.limit: str | None = None  # what stopped the refinement short of the targets
        self.into_band = False  # whether a direction out of its band was refined once more
        from rodfem.run import SetUps

        self.setups = setups if setups is not None else SetUps()

    # -- the runs ------------------------------------------------------------------------------

    def step(self, level: int) -> float:
        """The time step (fixed) or tolerance (adaptive) of a time level."""
        return self.first / self.ratio ** level

    def scene_at(self, cells: int, level: int) -> Scene:
        """The plain scene of a rung: the scene's, with its cells and time step, and no target
        (running it gives that rung's run, bit for bit)."""
        data = self.scene.data()
        data.pop("accuracy", None)
        data["mesh"]["cells"] = cells
        data["time"][self.time_key.split(".")[1]] = self.step(level)
        for entry in data.get("measures", {}).values():
            entry.pop("target", None)
        step = f"{self.time_key} = {self.step(level):g}"
        chosen = f"{cells} cells and {step} chosen for its accuracy target"
        data["description"] = f"{self.scene.description}; {chosen}" if self.scene.description \
            else chosen
        return validate(data, self.scene.source)

    def run(self, cells: int, level: int) -> Rung:
        from rodfem.run import simulate

        scene = self.scene_at(cells, level)
        started = time.perf_counter()
        result = simulate(scene, None, self.comm, progress=False, setups=self.setups)
        seconds = self.comm.allreduce(time.perf_counter() - started, op=_max())
        if result.status != "complete":
            raise LadderFailed(scene, result)
        measures = result.summary["measures"]
        adaptive = result.summary.get("adaptive") or {}
        rung = Rung(cells, level, {name: float(measures[name]) for name in self.targets},
                    int(result.summary["steps"]), int(adaptive.get("rejected", 0)), seconds)
        self.rungs[cells, level] = rung
        if self.say is not None:
            self.say(self.line(rung))
        return rung

    # -- the estimates -------------------------------------------------------------------------

    def _difference(self, name: str, pairs) -> float | None:
        """m_fine − m_coarse of ``name`` for the first pair ((coarse, fine) keys) made."""
        for coarse, fine in pairs:
            if coarse in self.rungs and fine in self.rungs:
                return self.rungs[fine].values[name] - self.rungs[coarse].values[name]
        return None

    def _levels(self, level: int) -> list[int]:
        """The time levels made, the nearest to ``level`` first (the finer of two as near)."""
        return sorted({k for _, k in self.rungs}, key=lambda k: (abs(k - level), -k))

    def _space(self, name: str, cells: int, level: int) -> Estimate | None:
        """The error in h of ``name`` at (cells, level): from cells/2 beside cells at this time
        level or one next to it (None: no such pair), and for its observed order the pair of
        cells/4 and cells/2 at the nearest level that has it."""
        last = self._difference(name, (((cells // 2, k), (cells, k))
                                       for k in (level, level - 1, level + 1)))
        if last is None:
            return None
        before = self._difference(name, (((cells // 4, k), (cells // 2, k))
                                         for k in self._levels(level)))
        return estimate([d for d in (before, last) if d is not None], 2.0, SPACE_ORDER)

    def _time(self, name: str, cells: int, level: int) -> Estimate | None:
        """The error in time of ``name`` at (cells, level): from the level before on this mesh
        or on half its cells (None: no such pair), and for its observed order the pair of the
        two levels before that, on the finest mesh up to this one that has it."""
        last = self._difference(name, (((c, level - 1), (c, level)) for c in (cells, cells // 2)))
        if last is None:
            return None
        meshes = sorted({c for c, _ in self.rungs if c <= cells}, reverse=True)
        before = self._difference(name, (((c, level - 2), (c, level - 1)) for c in meshes))
        return estimate([d for d in (before, last) if d is not None], self.ratio, self.order,
                        power_law=not self.adaptive)

    def plan(self, cells: int, level: int) -> list[tuple[int, int]]:
        """The runs still to make for (cells, level) and an estimate in each direction near it:
        half its cells at its time level (unless a pair in h at a level next to it is made),
        its cells at the level before (unless a pair in time on half its cells is made), then
        (cells, level) itself."""
        made = self.rungs
        space = any((cells // 2, k) in made and ((cells, k) in made or k == level)
                    for k in (level, level - 1, level + 1))
        time_ = any((c, level - 1) in made and ((c, level) in made or c == cells)
                    for c in (cells, cells // 2))
        wanted = [*([] if space else [(cells // 2, level)]),
                  *([] if time_ else [(cells, level - 1)]), (cells, level)]
        return [key for key in wanted if key not in made]

    def errors(self, cells: int, level: int) -> dict[str, dict]:
        """Each targeted measure at (cells, level): its value, error in h and in time, their
        combination (:func:`.estimates.combined`), and whether it is within its target."""
        out = {}
        rung = self.rungs[cells, level]
        for name, target in self.targets.items():
            space, time_ = self._space(name, cells, level), self._time(name, cells, level)
            error = math.inf if space is None or time_ is None \
                else combined(space, time_, signed=not self.adaptive)
            value = rung.values[name]
            within = bool(error <= target * abs(value))
            out[name] = {"value": value, "error": error, "target": target,
                         "met": within and time_ is not None and time_.checked,
                     "within": within, "space": space,
                         "time": time_}
        return out

    # -- the climb -----------------------------------------------------------------------------

    def climb(self) -> tuple[int, int, dict[str, dict]]:
        """Run until the targets are met or a limit is reached: the reported (cells, level) and
        its :meth:`errors`."""
        cells, level = self.cells0, 0
        self.run(cells, level)
        if 2 * cells > self.cells_max:
            self.limit = "cells_max"
            return cells, level, self.errors(cells, level)
        cells *= 2
        self.run(cells, level)
        level += 1
        self.run(cells, level)
        while True:
            errors = self.errors(cells, level)
            if all(e["met"] for e in errors.values()):
                check = self._space_check(cells, level, errors)
                if check is not None:
                    self.run(*check)
                    continue
                nxt = self._into_band(cells, level, errors)
                if nxt is None:
                    return cells, level, errors
                for key in self.plan(*nxt):
                    self.run(*key)
                cells, level = nxt
                continue
            worst = max(errors.values(), key=_shortfall)
            # within its target on one pair of time levels: the time step refined to check it
            space = not worst["within"] and worst["space"].error >= worst["time"].error
            if space and 2 * cells > self.cells_max:
                self.limit = "cells_max"
                return cells, level, errors
            if not space and not self._time_room(level + 1):
                self.limit = "time"
                return cells, level, errors
            nxt = (2 * cells, level) if space else (cells, level + 1)
            runs = self.plan(*nxt)
            if len(self.rungs) + len(runs) > self.runs_max:
                self.limit = "runs_max"
                return cells, level, errors
            for key in runs:
                self.run(*key)
            cells, level = nxt

    def _space_check(self, cells: int, level: int, errors: dict[str, dict]):
        """With fixed steps, where some measure's error in h rests on one pair of meshes, the
        run that gives it an observed order and a sign, so that it combines with the error in
        time by their signs: a quarter of the cells at that pair's time level (None: none to
        make, or no run left for it)."""
        if self.adaptive or cells % 4 or cells // 4 < MIN_CELLS \
                or all(e["space"].checked for e in errors.values()):
            return None
        k = next(k for k in (level, level - 1, level + 1)
                 if (cells // 2, k) in self.rungs and (cells, k) in self.rungs)
        key = (cells // 4, k)
        return None if key in self.rungs or len(self.rungs) >= self.runs_max else key

    def _into_band(self, cells: int, level: int, errors: dict[str, dict]):
        """With fixed steps, once a ladder, where every target is met but some measure's error in
        h or in time has its order outside the band (and so no sign to combine by): the next
        refinement in that direction, as ``rodfem verify`` advises for an order outside the
        band; of the two, the one whose error is the larger share of its measure's target (None:
        none, done already, or no room for it)."""
        if self.adaptive or self.into_band:
            return None
        shares = [(e[d].error / wanted if (wanted := e["target"] * abs(e["value"])) else math.inf,
                   d) for e in errors.values() for d in ("space", "time")
                  if e[d].asymptotic is False]
        if not shares:
            return None
        self.into_band = True
        space = max(shares)[1] == "space"
        nxt = (2 * cells, level) if space else (cells, level + 1)
        if (2 * cells > self.cells_max) if space else not self._time_room(level + 1):
            return None
        return None if len(self.rungs) + len(self.plan(*nxt)) > self.runs_max else nxt

    def _time_room(self, level: int) -> bool:
        """Whether a time level can be run: a tolerance above 0 (its bound's floor), a fixed
        step within the scene's bound on steps."""
        step = self.step(level)
        if self.adaptive:
            return step >= 1e-14
        return self.scene["time.end"] / step <= MAX_STEPS

    # -- what is said and written --------------------------------------------------------------

    def line(self, rung: Rung) -> str:
        values = ", ".join(f"{name} = {value:.6g}" for name, value in rung.values.items())
        rejected = f" ({rung.rejected} rejected)" if self.adaptive else ""
        return (f"accuracy: run {len(self.rungs)} (at most {self.runs_max}): {rung.cells} cells, "
                f"{self.time_key} = {self.step(rung.level):g}: {rung.steps} steps{rejected}, "
                f"{values}, {rung.seconds:.2f} s")

    def rows(self) -> list[dict]:
        """accuracy.csv's rows: every run in the order made."""
        return [{"run": i + 1, "cells": r.cells, "time_step": self.step(r.level),
                 "steps": r.steps, "rejected_steps": r.rejected, "seconds": r.seconds,
                 **r.values} for i, r in enumerate(self.rungs.values())]

    def record(self, cells: int, level: int, errors: dict[str, dict]) -> dict:
        """summary.json's ``errors`` and ``accuracy``."""
        measures = {}
        for name, e in errors.items():
            entry = {"value": _finite(e["value"]), "error": _finite(e["error"]),
                     "target": e["target"], "met": e["met"]}
            for direction in ("space", "time"):
                part: Estimate | None = e[direction]
                entry[direction] = None if part is None else {
                    "error": part.error, "difference": part.difference,
                    "order": _finite(part.order), "asymptotic": part.asymptotic,
                    "checked": part.checked,
                    "bounds": [_finite(part.low), _finite(part.high)]}
            measures[name] = entry
        met = all(e["met"] for e in errors.values())
        return {"errors": {name: _finite(e["error"]) for name, e in errors.items()},
                "accuracy": {"target": self.scene["accuracy.target"] or None,
                             "cells": cells, self.time_key.split(".")[1]: self.step(level),
                             "runs": len(self.rungs), "met": met,
                             "limit": None if met else self.limit,
                             "cells_max": self.cells_max, "runs_max": self.runs_max,
                             "seconds": sum(r.seconds for r in self.rungs.values()),
                             "measures": measures}}


def not_met_line(record: dict) -> str | None:
    """The one warning line of targets not met (None: all met)."""
    accuracy = record["accuracy"]
    if accuracy["met"]:
        return None
    missed = [f"{name} ± {_shown(e['error'])} ({_percent(e)} of {_shown(e['value'])}, target "
              f"{e['target']:g}{_unchecked(e)})" for name, e in accuracy["measures"].items()
              if not e["met"]]
    why = {"cells_max": f"more than accuracy.cells_max = {accuracy['cells_max']} cells "
                        "would be needed",
           "runs_max": f"its next refinement would pass accuracy.runs_max = "
                       f"{accuracy['runs_max']} runs ({accuracy['runs']} made)",
           "time": "the time step can be refined no further"}[accuracy["limit"]]
    return (f"accuracy target not met for {'; '.join(missed)}: {why}; the run reported has "
            f"{accuracy['cells']} cells")


def _shown(value: float | None) -> str:
    return "unknown" if value is None else f"{abs(value):.3g}"


def _unchecked(e: dict) -> str:
    """What a measure within its target lacks: its error in time from a second pair."""
    within = e["error"] is not None and e["value"] is not None \
        and e["error"] <= e["target"] * abs(e["value"])
    return "; within it, but its error in time rests on one pair of runs" if within else ""


def _percent(e: dict) -> str:
    if e["error"] is None or not e["value"]:
        return "an unknown share"
    return f"{100.0 * e['error'] / abs(e['value']):.3g} %"


def _shortfall(e: dict) -> tuple[bool, float]:
    """How far a measure is from its target: those not within it first, then those within it
    but unchecked in time."""
    wanted = e["target"] * abs(e["value"])
    return (not e["within"], math.inf if wanted == 0.0 else e["error"] / wanted) \
        if not e["met"] else (False, -math.inf)


def _finite(value: float | None) -> float | None:
    """``value``, None where it is not a finite number (strict JSON writes null there)."""
    return value if value is None or math.isfinite(value) else None


def _max():
    from mpi4py import MPI

    return MPI.MAX

