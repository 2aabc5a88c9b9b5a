"""A sweep's scenes overlaid (``rodfem plot SWEEPDIR --overlay``): the histories the sweep kept
(``rodfem sweep --histories``, ``histories.h5``) drawn as the curves of runs overlaid are
(:mod:`rodfem.post.curves`), each scene named by its swept values.

    sweep_scenes_contact.png   u(1, t) with the gap, u(0.5, t), u_t(1, t), σ(1, t)
    sweep_scenes_energy.png    ln(Ê + 0.01) against t

Over one numeric axis the scenes are coloured by its value (a sequential map and a colour bar, on
a log scale where the axis is log-spaced or its values span decades); over two, one of them
numeric and the other of a few values, coloured by the first and drawn in a line style for each
value of the second (named in the legend); otherwise each scene has its colour and a legend entry
naming its swept values in symbols (``scene 3: ζ = 0.2, ε = 0.001``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rodfem.output.names import CHOICES
from rodfem.output.results import HISTORIES, kept_histories
from rodfem.post import curves
from rodfem.post.curves import DASHES, Dashes
from rodfem.post.runs import PARAMETERS, PlotError, Run, _flatten, legend_labels

FIGURES = ("sweep_scenes_contact.png", "sweep_scenes_energy.png")  # or .pdf, .svg


@dataclass(frozen=True)
class Overlay:
    """The scenes to draw, their legend labels (none when coloured by ``colour_by``)."""

    runs: list[Run]
    labels: list[str]
    colour_by: str | None
    window: tuple[float, float] | None
    colour_log: bool = False
    dashes: Dashes | None = None


def _histories(path: Path, kept: bool) -> dict[int, tuple[np.ndarray, tuple[str, ...]]]:
    """The rows and column names of every scene's history in histories.h5, by index; ``kept``:
    whether the sweep was run to keep them (sweep.json's ``histories``)."""
    file = path / HISTORIES
    if not file.is_file():
        if kept:  # written when the sweep is complete
            raise PlotError(f"--overlay: {path} has no {HISTORIES} yet: the sweep keeps them "
                            f"when it is complete ('rodfem resume {path}' runs the rest)")
        raise PlotError(f"--overlay: {path} kept no histories (run the sweep with "
                        "--histories)")
    try:
        return kept_histories(file)
    except (OSError, KeyError, ValueError) as err:
        raise PlotError(f"--overlay: cannot read {file}: {' '.join(str(err).split())}") \
            from None


def plan(path: Path, sweep, columns: dict[str, np.ndarray],
         window: tuple[float, float] | None = None) -> Overlay:
    """Read the scenes' histories and make their runs (checked before anything is drawn)."""
    from rodfem.output.readers import History

    meta = json.loads((path / "sweep.json").read_text(encoding="utf-8"))
    histories = _histories(path, meta.get("histories") is True)
    base = _flatten(meta.get("base") or {})
    runs = []
    for row, index in enumerate(columns["index"]):
        if int(index) not in histories:
            continue
        rows, names = histories[int(index)]
        scene = {**base, **{axis: _value(columns[axis][row]) for axis in sweep.axes}}
        runs.append(Run(path, f"scene {int(index)}", History(rows, names), scene, None))
    if not runs:
        raise PlotError(f"--overlay: {path / HISTORIES} holds no scene's history")
    if window is not None and window[0] >= max(float(r.history.t[-1]) for r in runs):
        raise PlotError(f"--window starts at t = {window[0]:g}, after the scenes end")
    colour_by, dashes = _encoding(runs, sweep.axes)
    labels = [] if colour_by is not None else legend_labels(runs)
    return Overlay(runs, labels, colour_by, window, colour_by in sweep.logs, dashes)


def _encoding(runs: list[Run], axes: tuple[str, ...]) -> tuple[str | None, Dashes | None]:
    """How the scenes are told apart: over one numeric axis, by colour along its values; over
    two, one numeric, the other of at most as many values as there are line styles, by colour
    and line style; otherwise by colour and a legend entry each (None, None)."""
    values = {a: list(dict.fromkeys(run.scene[a] for run in runs)) for a in axes}
    numeric = [a for a in axes if len(values[a]) > 1
               and all(isinstance(v, float) for v in values[a])]
    if len(axes) == 1:
        return (axes[0], None) if numeric else (None, None)
    if len(axes) != 2:
        return None, None
    for colour, dashed in ((axes[0], axes[1]), (axes[1], axes[0])):
        if colour in numeric and len(values[dashed]) <= len(DASHES):
            first = {value: next(r for r in runs if r.scene[dashed] == value)
                     for value in values[dashed]}
            styles = [DASHES[values[dashed].index(run.scene[dashed])] for run in runs]
            legend = [(DASHES[i], first[v].parameter(dashed)) if dashed in PARAMETERS
                      or dashed in CHOICES else (DASHES[i], f"{dashed} = {v}")
                      for i, v in enumerate(values[dashed])]
            return colour, Dashes(styles, legend)
    return None, None


def _value(value):
    """A swept value from results.csv: numbers as floats, true and false (how the table writes
    a boolean) as booleans, other text as it is."""
    if isinstance(value, (bool, np.bool_)) or value in ("true", "false"):
        return value in (True, "true")
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    return str(value)


def draw(overlay: Overlay, files: list[Path]) -> list[Path]:
    """The overlaid curves, into ``files`` (those of :data:`FIGURES`, in a format)."""
    shared = dict(window=overlay.window, colour_by=overlay.colour_by,
                  colour_log=overlay.colour_log, dashes=overlay.dashes)
    labels = overlay.labels or [run.name for run in overlay.runs]
    return [curves.contact_figure(overlay.runs, labels, files[0], **shared),
            curves.energy_figure(overlay.runs, labels, files[1], **shared)]
