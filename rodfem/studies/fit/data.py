"""What a fit is fitted to: the measured data (a CSV of ``t`` and history columns) and the fit
file's own keys, read and checked against the scene before anything runs (``rodfem fit``).

A fit file is a study file (:mod:`rodfem.studies.sweep.parameters`) with these keys of its own::

    data = "measured.csv"             # t and history columns (relative to the fit file)
    columns = ["u_1"]                 # which columns to fit (default: every column but t)
    weights = { u_1 = 1.0 }           # a positive weight per column (default 1)
    start = { "model.zeta" = 0.5 }    # where the fit starts (default: each range's middle)
    max_evaluations = 100             # of the residuals, at most
    tolerance = 1e-8                  # of the optimiser's stopping tests

The data are any times in ``[0, time.end]``, strictly increasing, every value a finite number
or an empty cell (not measured then); their columns are separated by commas, semicolons or tabs.
The model's history is interpolated linearly at the times. A residual is ``w (model - data)``
of each value measured, column after column: an empty cell has none.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from pathlib import Path

import numpy as np

from rodfem.scene import SceneError
from rodfem.scene.files import read_text
from rodfem.scene.loading import _suggest
from rodfem.studies.sweep.parameters import Study

OWN = ("data", "columns", "weights", "start", "max_evaluations", "tolerance")
MAX_EVALUATIONS, TOLERANCE = 100, 1e-8
WEIGHTS = (1e-100, 1e100)  # w² |model - data|² of every datum well within float64's range
SLACK = 1e-9  # of time.end: a data time this far after the history's last row is at it


def shown(t: float) -> str:
    """A time for a message: short, unless that would show it equal to another."""
    return f"{t:g}" if float(f"{t:g}") == t else repr(float(t))


@dataclasses.dataclass(frozen=True)
class Data:
    """Measured histories: the times ``t`` and, per fitted column, its values (NaN where it
    was not measured) and weight."""

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray  # times × columns
    weights: np.ndarray  # per column

    @property
    def present(self) -> np.ndarray:
        """Where a value was measured (times × columns)."""
        return ~np.isnan(self.values)

    @property
    def count(self) -> int:
        """How many residuals: the values measured in the fitted columns."""
        return int(self.present.sum())

    def counts(self) -> dict[str, int]:
        """The values measured, by column."""
        return {c: int(n) for c, n in zip(self.columns, self.present.sum(axis=0), strict=True)}

    def residuals(self, rows: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
        """``w (model - data)`` of a run's history ``rows`` (its columns ``names``), the model
        interpolated at the times of each value measured, column after column."""
        t, present = rows[:, names.index("t")], self.present
        return np.concatenate([
            w * (np.interp(self.t[present[:, j]], t, rows[:, names.index(c)])
                 - self.values[present[:, j], j])
            for j, (c, w) in enumerate(zip(self.columns, self.weights, strict=True))])

    def after(self, t: np.ndarray, scene) -> str | None:
        """Why a run's history (its times ``t``) of ``scene`` cannot be interpolated at the
        data's last time, or None: its last row is before it (np.interp would hold it there)."""
        if self.t[-1] <= t[-1] + SLACK * scene["time.end"]:
            return None
        every = scene["output.history_every"]
        return (f"its history ends at t = {t[-1]:g}, before the data's last time t = "
                f"{shown(self.t[-1])}" + (f" (output.history_every = {every} keeps one row in "
                                          f"{every})" if every > 1 else ""))

    def model(self, residuals: np.ndarray) -> np.ndarray:
        """The model where a value was measured (times × columns, NaN elsewhere) from its
        residuals."""
        r, present = np.asarray(residuals), self.present
        model, first = np.full_like(self.values, np.nan), 0
        for j, w in enumerate(self.weights):
            here = present[:, j]
            end = first + int(here.sum())
            model[here, j] = self.values[here, j] + r[first:end] / w
            first = end
        return model


SEPARATORS = {",": "a comma", ";": "a semicolon", "\t": "a tab"}
ALLOWED = "a comma, a semicolon or a tab"


def separator(text: str, where: str) -> str:
    """The separator of the data ``text``, decided on its header (its first line with a name):
    the one of comma, semicolon and tab that splits it into cells, quotes respected. A header
    of ``t`` alone has none (it is taken as comma-separated).

    Raises:
        SceneError: none of them splits it, or more than one does (one line).
    """
    line = next((line for line in text.splitlines() if line.strip(' ,;\t"')), "")
    splits = [s for s in SEPARATORS if len(next(csv.reader([line], delimiter=s), [])) > 1]
    if len(splits) == 1:
        return splits[0]
    if not splits and line.strip(' "') in ("", "t"):
        return ","
    if not splits:
        raise SceneError(f"{where}: its header {line.strip()!r} has no comma, semicolon or tab "
                         "between its names; separate the columns by one of those")
    names = [SEPARATORS[s] for s in splits]
    raise SceneError(f"{where}: the separator of its columns cannot be decided: its header "
                     f"{line.strip()!r} holds {', '.join(names[:-1])} and {names[-1]}; "
                     f"separate the columns by one of {ALLOWED}, and no other")


def _cell(cell: str, sep: str) -> float:
    """The number of a cell: NaN where it is empty (not measured); a decimal comma read as a
    decimal point where the columns are separated by semicolons or tabs (ValueError else)."""
    cell = cell.strip()
    if not cell:
        return math.nan
    try:
        return float(cell)
    except ValueError:
        if sep == "," or cell.count(",") != 1 or "." in cell:
            raise
        return float(cell.replace(",", "."))


def read_csv(path: Path, name: str) -> tuple[list[str], np.ndarray]:
    """The header and rows of the data file ``path`` (``name`` in messages): UTF-8 (a BOM
    allowed), its columns separated by commas, semicolons or tabs (:func:`separator`), a
    header with ``t``, every row a time and every other cell a finite number or empty (NaN in
    the rows: not measured then), the times strictly increasing.

    Raises:
        SceneError: one line naming the file and what is wrong.
    """
    text = read_text(path, f"{name}: data '{path}'", "CSV")
    if text is None:
        raise SceneError(f"{name}: data '{path}': no such file")
    where = path.name
    sep = separator(text, where)
    rows = [row for row in csv.reader(io.StringIO(text), delimiter=sep)
            if any(cell.strip() for cell in row)]
    if not rows:
        raise SceneError(f"{where}: empty; it needs a header with t and history columns, e.g. "
                         "t,u_1")
    header = [cell.strip() for cell in rows[0]]
    if "t" not in header:
        raise SceneError(f"{where}: the header has no column t (it has {', '.join(header)})")
    for i, cell in enumerate(header):
        if not cell or cell in header[:i]:
            raise SceneError(f"{where}: column {i + 1} of the header is "
                             f"{'empty' if not cell else f'{cell} again'}")
    if len(rows) < 2:
        raise SceneError(f"{where}: no rows of data after its header")
    values = np.empty((len(rows) - 1, len(header)))
    time = header.index("t")
    for n, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise SceneError(f"{where}: row {n + 2} has {len(row)} cells; the header has "
                             f"{len(header)}")
        for j, cell in enumerate(row):
            try:
                values[n, j] = _cell(cell, sep)
            except ValueError:
                raise SceneError(f"{where}: row {n + 2}, column {header[j]}: {cell.strip()!r} "
                                 "is not a number") from None
            if math.isnan(values[n, j]) and not cell.strip():
                if j == time:
                    raise SceneError(f"{where}: row {n + 2} has no time t; every row needs one "
                                     "(an empty cell elsewhere is a value not measured)")
            elif not math.isfinite(values[n, j]):
                raise SceneError(f"{where}: row {n + 2}, column {header[j]}: {cell.strip()} is "
                                 "not a finite number")
    t = values[:, time]
    if len(t) > 1 and not np.all(np.diff(t) > 0):
        n = int(np.argmin(np.diff(t) > 0))
        raise SceneError(f"{where}: the times must increase strictly; row {n + 3} has t = "
                         f"{shown(t[n + 1])} after t = {shown(t[n])}")
    return header, values


def measured(header: list[str], values: np.ndarray,
             columns: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The times and values (times × ``columns``, NaN where not measured) of the rows of a
    data file (its ``header`` and ``values``) with a value in at least one of ``columns``;
    the others play no part in a fit of them."""
    chosen = values[:, [header.index(c) for c in columns]]
    kept = ~np.all(np.isnan(chosen), axis=1)
    return values[kept, header.index("t")], chosen[kept]


def allowed(scene) -> tuple[str, ...]:
    """The history columns of ``scene`` that can be fitted (real-valued, not t or Δt)."""
    from rodfem.output.columns import for_scene

    return tuple(c.name for c in for_scene(scene) if c.name not in ("t", "dt") and not c.integer)


def _number(value, what: str, low: float, high: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not value > low or (high is not None and not value < high):
        bound = f"> {low:g}" if high is None else f"between {low:g} and {high:g}"
        raise SceneError(f"{what}: must be a number {bound}, got {value!r}")
    return float(value)


def load_data(study: Study, path: Path, scene) -> Data:
    """The data of a fit: its CSV at ``path`` checked against the base scene ``scene`` (its
    recorded columns and its time span) and the fit file's ``columns`` and ``weights``.

    Raises:
        SceneError: one line naming what is wrong and what is allowed.
    """
    name, extra = study.name, study.extra
    header, values = read_csv(path, name)
    where = path.name
    possible = allowed(scene)
    if header == ["t"]:
        raise SceneError(f"{where}: no column beside t; it needs the measured histories' "
                         f"columns too, e.g. t,u_1 (those that can be fitted: "
                         f"{', '.join(possible)})")
    columns = extra.get("columns", [c for c in header if c != "t"])
    if not isinstance(columns, list) or not columns \
            or not all(isinstance(c, str) for c in columns):
        raise SceneError(f'{name}: columns must list the data\'s columns to fit, e.g. '
                         f'columns = ["u_1"]')
    for column in columns:
        if column not in possible:
            raise SceneError(f"{where}: column {column} is not a history column the scene "
                             f"records; those that can be fitted: {', '.join(possible)} (a "
                             "scene records more with output.history)")
        if column not in header:
            raise SceneError(f"{name}: columns: {column} is not a column of {where} "
                             f"({', '.join(header)})")
    if len(set(columns)) != len(columns):
        raise SceneError(f"{name}: columns: a column is named twice")
    weights = extra.get("weights", {})
    if not isinstance(weights, dict):
        raise SceneError(f"{name}: weights must be a table of column = weight, e.g. "
                         "weights = { u_1 = 1.0 }")
    for column, weight in weights.items():
        if column not in columns:
            raise SceneError(f"{name}: weights {column}: not a fitted column: "
                             f"{_suggest(column, columns)}")
        if not WEIGHTS[0] <= _number(weight, f"{name}: weights {column}", 0.0) <= WEIGHTS[1]:
            raise SceneError(f"{name}: weights {column}: must be from {WEIGHTS[0]:g} to "
                             f"{WEIGHTS[1]:g} (the squares of the residuals must stay within "
                             f"float64's range), got {weight!r}")
    for column in columns:
        if np.all(np.isnan(values[:, header.index(column)])):
            others = ", ".join(f'"{c}"' for c in columns if c != column)
            raise SceneError(f"{where}: column {column} has no values (every cell of it is "
                             "empty); fill it" + (f", or fit the others alone: columns = "
                                                  f"[{others}]" if others else ""))
    t = values[:, header.index("t")]
    end = scene["time.end"]
    if t[0] < 0:
        raise SceneError(f"{where}: t = {shown(t[0])} lies before the scene's start t = 0")
    if t[-1] > end:
        raise SceneError(f"{where}: t = {shown(t[-1])} lies after the scene's end time.end = "
                         f"{end:g}")
    every, steps = scene["output.history_every"], scene.steps  # end = steps dt, validated
    last = steps // every * every * scene["time.dt"]
    if not scene.adaptive and t[-1] > last + SLACK * end:
        raise SceneError(f"{where}: t = {shown(t[-1])} lies after the last row of the scene's "
                         f"history, at t = {last:g} (output.history_every = {every} keeps one "
                         f"row in {every} of its {steps} steps)")
    times, chosen = measured(header, values, tuple(columns))
    return Data(times, tuple(columns), chosen,
                np.array([float(weights.get(c, 1.0)) for c in columns]))


def options(study: Study) -> tuple[dict[str, float], int, float]:
    """The fit file's ``start`` (by key, each within its range), ``max_evaluations`` and
    ``tolerance``, checked (SceneError, one line)."""
    name, extra = study.name, study.extra
    if "time.end" in study.keys:
        raise SceneError(f"{name}: parameters time.end: the end time cannot be fitted (the data "
                         "must lie within it); set it in [set]")
    start = extra.get("start", {})
    if not isinstance(start, dict):
        raise SceneError(f'{name}: start must be a table of key = value, e.g. '
                         f'start = {{ "{study.keys[0]}" = {study.parameters[0].middle:g} }}')
    ranges = {p.key: p for p in study.parameters}
    for key, value in start.items():
        if key not in ranges:
            raise SceneError(f"{name}: start {key}: not a parameter: "
                             f"{_suggest(key, tuple(ranges))}")
        p = ranges[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not p.low <= value <= p.high:
            raise SceneError(f"{name}: start {key} = {value!r} lies outside its range "
                             f"[{p.low:g}, {p.high:g}]")
    count = extra.get("max_evaluations", MAX_EVALUATIONS)
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 100_000:
        raise SceneError(f"{name}: max_evaluations must be an integer from 1 to 100000, got "
                         f"{count!r}")
    # the optimiser refuses tolerances below float64's epsilon
    tolerance = _number(extra.get("tolerance", TOLERANCE), f"{name}: tolerance",
                        float(np.finfo(float).eps), 1.0)
    return ({p.key: float(start.get(p.key, p.middle)) for p in study.parameters}, count,
            tolerance)
