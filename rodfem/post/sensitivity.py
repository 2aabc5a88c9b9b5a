"""sensitivity.png: the indices of a sensitivity study (:mod:`rodfem.studies.sensitivity.run`), a
panel per measure, a group of bars per parameter with its confidence interval: Sobol's first
order S1 and total ST, or Morris' μ* and σ.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output.atomic import replacing
from rodfem.output.names import key_symbol
from rodfem.post import style

# The bars of each method: (column, its interval's column or None, legend).
BARS = {"sobol": (("S1", "S1_conf", "first order $S_1$"), ("ST", "ST_conf", "total $S_T$")),
        "morris": (("mu_star", "mu_star_conf", r"$\mu^*$"), ("sigma", None, r"$\sigma$"))}


def _name(key: str) -> str:
    symbol = key_symbol(key)
    return f"${symbol}$" if symbol else key


def plot_indices(method: str, rows: list[dict], path: Path) -> Path:
    """Draw the ``rows`` of :func:`rodfem.studies.sensitivity.indices.analyse` into ``path`` (whole
    or not at all)."""
    measures = list(dict.fromkeys(row["measure"] for row in rows))
    with style.mpl_fonts():
        fig = Figure(figsize=(style.MPL_SIZE[0], 1.5 + 3.0 * len(measures)),
                     dpi=style.MPL_DPI, layout="constrained")
        axes = fig.subplots(len(measures), 1, squeeze=False)[:, 0]
        for ax, measure in zip(axes, measures, strict=True):
            mine = [row for row in rows if row["measure"] == measure]
            x = np.arange(len(mine))
            width = 0.8 / len(BARS[method])
            for k, (column, conf, label) in enumerate(BARS[method]):
                heights = [row[column] for row in mine]
                errors = [row[conf] for row in mine] if conf else None
                ax.bar(x + (k - 0.5 * (len(BARS[method]) - 1)) * width, heights, width,
                       yerr=errors, capsize=4, label=label, color=style.colour(k))
            ax.set_xticks(x, [_name(row["parameter"]) for row in mine])
            ax.axhline(0.0, color="0.3", linewidth=0.8)
            ax.set_title(measure)
            ax.grid(axis="y", alpha=0.3)
            if method == "sobol":
                ax.set_ylabel("index")
        axes[0].legend(loc="best", fontsize=style.MPL_LEGEND_SIZE)
        with replacing(path, "wb") as file:
            fig.savefig(file, format="png", dpi=style.MPL_DPI)
    return path
