"""sensitivity.png (or .pdf, .svg): the indices of a sensitivity study
(:mod:`rodfem.studies.sensitivity.run`), a panel per measure named as the sweep figures name it, a
group of bars per parameter, labelled with its symbol and the range it was varied over, with its
confidence interval: Sobol's first order S1 and total ST, or Morris' μ* and σ.

Sobol indices are shares of a variance, in [0, 1]; their estimates (and the bootstrap intervals
about them) can stray outside by sampling error, so the bars and their intervals are drawn clipped
to [0, 1] (the table, sensitivity.csv, keeps the estimates as they are), and the figure says so.
Morris' μ* and σ are not shares: they are drawn from 0, unclipped above.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output import figures, names
from rodfem.output.names import key_symbol
from rodfem.post import style

# The bars of each method: (column, its interval's column or None, legend).
BARS = {"sobol": (("S1", "S1_conf", "first order $S_1$"), ("ST", "ST_conf", "total $S_T$")),
        "morris": (("mu_star", "mu_star_conf", r"$\mu^*$"), ("sigma", None, r"$\sigma$"))}
# The range of each method's bars: Sobol's indices are shares; Morris' measures have no top.
BOUNDS = {"sobol": (0.0, 1.0), "morris": (0.0, np.inf)}
CLIPPED = ("Sobol indices are shares of the variance, in [0, 1]: the estimates and their "
           "confidence intervals are drawn clipped to it (sensitivity.csv holds them as "
           "estimated).")


def _name(key: str) -> str:
    symbol = key_symbol(key)
    return f"${symbol}$" if symbol else key


def _tick(key: str, ranges: dict) -> str:
    """A parameter under its bars: its symbol and the range it was varied over."""
    if key not in ranges:
        return _name(key)
    low, high, log = ranges[key]
    return f"{_name(key)}\n[{low:.3g}, {high:.3g}]" + (" log" if log else "")


def clipped(heights, errors, bounds: tuple[float, float]) -> tuple[np.ndarray, np.ndarray | None]:
    """Bars and their symmetric errors within ``bounds``: the heights clipped, and the errors
    as (below, above) so that each interval ends inside (None without errors)."""
    lo, hi = bounds
    raw = np.asarray(heights, dtype=float)
    shown = np.clip(raw, lo, hi)
    if errors is None:
        return shown, None
    err = np.abs(np.asarray(errors, dtype=float))
    below = np.clip(np.minimum(raw - err, hi), lo, hi)
    above = np.clip(np.maximum(raw + err, lo), lo, hi)
    return shown, np.array([shown - below, above - shown])


def plot_indices(method: str, rows: list[dict], path: Path, parameters=(),
                 declared: dict | None = None) -> Path:
    """Draw the ``rows`` of :func:`rodfem.studies.sensitivity.indices.analyse` into ``path`` (whole or not
    at all, in the format of its suffix). ``parameters``: the study's
    (:class:`rodfem.studies.sweep.parameters.Parameter`), whose ranges label the bars; ``declared``:
    the declared measures' specs, which name the panels."""
    measures = list(dict.fromkeys(row["measure"] for row in rows))
    ranges = {p.key: (p.low, p.high, p.log) for p in parameters}
    bounds = BOUNDS[method]
    with style.mpl_fonts():
        fig = Figure(figsize=(style.MPL_SIZE[0], 1.9 + 3.2 * len(measures)),
                     dpi=style.MPL_DPI, layout="constrained")
        axes = fig.subplots(len(measures), 1, squeeze=False)[:, 0]
        for ax, measure in zip(axes, measures, strict=True):
            mine = [row for row in rows if row["measure"] == measure]
            x = np.arange(len(mine))
            width = 0.8 / len(BARS[method])
            for k, (column, conf, label) in enumerate(BARS[method]):
                heights, errors = clipped([row[column] for row in mine],
                                          [row[conf] for row in mine] if conf else None, bounds)
                ax.bar(x + (k - 0.5 * (len(BARS[method]) - 1)) * width, heights, width,
                       yerr=errors, capsize=4, label=label, color=style.colour(k))
            ax.set_xticks(x, [_tick(row["parameter"], ranges) for row in mine])
            ax.axhline(0.0, color="0.3", linewidth=0.8)
            ax.set_title(names.measure_title(measure, declared))
            ax.grid(axis="y", alpha=0.3)
            if method == "sobol":
                ax.set_ylim(0.0, 1.05)
                ax.set_ylabel("index (share of the variance)")
            else:
                ax.set_ylim(bottom=0.0)
                label = names.measure_label(measure, declared)  # the measure's unit, if any
                unit = label[label.rindex(" [$"):] if label.endswith("$]") else ""
                ax.set_ylabel("effect over a parameter's range" + unit)
        axes[0].legend(loc="best", fontsize=style.MPL_LEGEND_SIZE)
        if method == "sobol":
            fig.supxlabel(CLIPPED, fontsize=style.MPL_TICK_SIZE, color="0.2", wrap=True)
        return figures.save(fig, path, dpi=style.MPL_DPI)
