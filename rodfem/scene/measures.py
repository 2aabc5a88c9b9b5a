"""Declared measures: the ``[measures]`` table of a scene or sweep file, checked.

A scene declares the numbers it wants of every run::

    [measures]
    peak_force = { column = "contact_force", reduce = "max" }
    contact_time = { column = "contact_force", reduce = "time_positive" }
    late_energy = { column = "energy", reduce = "mean", window = [1.0, 2.0] }

Each is a reduction of one history column over the run (or a window of it); the output layer
computes them (:mod:`rodfem.output.reductions`). The scene layer sits below the output layer, so
the column names a measure may name are kept here (as :data:`rodfem.scene.schema.QUANTITIES`
is); a test checks that they agree with :mod:`rodfem.output.columns`. Every mistake is a
:class:`SceneError` of one line naming the measure and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

from rodfem.scene.expressions import shorten
from rodfem.scene.schema import QUANTITIES, SceneError

# The columns every history has, those of adaptive steps, and the probes' fields
# (rodfem.output.columns: COLUMNS, ADAPTIVE, PROBES).
DEFAULT_COLUMNS = ("t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations")
ADAPTIVE_COLUMNS = ("dt", "event")
PROBE_FIELDS = ("u", "theta", "sigma")
COLUMN_NAMES = (*DEFAULT_COLUMNS, *ADAPTIVE_COLUMNS, *QUANTITIES,
                *(f"{field}@x" for field in PROBE_FIELDS))
REDUCTIONS = ("max", "min", "max_abs", "mean", "integral", "final", "time_of_max_abs",
              "time_positive")
# An entry's keys and what each holds: (kind, required, meaning); the reference page shows them.
ENTRIES = {
    "column": ("choice", True, "the history column reduced; a column the scene does not "
               "record otherwise is recorded for it"),
    "reduce": ("choice", True, "what is made of the column over the window"),
    "window": ("list of reals", False, "the interval of time [t0, t1] reduced over; without "
               "one, the whole run"),
    "target": ("real", False, "the relative error wanted of this measure, 0 < target <= 0.5, "
               "in place of accuracy.target (docs/accuracy.md)"),
}
ENTRY_KEYS = tuple(ENTRIES)
# The built-in measures' names (rodfem.output.measures.NAMES) and results.csv's own columns.
BUILTIN_NAMES = ("t_final", "u_1_final", "sigma_1_final", "max_penetration", "contact_fraction",
                 "contact_intervals", "last_contact_change", "energy_final", "iterations_max",
                 "loop_seconds")
# The other columns of a sweep's results.csv (rodfem.output.results: RUN, ACCURACY_MET) and of a
# run's accuracy.csv (rodfem.studies.accuracy.ladder.COLUMNS), which a measure's would overwrite.
TABLE_COLUMNS = ("index", "status", "error", "steps", "rejected_steps", "coarse", "accuracy_met",
                 "run", "cells", "time_step", "seconds")
RESERVED = (*BUILTIN_NAMES, *TABLE_COLUMNS)
NAME = re.compile(r"[a-z_][a-z0-9_]*")
MAX_TARGET = 0.5  # the largest relative error a target may ask (accuracy.target's bound)
# Reductions set by the steps: time_of_max_abs is the time of a row, in any run; the others are
# values of the columns' piecewise-linear interpolant (its extremes at rows, its integral, its
# time above zero with the crossing interpolated), which follow the solution. The columns t, dt,
# iterations, contact and event are the steps' own: every reduction of them is set by the
# steps. Such a measure has no order of convergence and no error to hold to a target.
STEPPED_REDUCTIONS = ("time_of_max_abs",)
SMOOTH_REDUCTIONS = ("max", "min", "max_abs", "mean", "integral", "final", "time_positive")
STEPPED_COLUMNS = ("t", "dt", "iterations", "contact", "event")


@dataclasses.dataclass(frozen=True)
class Declared:
    """One declared measure: ``reduce`` of the history column ``column`` over ``window``
    (t0, t1), or over the whole run (None)."""

    name: str
    column: str
    reduce: str
    window: tuple[float, float] | None = None
    target: float | None = None  # the relative error wanted (None: accuracy.target's)

    @property
    def stepped(self) -> bool:
        """Whether the measure is set by the steps (:data:`STEPPED_REDUCTIONS`,
        :data:`STEPPED_COLUMNS`): its values move by whole steps as a run is refined."""
        return self.reduce in STEPPED_REDUCTIONS or self.column in STEPPED_COLUMNS

    def data(self) -> dict[str, Any]:
        """As TOML data: what :func:`parse` reads back."""
        entry: dict[str, Any] = {"column": self.column, "reduce": self.reduce}
        if self.window is not None:
            entry["window"] = list(self.window)
        if self.target is not None:
            entry["target"] = self.target
        return entry


def point(x: float) -> str:
    """x as a column name writes it: the shortest text that reads back as x, without ".0"."""
    text = repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _column(what: str, column: Any, adaptive: bool) -> str:
    """A measure's column, probes written as the history writes them (``u@0.50`` is
    ``u@0.5``)."""
    allowed = ", ".join(COLUMN_NAMES) + " (0 <= x <= 1)"
    if not isinstance(column, str):
        raise SceneError(f"{what}: column must be a string; allowed: {allowed}")
    field, at, x = column.partition("@")
    if at and field in PROBE_FIELDS:
        try:
            value = float(x)
        except ValueError:
            value = math.nan
        if not 0.0 <= value <= 1.0:
            raise SceneError(f"{what}: column {_quoted(column)}: the point x of {field}@x must "
                             "be a number with 0 <= x <= 1")
        return f"{field}@{point(value + 0.0)}"
    if column not in COLUMN_NAMES or "@" in column:
        raise SceneError(f"{what}: unknown column {_quoted(column)}; allowed: {allowed}")
    if column in ADAPTIVE_COLUMNS and not adaptive:
        raise SceneError(f"{what}: column {_quoted(column)} is recorded only with "
                         "time.adaptive = true")
    return column


def _window(what: str, window: Any, end: float) -> tuple[float, float]:
    numbers = (isinstance(window, (list, tuple)) and len(window) == 2
               and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in window))
    if not numbers or not all(math.isfinite(v) for v in window):
        raise SceneError(f"{what}: window must be [t0, t1], two numbers with 0 <= t0 < t1")
    t0, t1 = float(window[0]) + 0.0, float(window[1]) + 0.0
    if not 0.0 <= t0 < t1:
        raise SceneError(f"{what}: window [{window[0]!r}, {window[1]!r}] must have "
                         "0 <= t0 < t1")
    if t0 >= end:
        raise SceneError(f"{what}: window starts at {t0!r}, at or after time.end = {end!r}")
    return t0, t1


def entry(name: Any, spec: Any, adaptive: bool, end: float) -> Declared:
    """One measure of a ``[measures]`` table, checked (``adaptive``, ``end``: the scene's
    time.adaptive and time.end)."""
    what = f"measures.{shorten(str(name))}"
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise SceneError(f"{what}: a measure's name must be lower-case letters, digits and _, "
                         "not starting with a digit")
    if name in RESERVED:
        raise SceneError(f"{what}: {_quoted(name)} is a built-in measure or a column of "
                         f"results.csv; choose another name (taken: {', '.join(RESERVED)})")
    if not isinstance(spec, dict):
        raise SceneError(f'{what}: must be a table, e.g. {{ column = "contact_force", '
                         'reduce = "max" }')
    for key in spec:
        if key not in ENTRY_KEYS:
            raise SceneError(f"{what}: unknown key {_quoted(key)}; "
                             f"allowed: {', '.join(ENTRY_KEYS)}")
    for key in ("column", "reduce"):
        if key not in spec:
            raise SceneError(f"{what}: needs a {key}")
    reduce = spec["reduce"]
    if reduce not in REDUCTIONS:
        shown = _quoted(reduce) if isinstance(reduce, str) else "of another kind"
        raise SceneError(f"{what}: unknown reduce {shown}; allowed: {', '.join(REDUCTIONS)}")
    window = _window(what, spec["window"], end) if "window" in spec else None
    target = _target(what, spec["target"]) if "target" in spec else None
    return Declared(name, _column(what, spec["column"], adaptive), reduce, window, target)


def _quoted(value: Any) -> str:
    """What a user gave, as these messages quote it: its repr, cut short."""
    return shorten(repr(value))


def _target(what: str, target: Any) -> float:
    number = isinstance(target, (int, float)) and not isinstance(target, bool)
    if not number or not 0.0 < target <= MAX_TARGET:
        raise SceneError(f"{what}: target must be a number with 0 < target <= {MAX_TARGET:g} "
                         f"(a relative error), got {_quoted(target)}")
    return float(target)


def parse(table: Any, adaptive: bool, end: float) -> tuple[Declared, ...]:
    """A scene's ``[measures]`` table, in the file's order.

    Raises:
        SceneError: for the first mistake.
    """
    if not isinstance(table, dict):
        raise SceneError('measures: must be a section [measures] of name = { column = "...", '
                         'reduce = "..." }')
    return tuple(entry(name, spec, adaptive, end) for name, spec in table.items())


def merged(own: Any, added: Any, what: str) -> dict:
    """A scene's ``[measures]`` with a sweep's added (``what`` names the sweep file): a name
    declared in both is refused, so that a sweep never changes silently what a scene measures.

    Raises:
        SceneError: for a table that is not one, or a name declared twice.
    """
    tables = []
    for table in (own, added):
        if table is None:
            table = {}
        if not isinstance(table, dict):
            raise SceneError(f"{what}: measures: must be a section [measures]")
        tables.append(table)
    for name in tables[1]:
        if name in tables[0]:
            raise SceneError(f"{what}: measures.{name} is declared by the base scene too; "
                             "give it another name or remove one")
    return {**tables[0], **tables[1]}


def toml_lines(measures: tuple[Declared, ...]) -> list[str]:
    """The ``[measures]`` table as TOML lines (none without measures)."""
    if not measures:
        return []
    lines = ["[measures]"]
    for m in measures:
        window = f", window = [{m.window[0]!r}, {m.window[1]!r}]" if m.window else ""
        target = f", target = {m.target!r}" if m.target is not None else ""
        lines.append(f'{m.name} = {{ column = "{m.column}", reduce = "{m.reduce}"{window}'
                     f'{target} }}')
    return [*lines, ""]
