"""The figure of a fit, ``fit.png``: the measured data against the fitted run, a panel per fitted
history column (matplotlib, no display needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output import names
from rodfem.output.atomic import replacing
from rodfem.post.style import colour, mpl_fonts

DPI = 120


def plot_fit(path: Path, t: np.ndarray, data: dict[str, np.ndarray], run_t: np.ndarray,
             run: dict[str, np.ndarray], title: str) -> Path:
    """Draw ``data`` (by column, at the times ``t``) as points and the fitted run's history
    (``run`` by column, at ``run_t``) as lines into ``path``, written whole or not at all."""
    with mpl_fonts():
        fig = Figure(figsize=(7.0, 2.6 * len(data) + 0.6), layout="constrained")
        axes = fig.subplots(len(data), 1, sharex=True, squeeze=False)[:, 0]
        for ax, (column, values) in zip(axes, data.items(), strict=True):
            ax.plot(t, values, ".", color=colour(0), markersize=4, label="data")
            ax.plot(run_t, run[column], "-", color=colour(1), linewidth=1.4, label="fit")
            ax.set_ylabel(names.series_label(column))
            ax.grid(True, alpha=0.3)
        axes[0].legend(loc="best", frameon=False)
        axes[0].set_title(title)
        axes[-1].set_xlabel(names.TIME_LABEL)
        with replacing(path, "wb") as file:
            fig.savefig(file, format="png", dpi=DPI)
    return path
