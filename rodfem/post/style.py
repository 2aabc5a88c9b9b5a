"""What every figure shares: sizes, colours, fonts and the look of a chart.

Symbols are written in mathtext (``$\\sigma(1, t)$``), which VTK typesets through matplotlib, as
the paper writes them; VTK's own fonts have no Greek letters.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pyvista as pv
from matplotlib.ticker import MaxNLocator
from vtkmodules.vtkCommonCore import VTK_FONT_FILE
from vtkmodules.vtkRenderingCore import vtkTextProperty

WINDOW = (1200, 900)  # pixels, for the still figures
LINE_WIDTH = 3.0
TITLE_SIZE, LABEL_SIZE, TICK_SIZE, LEGEND_SIZE = 22, 22, 18, 18
# Run colours (matplotlib's tab10); a run's contact intervals are shaded in its own colour.
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
           "tab:pink", "tab:gray", "tab:olive", "tab:cyan")
SHADE_OPACITY = 0.18
# Plain text with Greek letters (ζ, θ, σ) is drawn in matplotlib's DejaVu Sans.
FONT_FILE = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"


def use_font(prop: vtkTextProperty) -> vtkTextProperty:
    """Draw a text property's plain (non-mathtext) text in DejaVu Sans, when matplotlib has it."""
    if FONT_FILE.is_file():
        prop.SetFontFamily(VTK_FONT_FILE)
        prop.SetFontFile(str(FONT_FILE))
    return prop


def colour(i: int) -> str:
    """The colour of the i-th run."""
    return COLOURS[i % len(COLOURS)]


def shade(i: int) -> tuple[float, float, float, float]:
    """The translucent colour that shades the i-th run's intervals of contact."""
    return (*pv.Color(colour(i)).float_rgb, SHADE_OPACITY)


def time_range(ends: list[float]) -> list[float]:
    """[0, the latest end time], never empty (a run may have stopped at t = 0)."""
    end = max(ends)
    return [0.0, end if end > 0 else 1.0]


def padded_range(values: list[np.ndarray], pad: float = 0.05) -> tuple[float, float]:
    """[min, max] of all finite values, widened by ``pad`` of their span (never empty)."""
    finite = np.concatenate([v[np.isfinite(v)] for v in values])
    if finite.size == 0:
        return -1.0, 1.0
    lo, hi = float(finite.min()), float(finite.max())
    span = hi - lo if hi > lo else max(abs(hi), 1.0)
    return lo - pad * span, hi + pad * span


def ticks(lo: float, hi: float, count: int = 7) -> np.ndarray:
    """Round tick values within [lo, hi] (matplotlib's choice), for colour bars."""
    values = MaxNLocator(count).tick_values(lo, hi)
    return values[(values >= lo - 1e-9 * (hi - lo)) & (values <= hi + 1e-9 * (hi - lo))]


def place_legend(chart: pv.Chart2D, curves: list[tuple[np.ndarray, np.ndarray]],
                 entries: int) -> None:
    """Put the legend in the corner of the plot area that the curves cross least.

    Args:
        chart: a chart whose ``x_range`` and ``y_range`` are set.
        curves: the (x, y) data drawn.
        entries: the number of legend entries (the legend's height grows with them).
    """
    (x0, x1), (y0, y1) = chart.x_range, chart.y_range
    width, height = 0.45, min(0.9, 0.07 * entries + 0.04)
    points = np.concatenate([np.column_stack([(x - x0) / (x1 - x0), (y - y0) / (y1 - y0)])
                             for x, y in curves])
    legend = chart.GetLegend()
    corners = [(legend.TOP, legend.RIGHT), (legend.TOP, legend.LEFT),
               (legend.BOTTOM, legend.RIGHT), (legend.BOTTOM, legend.LEFT)]

    def crossings(corner: tuple[int, int]) -> int:
        vertical, horizontal = corner
        in_x = points[:, 0] >= 1 - width if horizontal == legend.RIGHT else points[:, 0] <= width
        in_y = points[:, 1] >= 1 - height if vertical == legend.TOP else points[:, 1] <= height
        return int(np.count_nonzero(in_x & in_y))

    vertical, horizontal = min(corners, key=crossings)  # the first of equals: top right
    legend.SetVerticalAlignment(vertical)
    legend.SetHorizontalAlignment(horizontal)


def chart(title: str, x_label: str, y_label: str) -> pv.Chart2D:
    """A 2D line chart with the figures' fonts and sizes."""
    c = pv.Chart2D(x_label=x_label, y_label=y_label)
    c.title = title
    c.GetTitleProperties().SetFontSize(TITLE_SIZE)
    for axis in (c.x_axis, c.y_axis):
        axis.label_size = LABEL_SIZE
        axis.tick_label_size = TICK_SIZE
    c.GetLegend().GetLabelProperties().SetFontSize(LEGEND_SIZE)
    c.GetLegend().SetSymbolWidth(40)
    return c
