"""A run's and a sweep's data as pandas and xarray objects (``Result.to_pandas``,
``Fields.to_xarray``, ``SweepResult.to_pandas``), and the short numbers their reprs show.

pandas and xarray are imported here, when a bridge is first called: ``import rodfem`` and every
``rodfem`` command go without them (about a second of imports), and a machine without them runs
everything but the bridges. The set-up installs Debian's (``python3-pandas``,
``python3-xarray``), built for Debian's NumPy, which rodfem's FEniCSx packages need.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np

from rodfem.scene.expressions import shorten


def require(module: str, what: str) -> Any:
    """The module ``module`` (pandas, xarray), or an ImportError that says how to get it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"{what} needs {module}, which is not installed: on Debian, "
                          f"apt-get install python3-{module} (scripts/setup.sh does)") from None


def scene_attrs(scene) -> dict[str, str]:
    """What names a scene in a table's or a dataset's attributes: where it comes from, its
    description, and the whole resolved scene as TOML (which gives it again)."""
    return {"scene": scene.source, "description": scene.description,
            "scene_toml": scene.to_toml()}


def history_frame(history: np.ndarray, attrs: dict[str, str]):
    """A history (a structured array, a column per name) as a DataFrame indexed by t, a column
    per other name, each of the array's own dtype; ``attrs`` as its ``attrs``."""
    pd = require("pandas", "to_pandas()")
    names = [name for name in history.dtype.names if name != "t"]
    frame = pd.DataFrame({name: history[name] for name in names},
                         index=pd.Index(history["t"], name="t"), columns=names)
    frame.attrs.update(attrs)
    return frame


def results_frame(columns: dict[str, np.ndarray], axes: tuple[str, ...]):
    """A sweep's table as a DataFrame indexed by the scenes' ``index``: the swept keys, status,
    the measures and error as columns, in results.csv's order; ``attrs["axes"]``: the swept
    keys."""
    pd = require("pandas", "to_pandas()")
    names = [name for name in columns if name != "index"]
    frame = pd.DataFrame({name: _swept(columns[name]) if name in axes else columns[name]
                          for name in names},
                         index=pd.Index(columns["index"], name="index"), columns=names)
    frame.attrs["axes"] = list(axes)
    return frame


def _swept(values: np.ndarray) -> np.ndarray:
    """A swept key's values as the scenes have them: true and false (as results.csv writes a
    boolean key) as booleans."""
    if values.dtype == object and values.size and all(v in ("true", "false") for v in values):
        return values == "true"
    return values


def fields_dataset(fields, meanings: dict[str, str], node_names: tuple[str, ...]):
    """Saved fields as an xarray Dataset: a variable per field, on dims (t, x) at the nodes or
    (t, x_cells) on the cells, the coordinates t, x and x_cells; ``fields.attrs`` as its
    attributes."""
    xr = require("xarray", "to_xarray()")
    variables = {name: ((("t", "x") if name in node_names else ("t", "x_cells")),
                        getattr(fields, name), {"long_name": meanings[name]})
                 for name in fields.names}
    coords = {"t": ("t", fields.t, {"long_name": "time"}),
              "x": ("x", fields.x, {"long_name": "position along the rod, at the nodes"}),
              "x_cells": ("x_cells", fields.x_cells,
                          {"long_name": "position along the rod, the cells' midpoints"})}
    return xr.Dataset(variables, coords=coords, attrs=dict(fields.attrs))


def number(value) -> str:
    """A number as a repr shows it: four significant digits (a string: its start)."""
    if isinstance(value, (float, np.floating)):
        return f"{value:.4g}"
    return shorten(repr(value), 30) if isinstance(value, str) else str(value)


def span(values: np.ndarray) -> str:
    """The values of a swept key, in a few words: how many, and their range or themselves."""
    distinct = list(dict.fromkeys(values.tolist()))
    if values.dtype.kind in "if" and len(distinct) > 1:
        return f"{len(distinct)} values, {number(min(distinct))} … {number(max(distinct))}"
    shown = ", ".join(number(v) for v in distinct[:3])
    return shown + (f", … ({len(distinct)} values)" if len(distinct) > 3 else "")
