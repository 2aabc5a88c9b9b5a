"""Curves against time from ``history.csv``: the paper's four panels and its Figure 5.

Several runs are drawn on the same axes, each in its own colour, with one legend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista as pv

from rodfem.post import backend, style
from rodfem.post.runs import Run

# The paper's four panels (Figures 1-4): title, y label and history column.
PANELS = (
    ("displacement of the end", "$u(1, t)$", "u_1"),
    ("displacement of the midpoint", "$u(0.5, t)$", "u_half"),
    ("velocity of the end", "$u_t(1, t)$", "ut_1"),
    ("stress at the end", r"$\sigma(1, t)$", "sigma_1"),
)
ENERGY_FLOOR = 0.01  # the paper plots ln(Ê + 0.01)


def _shade_contact(chart: pv.Chart2D, runs: list[Run], y_range: tuple[float, float],
                   labelled: bool) -> None:
    """Shade, across the chart's height, the intervals where a run is in contact (u(1) > g)."""
    lo, hi = y_range
    for i, run in enumerate(runs):
        t, contact = run.history.t, run.history.u_1 > run.gap
        if not contact.any():
            continue
        label = ""
        if labelled:
            label = "contact: $u(1, t) > g$" if len(runs) == 1 else f"{run.name} in contact"
        chart.area(t, np.full_like(t, lo), np.where(contact, hi, lo), color=style.shade(i),
                   label=label)


def _panel(runs: list[Run], labels: list[str], panel: int) -> pv.Chart2D:
    """One of the four panels; the first also draws the gap and carries the legend."""
    title, y_label, column = PANELS[panel]
    first = panel == 0
    t_range = style.time_range([float(run.history.t[-1]) for run in runs])
    curves = [(run.history.t, getattr(run.history, column)) for run in runs]
    gaps = sorted({run.gap for run in runs}) if first else []
    curves += [(np.linspace(*t_range, 200), np.full(200, gap)) for gap in gaps]
    y_range = style.padded_range([y for _, y in curves])

    chart = style.chart(title, "$t$", y_label)
    _shade_contact(chart, runs, y_range, labelled=first)
    for i, ((t, y), label) in enumerate(zip(curves[: len(runs)], labels, strict=True)):
        chart.line(t, y, color=style.colour(i), width=style.LINE_WIDTH,
                   label=label if first else "")
    for gap in gaps:
        chart.line(t_range, [gap, gap], color="black", width=2.0, style="--",
                   label=f"gap $g = {gap:g}$")
    chart.x_range = t_range
    chart.y_range = list(y_range)
    chart.legend_visible = first
    if first:
        shaded = sum(bool((run.history.u_1 > run.gap).any()) for run in runs)
        style.place_legend(chart, curves, len(runs) + len(gaps) + shaded)
    return chart


def contact_figure(runs: list[Run], labels: list[str], path: Path) -> Path:
    """u(1, t) with the gap g, u(0.5, t), u_t(1, t) and σ(1, t), intervals of contact shaded."""
    plotter = pv.Plotter(shape=(2, 2), window_size=style.WINDOW, off_screen=True)
    for panel in range(len(PANELS)):
        plotter.subplot(panel // 2, panel % 2)
        plotter.add_chart(_panel(runs, labels, panel))
    backend.save_image(plotter, path)
    plotter.close()
    return path


def energy_figure(runs: list[Run], labels: list[str], path: Path) -> Path:
    """ln(Ê + 0.01) against t, the paper's Figure 5 (values with Ê + 0.01 ≤ 0 are left out)."""
    plotter = pv.Plotter(window_size=style.WINDOW, off_screen=True)
    chart = style.chart("discrete energy of Remark 4.4 (Figure 5)", "$t$", r"$\ln(\hat{E} + 0.01)$")
    series = []
    for i, (run, label) in enumerate(zip(runs, labels, strict=True)):
        shifted = run.history.energy + ENERGY_FLOOR
        y = np.log(np.where(shifted > 0, shifted, np.nan))
        series.append(y)
        chart.line(run.history.t, y, color=style.colour(i), width=style.LINE_WIDTH, label=label)
    chart.x_range = style.time_range([float(run.history.t[-1]) for run in runs])
    chart.y_range = list(style.padded_range(series))
    style.place_legend(chart, [(run.history.t, y) for run, y in zip(runs, series, strict=True)],
                       len(runs))
    plotter.add_chart(chart)
    backend.save_image(plotter, path)
    plotter.close()
    return path
