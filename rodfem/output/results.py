"""A sweep's ``results.csv``: one row per scene, in the sweep's order.

Columns: ``index`` (the scene's place in the sweep, from 0), the swept keys (named by the key,
e.g. ``model.k``), ``status`` (complete | failed | interrupted), the measures of
:mod:`rodfem.output.measures` and ``error`` (why a scene failed; empty otherwise). Numbers are
written to round-trip precision (``repr``), so the table of a sweep is the same text whatever the
number of ranks and however often it was stopped and resumed — but for ``loop_seconds``, a
timing. Importing this module needs NumPy only.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.output.measures import MEASURES
from rodfem.output.measures import NAMES as MEASURE_NAMES

NAME = "results.csv"
STATUSES = ("complete", "failed", "interrupted")


class ResultsError(ValueError):
    """A results.csv that is not rodfem's, or cannot be read."""


def header(axes: tuple[str, ...]) -> list[str]:
    return ["index", *axes, "status", *MEASURE_NAMES, "error"]


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if value != value
                                                           else ("inf" if value > 0 else "-inf"))
    return str(value)


def line(index: int, point: dict[str, Any], axes: tuple[str, ...], status: str,
         measures: dict[str, Any], error: str = "") -> str:
    """One row of results.csv, without its newline."""
    cells = [index, *(point[a] for a in axes), status,
             *(measures.get(name, math.nan) for name in MEASURE_NAMES), error]
    buffer = io.StringIO()
    # the terminator is the writer's, dropped after: a cell with a newline is quoted for it
    csv.writer(buffer, lineterminator="\r\n").writerow([_text(c) for c in cells])
    return buffer.getvalue().removesuffix("\r\n")


def text(axes: tuple[str, ...], lines: list[str]) -> str:
    """The whole file: the header and the rows (in the order given)."""
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(header(axes))
    return buffer.getvalue() + "".join(f"{row}\n" for row in lines)


def _column(name: str, cells: list[str]) -> np.ndarray:
    """A column as integers, floats, or strings, whichever all its cells are."""
    if name in ("status", "error"):
        return np.array(cells, dtype=object)
    measure = next((m for m in MEASURES if m.name == name), None)
    kinds = (int, float) if measure is None or measure.integer else (float,)
    for kind in kinds:
        try:
            return np.array([kind(c) for c in cells], dtype=np.int64 if kind is int else float)
        except ValueError:
            pass
    return np.array(cells, dtype=object)


def read(path: Path) -> tuple[tuple[str, ...], dict[str, np.ndarray]]:
    """The swept keys and the columns of a results.csv, by name (numbers as arrays of int or
    float, strings as object arrays). ResultsError (one line) for a file rodfem did not write."""
    try:
        with open(path, encoding="utf-8", newline="") as file:
            return parse(file.read(), str(path))
    except (OSError, UnicodeDecodeError) as err:
        raise ResultsError(f"cannot read {path}: {getattr(err, 'strerror', None) or err}") \
            from None


def cells(line: str) -> list[str]:
    """The cells of one row (as :func:`line` made it): read as a file's text, so that a cell
    holding a newline (a string value with one) is read whole. ResultsError for a row that is
    not one."""
    try:
        rows = list(csv.reader(io.StringIO(line, newline="")))
    except csv.Error as err:
        raise ResultsError(f"a row of results is not one ({err})") from None
    if len(rows) != 1:
        raise ResultsError(f"a row of results is {len(rows)} rows")
    return rows[0]


def status(line: str, axes: tuple[str, ...]) -> str:
    """The status of one row (as :func:`line` made it)."""
    row = cells(line)
    if len(row) <= 1 + len(axes) or row[1 + len(axes)] not in STATUSES:
        raise ResultsError(f"a row of results has no status after its {len(axes)} swept values")
    return row[1 + len(axes)]


def parse(content: str, path: str = NAME) -> tuple[tuple[str, ...], dict[str, np.ndarray]]:
    """:func:`read` of a results.csv's text."""
    try:
        rows = list(csv.reader(io.StringIO(content, newline="")))
    except csv.Error as err:
        raise ResultsError(f"cannot read {path}: {err}") from None
    status_at = rows[0].index("status") if rows and "status" in rows[0] else -1
    # the built-in measures, then any declared ones, then error
    if not rows or rows[0][:1] != ["index"] or status_at < 0 or rows[0][-1:] != ["error"] \
            or rows[0][status_at + 1:status_at + 1 + len(MEASURE_NAMES)] != list(MEASURE_NAMES):
        raise ResultsError(f"{path} is not a sweep's results.csv (its header is not rodfem's)")
    names = rows[0]
    axes = tuple(names[1:names.index("status")])
    body = rows[1:]
    if any(len(r) != len(names) for r in body):
        raise ResultsError(f"{path} has rows of another length than its header")
    return axes, {name: _column(name, [r[j] for r in body]) for j, name in enumerate(names)}
