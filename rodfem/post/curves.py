"""Curves against time from ``history.h5``: the paper's four panels and ln(Ê + 0.01).

Drawn with matplotlib (its figures, not pyplot's: nothing global, no backend to choose), which
lays out what VTK's charts cannot: a legend outside the axes, below them, so that it never covers
a curve, and a colour bar for runs coloured by a scene value. Several runs share the axes, each
in its own colour with one legend, or (``colour_by``) coloured along a sequential map of that
value with one colour bar and no per-run legend.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rodfem.output.names import TIME_LABEL, series_label
from rodfem.output import figures as formats
from rodfem.post import style
from rodfem.post.runs import Run

# The paper's four panels (Figures 1-4): title, y label (rodfem.output.names) and history column.
PANELS = tuple((title, series_label(column), column) for title, column in (
    ("displacement of the end", "u_1"),
    ("displacement of the midpoint", "u_half"),
    ("velocity of the end", "ut_1"),
    ("stress at the end", "sigma_1"),
))
ENERGY_FLOOR = 0.01
# Line styles that tell runs apart beside their colours (never the gap's dashes "--").
DASHES = ("-", ":", "-.", (0, (6, 2, 1, 2, 1, 2)))


class Dashes(NamedTuple):
    """Runs told apart by their line styles too: one style per run, and the legend's entries
    (style, label) that say what each style stands for."""

    styles: list
    legend: list[tuple[object, str]]  # the paper plots ln(Ê + 0.01)
# The legend's rows at most: the panels keep two thirds of the figure however many runs it shows.
LEGEND_ROWS = 8


def _in_window(t: np.ndarray, window: tuple[float, float] | None) -> np.ndarray:
    """The samples drawn: those in the window and one beyond each end, so that a curve reaches
    the edges of the axes (which clip it)."""
    if window is None:
        return np.ones(t.size, dtype=bool)
    inside = (t >= window[0]) & (t <= window[1])
    reach = inside.copy()
    reach[:-1] |= inside[1:]
    reach[1:] |= inside[:-1]
    return reach


def _limits(ax, curves: list[tuple[np.ndarray, np.ndarray]], t_range: list[float]) -> None:
    """x from the window (or the runs' span), y from the values inside it, padded."""
    ax.set_xlim(*t_range)
    visible = [y[(t >= t_range[0]) & (t <= t_range[1])] for t, y in curves]
    ax.set_ylim(*style.padded_range(visible or [np.array([])]))


def _t_range(runs: list[Run], window: tuple[float, float] | None) -> list[float]:
    return list(window) if window else style.time_range([float(r.history.t[-1]) for r in runs])


def _contact_intervals(run: Run) -> list[tuple[float, float]]:
    """The intervals [t_i, t_j] of consecutive steps with u(1, t) > g; in an adaptive run's
    history, from and to the contact events around them (rows where u(1) = g to round-off)."""
    t, touching = run.history.t, run.history.u_1 > run.gap
    edges = np.diff(np.concatenate([[0], touching.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    if "event" in run.history.names:
        event = run.history["event"] != 0
        starts = np.where((starts > 0) & event[np.maximum(starts - 1, 0)], starts - 1, starts)
        last = t.size - 1
        ends = np.where((ends < last) & event[np.minimum(ends + 1, last)], ends + 1, ends)
    return [(float(t[i]), float(t[j])) for i, j in zip(starts, ends, strict=True)]


def _columns(labels: list[str]) -> int:
    """Legend columns: as many as fit the figure's width for labels of this length."""
    longest = max((len(label) for label in labels), default=1)
    return max(1, min(len(labels), 4 if longest < 28 else 3 if longest < 40 else 2))


def _fitted(handles: list, names: list[str], runs: int) -> tuple[list, list[str]]:
    """The legend's entries, the runs' first (``runs`` of them), then the others (the gap, the
    contact shading), which are always shown. Where they do not fit in ``LEGEND_ROWS`` rows, the
    runs' entries that do but one, and one that counts the runs left out."""
    room = LEGEND_ROWS * _columns(names) - (len(names) - runs)
    if runs <= room:
        return handles, names
    keep = room - 1
    return ([*handles[:keep], Line2D([], [], color="none"), *handles[runs:]],
            [*names[:keep], f"… and {runs - keep} more runs", *names[runs:]])


def _axes(fig: Figure, rows: int, columns: int, labels: list[str], bar: bool, top: float):
    """The panels; below them a strip for the legend (an empty axes), as high as its entries
    need, so that it sits beside the curves, never over them; and right of them the colour
    bar's axes if ``bar``. The margins are fixed (the figure's size and fonts are): a layout
    engine would measure every label first, a third of the drawing time."""
    height = style.MPL_SIZE[1]
    legend = (0.25 + 0.3 * -(-len(labels) // _columns(labels))) if labels else 0.0  # inches
    bottom = (legend + 0.6) / height  # the tick labels and "t" under the lowest panels
    right = 0.87 if bar else 0.98
    grid = fig.add_gridspec(rows, columns, left=0.075, right=right, bottom=bottom, top=top,
                            hspace=0.38, wspace=0.22)
    axes = np.array([[fig.add_subplot(grid[r, c]) for c in range(columns)] for r in range(rows)])
    box = None
    if labels:
        box = fig.add_axes((0.02, 0.0, 0.96, legend / height))
        box.axis("off")
    bar_axes = fig.add_axes((0.9, bottom, 0.018, top - bottom)) if bar else None
    return axes, box, bar_axes


def _legend(box, handles: list, labels: list[str]) -> None:
    """The legend, in the strip below the panels."""
    if box is not None:
        box.legend(handles, labels, loc="center", ncol=_columns(labels), frameon=False,
                   fontsize=style.MPL_LEGEND_SIZE, handlelength=2.5, borderaxespad=0)


def _colour_bar(fig: Figure, bar_axes, mappable, key: str | None) -> None:
    if mappable is not None:
        fig.colorbar(mappable, cax=bar_axes, label=style.key_label(key))


def contact_figure(runs: list[Run], labels: list[str], path: Path,
                   window: tuple[float, float] | None = None,
                   colour_by: str | None = None, colour_log: bool = False,
                   dashes: Dashes | None = None) -> Path:
    """u(1, t) with the gap g, u(0.5, t), u_t(1, t) and σ(1, t).

    For one run the intervals of contact (u(1, t) > g) are shaded in grey across the four
    panels; for several, shadings would pile up, and the gap line shows contact in the first.
    ``colour_log``: the colours on a log scale (:func:`rodfem.post.style.run_colours`);
    ``dashes``: the runs' line styles and what they stand for, in the legend.
    """
    colours, mappable = style.run_colours(runs, colour_by, colour_log)
    t_range = _t_range(runs, window)
    gaps = sorted({run.gap for run in runs})
    intervals = _contact_intervals(runs[0]) if len(runs) == 1 else []
    handles = [] if mappable else [Line2D([], [], color=c, lw=style.MPL_LINE_WIDTH)
                                   for c in colours]
    names = [] if mappable else list(labels)
    styles, more = _dashes(dashes, len(runs))
    handles, names = handles + more[0], names + more[1]
    handles += [Line2D([], [], color="black", ls="--", lw=1.5) for _ in gaps]
    names += [f"gap $g = {gap:g}$" for gap in gaps]
    if intervals:
        handles.append(Patch(color=style.CONTACT_SHADE))
        names.append("contact: $u(1, t) > g$")
    handles, names = _fitted(handles, names, 0 if mappable else len(runs))
    with style.mpl_fonts():
        fig = Figure(figsize=style.MPL_SIZE, dpi=style.MPL_DPI)
        axes, box, bar = _axes(fig, 2, 2, names, mappable is not None, top=0.96)
        for panel, ax in enumerate(axes.flat):
            title, y_label, column = PANELS[panel]
            for start, end in intervals:
                ax.axvspan(start, end, color=style.CONTACT_SHADE, lw=0, zorder=0)
            curves = []
            for run, colour, ls in zip(runs, colours, styles, strict=True):
                keep = _in_window(run.history.t, window)
                t, y = run.history.t[keep], run.history[column][keep]
                ax.plot(t, y, color=colour, ls=ls, lw=style.MPL_LINE_WIDTH)
                curves.append((t, y))
            if panel == 0:
                for gap in gaps:
                    ax.axhline(gap, color="black", ls="--", lw=1.5)
                    curves.append((np.array(t_range), np.array([gap, gap])))
            ax.set_title(title)
            ax.set_xlabel(TIME_LABEL)
            ax.set_ylabel(y_label)
            ax.grid(True, color="0.9")
            _limits(ax, curves, t_range)
        _colour_bar(fig, bar, mappable, colour_by)
        _legend(box, handles, names)
        return _save(fig, path)


def energy_title(runs: list[Run]) -> str:
    """What the energy figure shows; the paper's Figure 5 is named only where every run is the
    paper's experiment 1 or 2 (the figure compares the two)."""
    title = r"$\ln(\hat{E} + 0.01)$ against $t$"
    experiments = sorted({run.experiment for run in runs}, key=str)
    if set(experiments) <= {1, 2}:
        which = " and ".join(str(e) for e in experiments)
        plural = "s" if len(experiments) > 1 else ""
        title += f": the paper's Figure 5 (experiment{plural} {which})"
    return title


def energy_figure(runs: list[Run], labels: list[str], path: Path,
                  window: tuple[float, float] | None = None,
                  colour_by: str | None = None, colour_log: bool = False,
                  dashes: Dashes | None = None) -> Path:
    """ln(Ê + 0.01) against t, Ê the discrete energy of Remark 4.4 (values with Ê + 0.01 ≤ 0
    are left out); ``colour_log`` and ``dashes`` as :func:`contact_figure`'s."""
    colours, mappable = style.run_colours(runs, colour_by, colour_log)
    t_range = _t_range(runs, window)
    names = [] if mappable else list(labels)
    handles = [Line2D([], [], color=c, lw=style.MPL_LINE_WIDTH) for c in colours[:len(names)]]
    runs_named = len(names)
    styles, more = _dashes(dashes, len(runs))
    handles, names = _fitted(handles + more[0], names + more[1], runs_named)
    with style.mpl_fonts():
        fig = Figure(figsize=style.MPL_SIZE, dpi=style.MPL_DPI)
        axes, box, bar = _axes(fig, 1, 1, names, mappable is not None, top=0.91)
        ax, curves = axes[0, 0], []
        for run, colour, ls in zip(runs, colours, styles, strict=True):
            keep = _in_window(run.history.t, window)
            shifted = run.history.energy[keep] + ENERGY_FLOOR
            t, y = run.history.t[keep], np.log(np.where(shifted > 0, shifted, np.nan))
            ax.plot(t, y, color=colour, ls=ls, lw=style.MPL_LINE_WIDTH)
            curves.append((t, y))
        ax.set_title(energy_title(runs) + "\n" + r"$\hat{E}$: the discrete energy of Remark 4.4")
        ax.set_xlabel(TIME_LABEL)
        ax.set_ylabel(r"$\ln(\hat{E} + 0.01)$, $\hat{E}$ in [$EL$]")  # the log of a number
        ax.grid(True, color="0.9")
        _limits(ax, curves, t_range)
        _colour_bar(fig, bar, mappable, colour_by)
        _legend(box, handles, names)
        return _save(fig, path)


def _dashes(dashes: Dashes | None, runs: int) -> tuple[list, tuple[list, list[str]]]:
    """The runs' line styles (solid without ``dashes``) and the legend's handles and labels of
    the styles."""
    if dashes is None:
        return ["-"] * runs, ([], [])
    return list(dashes.styles), ([Line2D([], [], color="0.3", ls=ls, lw=style.MPL_LINE_WIDTH)
                                  for ls, _ in dashes.legend],
                                 [label for _, label in dashes.legend])


def _save(fig: Figure, path: Path) -> Path:
    """Whole or not at all, in the format of the path's suffix (:mod:`rodfem.output.figures`)."""
    return formats.save(fig, path, dpi=style.MPL_DPI)
