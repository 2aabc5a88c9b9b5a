"""Space-time maps of the saved fields: u, θ and σ (and u_t, −θ_x) coloured over (t, x).

Time runs to the right and the rod's coordinate x upwards, so that the top edge of each map is
the end x = 1 that meets the obstacle. θ, u and u_t are P1 (linear between nodes: shaded between
the node values); σ and −θ_x are constant per cell (cells that span the nodes in x and reach
halfway to the neighbouring saved times in t).

A map shows the fields at the saved times only (``output.every``), and a short event between two
saves, such as the impact on a stiff obstacle, falls between them. The colour range is therefore
that of the saved fields and of the run's history (``history.h5``, every step) together: the map's
colour bar always reaches the extreme the history recorded at the end x = 1 (and at the probes),
and where the saved frames miss it, or are sparser than an interval of contact, the figure says
so in a note below the map. Drawn with matplotlib, as the curves (:mod:`rodfem.post.curves`).
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from rodfem.output.names import TIME_LABEL, with_unit
from rodfem.output import figures as formats
from rodfem.post import style
from rodfem.post.fields import CELL_FUNCTIONS, Fields

# name: title, symbol (Unicode), colour map, centred on zero, symbol (mathtext), unit, the
# history's columns of the same quantity (at x = 1 or elsewhere; probes "name@x" are added).
# Diverging maps are centred on zero, where zero means something: no stress, no velocity, no
# heat flux, and for θ the reference temperature, at which the rod is free of thermal stress
# (σ = u_x + ζu_xt − aθ) and which the medium at x = 1 has (−θ_x(1) = kθ(1)): red is warmer than
# it, blue colder. u is drawn on a sequential map: its sign is a direction, not a departure from
# a state.
MAPS = {
    "u": ("displacement u", "u(x, t)", "viridis", False, "u(x, t)", "L", ("u_1", "u_half")),
    "theta": ("temperature θ", "θ(x, t)", "coolwarm", True, r"\theta(x, t)", "", ("theta_1",)),
    "sigma": ("stress σ", "σ(x, t)", "RdBu_r", True, r"\sigma(x, t)", "E", ("sigma_1",)),
    "velocity": ("velocity u_t", "u_t(x, t)", "PuOr_r", True, "u_t(x, t)", "L/t_0", ("ut_1",)),
    "heat_flux": ("heat flux −θ_x", "−θ_x(x, t)", "PiYG", True, r"-\theta_x(x, t)", "",
                  ("heat_flux_1",)),
}
X_LABEL = with_unit("$x$", "L")
MISSED = 0.01  # the history's extreme beyond the frames' by more than this share: a note


class Grid(NamedTuple):
    """What a map colours: the times (``x``, scaled) and positions (``y``) of its nodes (P1
    fields) or of its cells' edges (per-cell fields), and the values, one row per position."""

    x: np.ndarray
    y: np.ndarray
    values: np.ndarray
    cells: bool


class Range(NamedTuple):
    """A map's colour range and the notes that say what the saved frames miss."""

    lo: float
    hi: float
    notes: list[str]


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres: midpoints between them, the ends kept."""
    if centres.size == 1:
        return np.array([centres[0], centres[0] + 1.0])
    mid = 0.5 * (centres[1:] + centres[:-1])
    return np.concatenate([[centres[0]], mid, [centres[-1]]])


def _grid(fields: Fields, name: str, t0: float, t_scale: float) -> Grid:
    """The map of one field: its times shifted by ``t0`` and scaled by ``t_scale``."""
    values = getattr(fields, name).T  # (positions, saves)
    if name in CELL_FUNCTIONS:
        return Grid((_edges(fields.t) - t0) * t_scale, fields.x, values, True)
    t = fields.t
    if t.size == 1:  # one save: a band of one colour per node, one time unit wide
        t, values = np.array([t[0], t[0] + 1.0]), np.repeat(values, 2, axis=1)
    return Grid((t - t0) * t_scale, fields.x, values, False)


def _history_extremes(history, name: str, t0: float, t1: float):
    """The history's rows in [t0, t1] of the columns that hold the field ``name`` somewhere
    (x = 1, the midpoint, the probes): the (value, t, column) of its least and greatest value,
    or None where it has none."""
    if history is None:
        return None
    columns = [c for c in (*MAPS[name][6], *(n for n in history.names
                                            if n.startswith(f"{name}@")))
               if c in history.names]
    t = np.asarray(history.t)
    rows = (t >= t0) & (t <= t1)
    found = []
    for column in columns:
        values = np.asarray(history[column], dtype=float)[rows]
        finite = np.isfinite(values)
        if finite.any():
            times = t[rows][finite]
            values = values[finite]
            found += [(float(values.min()), float(times[values.argmin()]), column),
                      (float(values.max()), float(times[values.argmax()]), column)]
    if not found:
        return None
    return min(found), max(found)


def _contact_shortest(history, gap: float | None, t0: float, t1: float) -> float | None:
    """The shortest interval of contact (u(1) > g) in [t0, t1] that the history shows."""
    if history is None or gap is None or "u_1" not in history.names:
        return None
    t = np.asarray(history.t)
    rows = (t >= t0) & (t <= t1)
    t, touching = t[rows], np.asarray(history.u_1)[rows] > gap
    edges = np.diff(np.concatenate([[0], touching.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    spans = [t[j] - t[i] for i, j in zip(starts, ends, strict=True) if j > i]
    return min(spans) if spans else None


def colour_range(fields: Fields, name: str, history=None, gap: float | None = None) -> Range:
    """The colour range of a map: the saved field's values and the history's of the same
    quantity together (symmetric about zero for a centred map), with a note where the history
    goes beyond the saved frames or a contact is shorter than the frames' spacing."""
    values = getattr(fields, name)
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    t0, t1 = float(fields.t[0]), float(fields.t[-1])
    symbol = MAPS[name][4].replace("(x, t)", "")
    notes = []
    extremes = _history_extremes(history, name, t0, t1)
    if extremes is not None:
        (low, t_low, c_low), (high, t_high, c_high) = extremes
        span = max(hi - lo, abs(lo), abs(hi), 1e-300)
        missed = [(v, tv, c) for v, tv, c in ((low, t_low, c_low), (high, t_high, c_high))
                  if v < lo - MISSED * span or v > hi + MISSED * span]
        lo, hi = min(lo, low), max(hi, high)
        for value, when, column in missed:
            notes.append(f"The saved frames miss the extreme ${_column_math(column, symbol)}"
                         f" = {value:.3g}$ of the history at $t = {when:.4g}$; the colour range "
                         "includes it.")
    spacing = float(np.min(np.diff(fields.t))) if fields.t.size > 1 else None
    shortest = _contact_shortest(history, gap, t0, t1)
    if spacing is not None and shortest is not None and shortest < spacing:
        notes.append(f"Frames are saved every $\\Delta t \\geq {spacing:.3g}$, longer than the "
                     f"shortest contact ({shortest:.3g}): output.every sets how often.")
    if MAPS[name][3]:
        bound = max(abs(lo), abs(hi), 1e-300)
        lo, hi = -bound, bound
    elif hi <= lo:
        lo, hi = lo - max(abs(lo), 1.0) / 2, hi + max(abs(hi), 1.0) / 2
    return Range(lo, hi, notes)


def _column_math(column: str, symbol: str) -> str:
    """A history column as a symbol in a note: ``\\sigma(1)``, ``u(0.5)``, ``\\sigma(0.25)``."""
    from rodfem.output.names import column_symbol

    return column_symbol(column)[0] if column else symbol


def spacetime_figure(fields: Fields, name: str, run_label: str, path: Path, history=None,
                     gap: float | None = None) -> Path:
    """Draw one field over (t, x) with labelled axes (units included) and a colour bar.

    Args:
        fields: the run's saved fields (those of a time window: :func:`fields_in_window`).
        name: a field of :data:`MAPS` the run saved.
        run_label: the run, for the title.
        path: the figure to write (PNG, PDF or SVG, by its suffix).
        history: the run's history, whose values of the same quantity widen the colour range
            (None: the saved fields' range alone).
        gap: the obstacle's gap, for the contact intervals the history shows.
    """
    title, _, cmap, _, symbol, unit, _ = MAPS[name]
    t0 = float(fields.t[0])
    grid = _grid(fields, name, 0.0, 1.0)
    limits = colour_range(fields, name, history, gap)
    norm = Normalize(limits.lo, limits.hi)
    with style.mpl_fonts():
        fig = Figure(figsize=style.MPL_SIZE, dpi=style.MPL_DPI, layout="constrained")
        ax = fig.add_subplot()
        mesh = ax.pcolormesh(grid.x, grid.y, grid.values, cmap=cmap, norm=norm,
                             shading="flat" if grid.cells else "gouraud", rasterized=True)
        fig.colorbar(mesh, ax=ax, label=with_unit(f"${symbol}$", unit), fraction=0.06)
        ax.set_xlim(t0, float(grid.x[-1]))
        ax.set_ylim(float(fields.x[0]), float(fields.x[-1]))
        ax.set_xlabel(TIME_LABEL)
        ax.set_ylabel(X_LABEL)
        ax.set_title(f"{title}: {run_label}")
        if limits.notes:  # below the map, inside the canvas (the layout makes room)
            fig.supxlabel("\n".join(limits.notes), fontsize=style.MPL_TICK_SIZE, color="0.2")
        return formats.save(fig, path, dpi=style.MPL_DPI)
