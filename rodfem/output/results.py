"""A sweep's ``results.csv``: one row per scene, in the sweep's order.

Columns: ``index`` (the scene's place in the sweep, from 0), the swept keys (named by the key,
e.g. ``model.k``), ``status`` (complete | failed | interrupted), the built-in measures of
:mod:`rodfem.output.measures`, the measures the scenes declare (:mod:`rodfem.scene.measures`:
the same for every scene of a sweep), what the sweep says of each scene's run (:data:`RUN`:
``steps``, ``rejected_steps``, ``coarse``), where the scenes hold measures to an accuracy
target each one's estimated error (``<measure>_error``) and ``accuracy_met`` (1 where every
target was met, else 0), and ``error`` (why a scene failed; empty otherwise).
:func:`measure_names` gives the measures of a header. Numbers are
written to round-trip precision (``repr``), so the table of a sweep is the same text whatever the
number of ranks and however often it was stopped and resumed — but for ``loop_seconds``, a
timing. Importing this module needs NumPy only.
"""

from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.output.measures import MEASURES
from rodfem.output.measures import NAMES as MEASURE_NAMES

NAME = "results.csv"
HISTORIES = "histories.h5"  # the scenes' histories a sweep keeps (rodfem sweep --histories)
STATUSES = ("complete", "failed", "interrupted")
# Of each scene's run, after its measures (docs/sweeps.md lists them with these meanings). A scene
# whose set-up failed took no step: 0, 0, 0. The tables of an earlier rodfem have none of them.
RUN_MEANINGS = {
    "steps": "the steps the run took",
    "rejected_steps": "the steps an adaptive run rejected and took again smaller (0 for a fixed "
                      "step)",
    "coarse": "1 where the run's fixed step was coarse for its contact (it touched the obstacle "
              "with fewer steps per contact time √(b ε) than its scheme needs, or touched the "
              "rigid obstacle: the warning of docs/time-schemes.md), else 0",
}
RUN = tuple(RUN_MEANINGS)
# Of a sweep whose scenes hold measures to an accuracy target (docs/accuracy-targets.md), after
# the run's columns: each targeted measure's estimated error, then whether every target was met.
ERROR_SUFFIX, ACCURACY_MET = "_error", "accuracy_met"


def accuracy_names(targeted: tuple[str, ...]) -> tuple[str, ...]:
    """The columns of the accuracy of ``targeted`` measures (none without them)."""
    return (*(f"{name}{ERROR_SUFFIX}" for name in targeted), ACCURACY_MET) if targeted else ()


class ResultsError(ValueError):
    """A results.csv that is not rodfem's, or cannot be read."""


DECLARED = re.compile(r"[a-z_][a-z0-9_]*")  # a declared measure's name (rodfem.scene.measures)


def header(axes: tuple[str, ...], declared: tuple[str, ...] = (),
           targeted: tuple[str, ...] = ()) -> list[str]:
    """The names of the columns: ``declared``, the names of the measures the scenes declare;
    ``targeted``, those of them held to an accuracy target."""
    return ["index", *axes, "status", *MEASURE_NAMES, *declared, *RUN,
            *accuracy_names(targeted), "error"]


def _run_start(names: list[str]) -> int | None:
    """Where a header's run columns (:data:`RUN`) begin: followed by the accuracy columns of
    some of the measures before them, then error (None: a table of an earlier rodfem)."""
    for start in range(len(names) - len(RUN) - 1, names.index("status"), -1):
        if tuple(names[start:start + len(RUN)]) == RUN:
            after = names[start + len(RUN):-1]
            targeted = tuple(n.removesuffix(ERROR_SUFFIX) for n in after[:-1])
            if tuple(after) == accuracy_names(targeted) \
                    and set(targeted) <= set(names[:start]):
                return start
    return None


def measure_names(names: list[str] | tuple[str, ...]) -> tuple[str, ...]:
    """The measures of a header (its names): every column between status and the run's columns
    (:data:`RUN`; error, in the tables of an earlier rodfem)."""
    names = list(names)
    start = _run_start(names)
    return tuple(names[names.index("status") + 1:len(names) - 1 if start is None else start])


def targeted_names(names: list[str] | tuple[str, ...]) -> tuple[str, ...]:
    """The measures of a header held to an accuracy target (those with an error column)."""
    names = list(names)
    start = _run_start(names)
    if start is None:
        return ()
    return tuple(n.removesuffix(ERROR_SUFFIX) for n in names[start + len(RUN):-2])


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if value != value
                                                           else ("inf" if value > 0 else "-inf"))
    return str(value)


def line(index: int, point: dict[str, Any], axes: tuple[str, ...], status: str,
         measures: dict[str, Any], error: str = "", declared: tuple[str, ...] = (),
         run: dict[str, int] | None = None, targeted: tuple[str, ...] = (),
         accuracy: dict[str, Any] | None = None) -> str:
    """One row of results.csv, without its newline (``declared``, ``targeted``: as for
    :func:`header`; ``run``: the run's columns by name, :data:`RUN`, 0 where not given;
    ``accuracy``: the accuracy columns by name, nan and 0 where not given)."""
    run, accuracy = run or {}, accuracy or {}
    cells = [index, *(point[a] for a in axes), status,
             *(measures.get(name, math.nan) for name in (*MEASURE_NAMES, *declared)),
             *(int(run.get(name, 0)) for name in RUN),
             *(accuracy.get(name, 0 if name == ACCURACY_MET else math.nan)
               for name in accuracy_names(targeted)), error]
    buffer = io.StringIO()
    # the terminator is the writer's, dropped after: a cell with a newline is quoted for it
    csv.writer(buffer, lineterminator="\r\n").writerow([_text(c) for c in cells])
    return buffer.getvalue().removesuffix("\r\n")


def text(axes: tuple[str, ...], lines: list[str], declared: tuple[str, ...] = (),
         targeted: tuple[str, ...] = ()) -> str:
    """The whole file: the header and the rows (in the order given)."""
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(header(axes, declared, targeted))
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


def _measures_of(names: list[str]) -> bool:
    """Whether the names after status are the built-in measures, then declared ones (none in
    the tables of an earlier rodfem), then the run's columns (none in those tables), then
    error."""
    after = list(measure_names(names))
    built_in, declared = after[:len(MEASURE_NAMES)], after[len(MEASURE_NAMES):]
    return (tuple(built_in) == MEASURE_NAMES and len(set(declared)) == len(declared)
            and all(DECLARED.fullmatch(name) and name not in MEASURE_NAMES for name in declared))


def parse(content: str, path: str = NAME) -> tuple[tuple[str, ...], dict[str, np.ndarray]]:
    """:func:`read` of a results.csv's text."""
    try:
        rows = list(csv.reader(io.StringIO(content, newline="")))
    except csv.Error as err:
        raise ResultsError(f"cannot read {path}: {err}") from None
    names = rows[0] if rows else []
    if names[:1] != ["index"] or "status" not in names or names[-1:] != ["error"] \
            or not _measures_of(names):
        raise ResultsError(f"{path} is not a sweep's results.csv (its header is not rodfem's)")
    axes = tuple(names[1:names.index("status")])
    body = rows[1:]
    if any(len(r) != len(names) for r in body):
        raise ResultsError(f"{path} has rows of another length than its header")
    return axes, {name: _column(name, [r[j] for r in body]) for j, name in enumerate(names)}


def kept_histories(path: Path, indices=None) -> dict[int, tuple[np.ndarray, tuple[str, ...]]]:
    """The rows and column names of the scenes' histories in a sweep's histories.h5 (``path``),
    by index: of ``indices`` (those kept), or of every scene kept. A scene's columns are its
    own (the default ones, then what its [output] adds), or the file's where it has none.
    OSError, KeyError or ValueError for a file that is not one."""
    import h5py  # here: imported before dolfinx, Debian's serial h5py aborts an MPI run

    with h5py.File(path, "r") as file:
        scenes = file["scenes"]
        wanted = list(scenes) if indices is None else [str(i) for i in indices]
        return {int(name): (scenes[name][...], tuple(str(scenes[name].attrs.get(
            "columns", file.attrs["columns"])).split(","))) for name in wanted if name in scenes}
