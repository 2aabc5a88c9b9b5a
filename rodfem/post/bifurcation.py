"""The two-parameter map of ``rodfem steady --follow``: from ``curves.csv`` and ``counts.csv``, the
plane of the two scene values shaded by the number of steady states, with the curves of folds,
grazing points or Hopf points drawn over it and a legend saying which is which. Drawn with
matplotlib, as the branches of :mod:`rodfem.post.steady`."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rodfem.output import figures
from rodfem.output.names import KEYS, key_label
from rodfem.post import style
from rodfem.post.runs import PlotError

FIGURE = "curves.png"
SHADES = ("#f4f4f4", "#d6e4f0", "#f6d5c2", "#e6c7e6", "#cfe8cf")  # 1, 2, 3, 4, 5+ states
LINES = {"fold": ("k", "-", "folds"), "grazing": ("tab:green", "--", "grazing points"),
         "hopf": ("tab:purple", "-", "Hopf points")}


def _read(path: Path) -> list[dict]:
    try:
        with open(path, encoding="utf-8", newline="") as f:
            return list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None


def plot_curves(out: Path, format: str = "png") -> list[Path]:
    """figures/curves.png (or .pdf, .svg) of ``out``."""
    rows, grid = _read(out / "curves.csv"), _read(out / "counts.csv")
    if not grid:
        raise PlotError(f"{out / 'counts.csv'} holds no counts")
    key, key2 = grid[0]["key"], grid[0]["key2"]
    x = np.array(sorted({float(r["parameter"]) for r in grid}))
    y = np.array(sorted({float(r["parameter2"]) for r in grid}))
    count = np.zeros((y.size, x.size))
    for r in grid:
        count[np.searchsorted(y, float(r["parameter2"])),
              np.searchsorted(x, float(r["parameter"]))] = float(r["count"])
    top = int(count.max())
    with style.mpl_fonts():
        fig = Figure(figsize=style.MPL_SIZE, dpi=style.MPL_DPI, layout="constrained")
        ax = fig.subplots()
        levels = np.arange(0.5, max(top, 1) + 1.5)
        colours = ListedColormap([SHADES[min(i, len(SHADES) - 1)] for i in range(levels.size - 1)])
        ax.pcolormesh(x, y, count, cmap=colours,
                      norm=BoundaryNorm(levels, colours.N), shading="nearest")
        entries = [(Patch(color=SHADES[min(n - 1, len(SHADES) - 1)]),
                    f"{n} steady state{'s' if n > 1 else ''}")
                   for n in sorted({int(c) for c in count.ravel()}) if n > 0]
        for kind in LINES:
            mine = [r for r in rows if r["kind"] == kind]
            colour, line, label = LINES[kind]
            for curve in sorted({r["curve"] for r in mine}, key=int):
                part = [r for r in mine if r["curve"] == curve]
                ax.plot([float(r["parameter"]) for r in part],
                        [float(r["parameter2"]) for r in part], color=colour, linestyle=line,
                        linewidth=style.MPL_LINE_WIDTH, marker="." if len(part) < 3 else None)
            if mine:
                entries.append((Line2D([], [], color=colour, linestyle=line), label))
        ax.set_xlabel(key_label(key) if key in KEYS else key)
        ax.set_ylabel(key_label(key2) if key2 in KEYS else key2)
        ax.set_xlim(x[0], x[-1])
        ax.set_ylim(y[0], y[-1])
        ax.set_title("Steady states over two values")
        ax.legend(*zip(*entries, strict=True), loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  borderaxespad=0.0, fontsize=style.MPL_LEGEND_SIZE, frameon=False)
        path = out / "figures" / Path(FIGURE).with_suffix(f".{format}").name
        path.parent.mkdir(exist_ok=True)
        return [figures.save(fig, path, dpi=style.MPL_DPI)]
