"""The measures of a run: one number each, made from its history (the columns of
:mod:`rodfem.output.columns`), its scene and its summary. A sweep's ``results.csv`` has a column
per measure (:mod:`rodfem.studies.sweep.run`), and :attr:`rodfem.Result.measures` gives them for any
run. Importing this module needs NumPy only.

The rod is *in contact* at tⁿ when the obstacle pushes on it: σ(1, tⁿ) < 0 (the elastic laws:
u(1, tⁿ) > g; the rigid obstacle: a positive multiplier). Counts and fractions are over the steps
n = 1 … N that the run took (the initial state, n = 0, is data, not a step). Times are the
history's ``t`` column, never n·Δt: they hold for steps of any length.

A step (tⁿ⁻¹, tⁿ] is in contact when the rod is at its end tⁿ. An adaptive run's history marks
the rows where a step ends at a contact event (its ``event`` column: contact begins or ends
there); σ(1) is zero there to round-off and tells nothing, so a step ending at an event is in the
state of its start (or, when an event ends the step before too, in the opposite state of that
step), and the state changes at the event's time. Its fraction in contact weighs each step by its
length Δtⁿ = tⁿ − tⁿ⁻¹. Fixed-step runs have no events and steps of one length: their measures
count steps, as they always did, bit for bit.

A run keeps the measures of contact over every step as it goes (:class:`Contact`, in its summary
as ``contact``), so that they are the same whatever rows its history keeps
(``output.history_every``); without that record (a run killed before it wrote its summary) they
are computed from the history's rows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from rodfem.output.reductions import reduce
from rodfem.scene.measures import Declared


@dataclasses.dataclass(frozen=True)
class Measure:
    """One measure: its name, meaning, and how it is computed from the history's columns (a dict
    of name → array over n = 0 … N), the scene and the run's summary."""

    name: str
    meaning: str
    compute: Callable[[dict[str, np.ndarray], object, dict], float]
    integer: bool = False


def adaptive(history: dict[str, np.ndarray]) -> bool:
    """Whether the history is an adaptive run's (it has the ``event`` column)."""
    return "event" in history


def step_states(touching: np.ndarray, event: np.ndarray | None, before_touching: bool = False,
                before_event: bool = False, before_state: bool = False) -> np.ndarray:
    """Whether the steps ending at a block of rows are in contact (the module's docstring):
    ``touching``, whether the rod is in contact at each row; ``event``, whether the row is a
    contact event (None: no events); ``before_*``: the same of the row before the block, and
    the state of the step that ends there."""
    states = touching.copy()
    if event is None:
        return states
    for i in np.flatnonzero(event != 0):
        previous_event = event[i - 1] != 0 if i else before_event
        previous_state = states[i - 1] if i else before_state
        previous_touching = touching[i - 1] if i else before_touching
        states[i] = (not previous_state) if previous_event else previous_touching
    return states


def in_contact(history: dict[str, np.ndarray]) -> np.ndarray:
    """Whether the rod is in contact over each step n = 1 … N (the module's docstring)."""
    touching = history["sigma_1"] < 0.0
    return step_states(touching, history.get("event"))[1:]


def _change_times(t: np.ndarray, events: np.ndarray, states: np.ndarray,
                  was: bool) -> np.ndarray:
    """When the state of a block's steps changes: tⁿ of the first step in its new state, or the
    time tⁿ⁻¹ of an event that ends the step before. ``t``, ``events``: the block's rows with
    the row before them first; ``states``: its steps' states; ``was``: the state before."""
    changed = np.flatnonzero(np.diff(states.astype(np.int8), prepend=np.int8(was)) != 0)
    return np.where(events[:-1][changed], t[:-1][changed], t[1:][changed])


# The built-in measures that are a reduction of a column (rodfem.output.reductions): of the
# history's rows, as they always were (its last row, whatever rows it keeps).
BUILT_IN = (Declared("t_final", "t", "final"), Declared("u_1_final", "u_1", "final"),
            Declared("sigma_1_final", "sigma_1", "final"),
            Declared("energy_final", "energy", "final"))


def _reduced(name: str):
    declared = next(m for m in BUILT_IN if m.name == name)
    return lambda history, scene, summary: reduce((declared,), history)[name]


@dataclasses.dataclass
class Contact:
    """The measures of contact over every step, updated block by block as a run records its
    rows (and continued from a checkpoint): what :data:`MEASURES` computes from a history of
    every step."""

    steps: int = 0  # steps n ≥ 1 seen
    touching: int = 0  # of them in contact
    intervals: int = 0
    last_change: int | None = None  # the step n of the last change of contact state
    was: bool = False  # in contact over the last step seen (none: not)
    max_penetration: float = 0.0  # max over n ≥ 0 of [u(1, tⁿ) − g]₊
    # With the rows' times (update's t): the time of the last change, the time the steps span and
    # of it the time in contact; the last row seen: its time, contact and event.
    last_change_t: float | None = None
    time: float = 0.0
    time_touching: float = 0.0
    row_t: float | None = None
    row_touching: bool = False
    row_event: bool = False

    def update(self, steps: np.ndarray, u_1: np.ndarray, sigma_1: np.ndarray, gap: float,
               t: np.ndarray | None = None, event: np.ndarray | None = None) -> None:
        """Count a block of consecutive rows: their step numbers n, u(1) and σ(1); ``t``, their
        times (the history's t column); ``event``, an adaptive run's event column."""
        if steps.size == 0:
            return
        self.max_penetration = max(self.max_penetration,
                                   float(np.max(np.maximum(u_1 - gap, 0.0))))
        taken = steps >= 1
        rows_touching = sigma_1 < 0.0
        states = step_states(rows_touching, event, self.row_touching, self.row_event, self.was)
        touching = states[taken]
        if t is not None:
            if touching.size:
                self._times(t, event, taken, touching)
            self.row_t = float(t[-1])
        self.row_touching = bool(rows_touching[-1])
        self.row_event = bool(event is not None and event[-1] != 0)
        if touching.size == 0:
            return
        change = np.diff(touching.astype(np.int8), prepend=np.int8(self.was))
        self.steps += int(touching.size)
        self.touching += int(np.count_nonzero(touching))
        self.intervals += int(np.count_nonzero(change == 1))
        changed = np.flatnonzero(change != 0)
        if changed.size:
            self.last_change = int(steps[taken][changed[-1]])
        self.was = bool(touching[-1])

    def _times(self, t: np.ndarray, event: np.ndarray | None, taken: np.ndarray,
               touching: np.ndarray) -> None:
        """The times of a block's steps (:meth:`update`): their lengths Δtⁿ = tⁿ − tⁿ⁻¹, the
        time in contact, the time of the last change."""
        before = np.nan if self.row_t is None else self.row_t
        times = np.concatenate([[before], t])
        events = np.concatenate([[self.row_event], np.zeros(t.size, dtype=bool)
                                 if event is None else event != 0])
        at = np.concatenate([[False], taken])  # the rows of the steps, in times
        ends = np.flatnonzero(at)
        starts = ends - 1
        dt = times[ends] - times[starts]
        # summed one step after another (np.cumsum is sequential): the totals do not depend on
        # how the rows come in blocks, which a resumed run's do not share with the run's
        self.time = float(np.cumsum(np.concatenate([[self.time], dt]))[-1])
        self.time_touching = float(np.cumsum(np.concatenate([[self.time_touching],
                                                             dt[touching]]))[-1])
        changes = _change_times(times[np.concatenate([[starts[0]], ends])],
                                events[np.concatenate([[starts[0]], ends])], touching, self.was)
        if changes.size:
            self.last_change_t = float(changes[-1])


def _kept(summary: dict) -> dict | None:
    """The run's record of contact over every step (:class:`Contact`), if it has one."""
    kept = summary.get("contact")
    return kept if isinstance(kept, dict) else None


def _max_penetration(history, scene, summary) -> float:
    if (kept := _kept(summary)) is not None:
        return float(kept["max_penetration"])
    return float(np.max(np.maximum(history["u_1"] - scene["obstacle.gap"], 0.0)))


def _timed(kept: dict | None) -> bool:
    """Whether the run's record of contact was kept with the rows' times."""
    return kept is not None and (kept.get("time") or 0.0) > 0.0


def _contact_fraction(history, scene, summary) -> float:
    kept = _kept(summary)
    if not adaptive(history):
        if kept is not None:
            return kept["touching"] / kept["steps"] if kept["steps"] else 0.0
        touching = in_contact(history)
        return float(touching.mean()) if touching.size else 0.0
    if _timed(kept):
        return float(kept["time_touching"] / kept["time"])
    touching, dt = in_contact(history), np.diff(history["t"])
    span = float(np.sum(dt))
    return float(np.sum(dt[touching])) / span if span > 0.0 else 0.0


def _contact_intervals(history, scene, summary) -> int:
    if (kept := _kept(summary)) is not None:
        return int(kept["intervals"])
    touching = in_contact(history).astype(np.int8)
    return int(np.count_nonzero(np.diff(touching, prepend=0) == 1))


def _last_contact_change(history, scene, summary) -> float:
    kept = _kept(summary)
    if kept is not None and kept.get("last_change_t") is not None:
        return float(kept["last_change_t"])
    if kept is not None and (kept["last_change"] is None or not adaptive(history)):
        step = kept["last_change"]
        return float(step * scene["time.dt"]) if step is not None else float("nan")
    events = history.get("event", np.zeros(history["t"].size)) != 0
    changes = _change_times(history["t"], events, in_contact(history), False)
    return float(changes[-1]) if changes.size else float("nan")


MEASURES = (
    Measure("t_final", "the time the run reached: T if it is complete", _reduced("t_final")),
    Measure("u_1_final", "u(1, t) at the last step", _reduced("u_1_final")),
    Measure("sigma_1_final", "the contact stress σ(1, t) at the last step",
            _reduced("sigma_1_final")),
    Measure("max_penetration", "max over the steps of [u(1, tⁿ) − g]₊ (the rigid obstacle: "
            "round-off)", _max_penetration),
    Measure("contact_fraction", "the fraction of the steps in contact (an adaptive run: of the "
            "time, each step weighed by its length)", _contact_fraction),
    Measure("contact_intervals", "how many separate intervals of contact (runs of steps in "
            "contact)", _contact_intervals, integer=True),
    Measure("last_contact_change", "the time tⁿ of the last step whose contact state differs "
            "from the step before's, or of the contact event before it (nan if it never "
            "changes; a run starting in contact counts as a change at t¹)", _last_contact_change),
    Measure("energy_final", "the discrete energy Êⁿ at the last step", _reduced("energy_final")),
    Measure("iterations_max", "the most iterations any step took (a failed step's included)",
            lambda history, scene, summary: int(summary["iterations_max"]), integer=True),
    Measure("loop_seconds", "wall time of the time loop, s (a timing: it varies from run to "
            "run)", lambda history, scene, summary: float(summary["loop_seconds"])),
)
NAMES = tuple(measure.name for measure in MEASURES)
TIMINGS = ("loop_seconds",)  # the measures that are not reproducible bit for bit


def measures(history: dict[str, np.ndarray], scene, summary: dict) -> dict[str, float | int]:
    """Every measure of a run, by name: the built-in ones, then those the scene declares
    (``scene.measures``). ``history``: its columns by name (at least the row of n = 0).

    A run reduces its declared measures over every step as it goes, into its summary's
    ``measures``; where the summary has none (a run killed before it wrote it), they are
    reduced from the history's rows (the same values where it keeps every row). So are the
    built-in final values, of the last step's row, which a history of every n-th step
    (``output.history_every``) may not keep."""
    values = {m.name: m.compute(history, scene, summary) for m in MEASURES}
    declared = getattr(scene, "measures", ())  # a Scene's (a mapping of its keys has none)
    kept = summary.get("measures")
    kept = kept if isinstance(kept, dict) else {}
    values.update({m.name: float(kept[m.name]) for m in BUILT_IN
                   if isinstance(kept.get(m.name), float)})
    if any(m.name not in kept for m in declared):
        kept = {**reduce(declared, history), **kept}
    # summary.json writes NaN (a window the run never reached) as null
    return {**values, **{m.name: float("nan") if kept[m.name] is None else float(kept[m.name])
                         for m in declared}}
