"""What a sweep's figures draw and how: which measures (``--measures``, or the informative ones),
which axes are logarithmic, and what the sweep file declares of its measures.

A measure is a column of ``results.csv`` between ``status`` and ``error``: the built-in measures
of :mod:`rodfem.output.measures`, then those the sweep or its base scene declares under
``[measures]``. By default a figure is drawn for each measure that tells the scenes apart: not
for the measures of how a run was computed (the time loop's wall time, the most iterations in a
step), nor for a measure with one value in every scene (every scene reached T: ``t_final``).

An axis is logarithmic where the design is (a grid or zip axis given as ``{logspace = [...]}``, a
sample range ``{log = [...]}``), or where its values are positive and span two decades or more;
never where a value is zero or negative.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodfem.output.names import COMPUTING
from rodfem.output.results import measure_names
from rodfem.post.runs import PlotError

DECADES = 2  # positive values spanning this many decades or more are drawn on a log scale


def measure_columns(columns: dict[str, np.ndarray]) -> list[str]:
    """The measures of a results.csv's columns (read in the header's order): the built-in ones
    and those the sweep declares (:func:`rodfem.output.results.measure_names`)."""
    return list(measure_names(tuple(columns)))


def log_design(meta: dict[str, Any]) -> frozenset[str]:
    """The swept keys that sweep.json's sweep lays out logarithmically: a grid or zip axis
    ``{logspace = [...]}``, a sample range ``{log = [...]}``."""
    sweep = meta.get("sweep") if isinstance(meta.get("sweep"), dict) else {}
    tables = [sweep.get("grid"), sweep.get("zip"), (sweep.get("sample") or {}).get("ranges")]
    return frozenset(key for table in tables if isinstance(table, dict)
                     for key, spec in table.items()
                     if isinstance(spec, dict) and ("logspace" in spec or "log" in spec))


def declared(meta: dict[str, Any]) -> dict[str, dict]:
    """The measures declared in sweep.json's base scene and sweep (``[measures]``), by name."""
    found = {}
    for part in (meta.get("base"), meta.get("sweep")):
        table = part.get("measures") if isinstance(part, dict) else None
        if isinstance(table, dict):
            found.update({k: v for k, v in table.items() if isinstance(v, dict)})
    return found


def logarithmic(values: np.ndarray, by_design: bool = False) -> bool:
    """Whether an axis of these values is drawn on a log scale: never with a value ≤ 0 (or none
    finite); by design, or where they span ``DECADES`` decades or more."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    if finite.size == 0 or finite.min() <= 0:
        return False
    return by_design or finite.max() / finite.min() >= 10.0 ** DECADES


def constant(values: np.ndarray) -> bool:
    """Whether a measure has one value (or none) over the scenes: nan rows aside."""
    finite = np.asarray(values, dtype=float)
    return len(np.unique(finite[np.isfinite(finite)])) <= 1


def choose(columns: dict[str, np.ndarray], asked: list[str] | None,
           option: str = "--measures") -> tuple[list[str], str | None]:
    """The measures to draw, in the table's order, and a line naming those left out (None if
    none is). ``asked``: the user's names (checked against the table's), or None for the
    informative ones.

    Raises:
        PlotError: an unknown or empty name; no informative measure where none was asked for.
    """
    names = measure_columns(columns)
    if asked is not None:
        unknown = [name for name in asked if name not in names] or ([""] if not asked else [])
        if unknown:
            raise PlotError(f"{option}: unknown measure {unknown[0]!r}; the measures are "
                            f"{', '.join(names)}")
        return [name for name in names if name in asked], None
    computing = [name for name in names if name in COMPUTING]
    # the figures draw the complete scenes: a failed run's shorter t_final tells none apart
    complete = np.asarray(columns["status"]) == "complete"
    same = [name for name in names
            if name not in COMPUTING and constant(np.asarray(columns[name])[complete])]
    drawn = [name for name in names if name not in computing and name not in same]
    if not drawn:
        raise PlotError(f"no measure differs between the sweep's scenes; {option} NAME,... "
                        f"draws any of {', '.join(names)}")
    why = [f"{', '.join(computing)} (how the runs were computed)" if computing else "",
           f"{', '.join(same)} (the same in every scene)" if same else ""]
    skipped = "; ".join(w for w in why if w)
    return drawn, (f"not drawn: {skipped}; {option} draws them" if skipped else None)
