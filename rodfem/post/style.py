"""What every still figure shares: sizes, colours and fonts (the figures are drawn with
matplotlib; only the animations of ``rodfem plot`` with VTK, :mod:`rodfem.post.animation`).

Symbols are written in mathtext (``$\\sigma(1, t)$``), which matplotlib typesets, as the paper
writes them.
"""

from __future__ import annotations

import contextlib

import matplotlib
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import ListedColormap, LogNorm, Normalize
from matplotlib.ticker import MaxNLocator

from rodfem.output import names
from rodfem.post.choice import logarithmic
from rodfem.post.runs import Run

WINDOW = (1200, 900)  # pixels, for the still figures
# Run colours (matplotlib's tab10).
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
           "tab:pink", "tab:gray", "tab:olive", "tab:cyan")
# Runs coloured by a value: viridis, dark blue (low) to green, without its last 15 %, whose
# yellows are too light to read as lines on white.
SEQUENTIAL = ListedColormap(matplotlib.colormaps["viridis"](np.linspace(0.0, 0.85, 256)),
                            name="viridis_dark")
# Intervals of contact of a single run, in a neutral grey that no run colour uses.
CONTACT_SHADE = "0.87"
# The figures' size (inches, at MPL_DPI: WINDOW's pixels), fonts in points.
MPL_SIZE, MPL_DPI = (WINDOW[0] / 100, WINDOW[1] / 100), 100
MPL_LINE_WIDTH = 2.0
MPL_TITLE_SIZE, MPL_LABEL_SIZE, MPL_TICK_SIZE, MPL_LEGEND_SIZE = 15, 15, 12, 13


def colour(i: int) -> str:
    """The colour of the i-th run."""
    return COLOURS[i % len(COLOURS)]


@contextlib.contextmanager
def mpl_fonts():
    """matplotlib's font sizes for the figures drawn inside (and saved inside) the block."""
    with matplotlib.rc_context({"font.size": MPL_TICK_SIZE, "axes.titlesize": MPL_TITLE_SIZE,
                                "axes.labelsize": MPL_LABEL_SIZE, "xtick.labelsize": MPL_TICK_SIZE,
                                "ytick.labelsize": MPL_TICK_SIZE}):
        yield


def key_label(key: str | None) -> str:
    """A scene key for a colour bar: its paper's symbol and the key, ``$\\zeta$ (model.zeta)``
    (:func:`rodfem.output.names.key_label`)."""
    return names.key_label(key) if key is not None else "None"


def run_colours(runs: list[Run], key: str | None,
                log: bool = False) -> tuple[list, ScalarMappable | None]:
    """The runs' line colours: tab10 in turn, or (``key``) the sequential map over the runs'
    values of that scene key, on a log scale where they are positive and laid out so (``log``:
    a sweep's log-spaced axis) or span two decades or more, with the mappable its colour bar
    draws."""
    if key is None:
        return [colour(i) for i in range(len(runs))], None
    values = np.array([float(run.scene[key]) for run in runs])
    lo, hi = float(values.min()), float(values.max())
    if logarithmic(values, log) and hi > lo:
        norm = LogNorm(lo, hi)
    else:
        if lo == hi:  # one value: the middle of the map
            lo, hi = lo - max(abs(lo), 1.0) / 2, hi + max(abs(hi), 1.0) / 2
        norm = Normalize(lo, hi)
    mappable = ScalarMappable(norm=norm, cmap=SEQUENTIAL)
    return [mappable.to_rgba(v) for v in values], mappable


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
