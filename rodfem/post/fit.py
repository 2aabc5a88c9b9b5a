"""The figure of a fit, ``fit.png`` (or .pdf, .svg): the measured data against the fitted run, a
panel per fitted history column, axes with their units, the fitted values in the title (matplotlib,
no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output import figures, names
from rodfem.post.style import colour, mpl_fonts

DPI = 120
PER_LINE = 3  # fitted values in a line of the title


def fit_title(parameters: dict[str, dict]) -> str:
    """The title of a fit's figure: its fitted values by their symbols (``$\\zeta$ = 0.2``),
    a few to a line so that the title fits the figure's width."""
    items = []
    for key, found in parameters.items():
        symbol = names.key_symbol(key)
        shown = f"${symbol}$" if symbol else key
        items.append(f"{shown} = {found['value']:.4g}")
    lines = [", ".join(items[i:i + PER_LINE]) for i in range(0, len(items), PER_LINE)]
    return "fitted: " + "\n".join(lines)


def plot_fit(path: Path, t: np.ndarray, data: dict[str, np.ndarray], run_t: np.ndarray,
             run: dict[str, np.ndarray], title: str) -> Path:
    """Draw ``data`` (by column, at the times ``t``) as points and the fitted run's history
    (``run`` by column, at ``run_t``) as lines into ``path`` (in the format of its suffix),
    written whole or not at all; every text inside the canvas (:mod:`rodfem.output.figures`)."""
    with mpl_fonts():
        fig = Figure(figsize=(7.0, 2.6 * len(data) + 0.6 + 0.3 * title.count("\n")),
                     layout="constrained")
        axes = fig.subplots(len(data), 1, sharex=True, squeeze=False)[:, 0]
        for ax, (column, values) in zip(axes, data.items(), strict=True):
            ax.plot(t, values, ".", color=colour(0), markersize=4, label="data")
            ax.plot(run_t, run[column], "-", color=colour(1), linewidth=1.4, label="fit")
            ax.set_ylabel(names.series_label(column))
            ax.grid(True, alpha=0.3)
        axes[0].legend(loc="best", frameon=False)
        axes[0].set_title(title, fontsize="medium")
        axes[-1].set_xlabel(names.TIME_LABEL)
        return figures.save(fig, path, dpi=DPI)
