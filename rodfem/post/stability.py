"""Figures of a stability map (``rodfem stability``): one per method, from ``stability.csv``.

Each figure has one panel per (a, ζ): the (Δt, ε) plane on log axes, each point marked as
converged with a non-increasing energy, converged with an energy increase, or failed, and the two
predicted boundaries of Picard's iteration, the paper's ε = Δt/ζ (Δt < εζ) and the compliance's
ε = w(Δt) (w/ε < 1), under the title and a key to the marks and lines; drawn with matplotlib
(vectors in PDF and SVG), Δt in t₀. Reads the map's files only; imports nothing from the solver
side.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rodfem.output import figures
from rodfem.output.names import with_unit
from rodfem.post import style
from rodfem.post.runs import PlotError

TEXT = {"method", "status", "error"}
FLAGS = {"converged", "energy_non_increasing", "paper_predicts", "w_predicts"}
TITLES = {"picard": "Picard iteration (3.3)-(3.4)", "newton": "Newton's method (SNES)",
          "direct": "direct solve"}
# category: (label, colour, marker)
MARKERS = {
    "good": ("converged, energy non-increasing", "tab:green", "o"),
    "rising": ("converged, energy increases", "tab:orange", "d"),
    "failed": ("failed", "tab:red", "x"),
}
PAPER_LINE = ("paper's condition: ε = Δt/ζ  (Δt < εζ above it)", "black")
W_LINE = ("compliance: ε = w(Δt)  (w/ε < 1 above it)", "tab:blue")
PANEL = (6.2, 5.6)  # inches per panel
KEY = 1.1  # inches: the key above the panels
MARKER_SIZE = 9


def read_rows(path: Path) -> list[dict]:
    """The rows of stability.csv, typed back (booleans, numbers, None for empty)."""
    rows = []
    try:
        with open(path, encoding="utf-8", newline="") as f:
            for raw in csv.DictReader(f):
                rows.append({k: (v if k in TEXT else v == "true" if k in FLAGS
                                 else float(v) if v != "" else None) for k, v in raw.items()})
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None
    if not rows:
        raise PlotError(f"{path} holds no points")
    return rows


def _category(row: dict) -> str:
    if not row["converged"]:
        return "failed"
    return "good" if row["energy_non_increasing"] else "rising"


def _panel(ax, rows: list[dict], zeta: float, a: float, x_range, y_range) -> None:
    """One (a, ζ)'s points by category on log axes, with Picard's two predicted boundaries."""
    title = f"ζ = {zeta:g}, a = {a:g}"
    if zeta == 0:
        title += "  (Δt < εζ never holds)"
    for name, (label, colour, marker) in MARKERS.items():
        chosen = [r for r in rows if _category(r) == name]
        if chosen:
            ax.plot([r["dt"] for r in chosen], [r["epsilon"] for r in chosen], linestyle="none",
                    marker=marker, markersize=MARKER_SIZE, color=colour, markeredgewidth=2.0,
                    label=label)
    # Picard's two predicted boundaries, on every method's map for comparison
    dts = np.array(sorted({r["dt"] for r in rows}))
    w = np.array([next(r["w"] for r in rows if r["dt"] == dt) for dt in dts])
    ax.plot(dts, w, color=W_LINE[1], linewidth=style.MPL_LINE_WIDTH, label=W_LINE[0])
    if zeta > 0:  # ε = Δt/ζ, clipped to the plot's ε range
        lo, hi = max(x_range[0], zeta * y_range[0]), min(x_range[1], zeta * y_range[1])
        if lo < hi:
            ax.plot([lo, hi], [lo / zeta, hi / zeta], color=PAPER_LINE[1],
                    linewidth=style.MPL_LINE_WIDTH, linestyle="--", label=PAPER_LINE[0])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(*x_range)
    ax.set_ylim(*y_range)
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(title)
    ax.set_xlabel(with_unit(r"$\Delta t$", "t_0"))
    ax.set_ylabel(r"$\varepsilon$")


def _key() -> list[Line2D]:
    """The key to every panel's markers and lines, whether a panel shows them or not."""
    marks = [Line2D([], [], linestyle="none", marker=marker, markersize=MARKER_SIZE,
                    markeredgewidth=2.0, color=colour, label=label)
             for label, colour, marker in MARKERS.values()]
    return marks + [Line2D([], [], color=PAPER_LINE[1], linestyle="--",
                           linewidth=style.MPL_LINE_WIDTH, label=PAPER_LINE[0]),
                    Line2D([], [], color=W_LINE[1], linewidth=style.MPL_LINE_WIDTH,
                           label=W_LINE[0])]


def stability_figure(rows: list[dict], method: str, info: dict, path: Path) -> Path:
    """One method's map: a panel per (a, ζ), rows of a, columns of ζ, under its title and the
    key to its markers and lines."""
    rows = [r for r in rows if r["method"] == method]
    zetas = sorted({r["zeta"] for r in rows})
    alphas = sorted({r["a"] for r in rows})
    dts = [r["dt"] for r in rows]
    eps = [r["epsilon"] for r in rows]
    x_range = [min(dts) / 1.6, max(dts) * 1.6]
    y_range = [min(eps) / 2.5, max(eps) * 2.5]
    converged = sum(r["converged"] for r in rows)
    with style.mpl_fonts():
        fig = Figure(figsize=(max(PANEL[0] * len(zetas), 11.0), PANEL[1] * len(alphas) + KEY),
                     dpi=style.MPL_DPI, layout="constrained")
        grid = fig.add_gridspec(len(alphas) + 1, len(zetas),
                                height_ratios=[KEY / PANEL[1]] + [1.0] * len(alphas))
        strip = fig.add_subplot(grid[0, :])
        strip.set_axis_off()
        strip.legend(handles=_key(), loc="center", ncol=2, frameon=False,
                     fontsize=style.MPL_TICK_SIZE)
        fig.suptitle(f"{TITLES.get(method, method)}: where it solves the scheme (3.1)-(3.2)\n"
                        f"{info.get('scene', '')}, T = {info.get('grid', {}).get('end', '?')}, "
                        f"{info.get('cells', '?')} cells, Picard tol {info.get('tol', '?')}, at "
                        f"most {info.get('max_iterations', '?')} iterations per step; converged "
                        f"at {converged} of {len(rows)} points", fontsize=style.MPL_LABEL_SIZE)
        for i, a in enumerate(alphas):
            for j, zeta in enumerate(zetas):
                panel = [r for r in rows if r["a"] == a and r["zeta"] == zeta]
                _panel(fig.add_subplot(grid[i + 1, j]), panel, zeta, a, x_range, y_range)
        return figures.save(fig, path, dpi=style.MPL_DPI)


def plot_stability(directory: Path, out: Path | None = None,
                   format: str = "png") -> list[Path]:
    """Draw stability_<method>.png (or .pdf, .svg: ``format``) for every method in
    ``directory``/stability.csv.

    Args:
        directory: written by ``rodfem stability``.
        out: the figure directory (default: ``directory``/figures), created if need be.
        format: png, pdf or svg.

    Returns:
        The files written.
    """
    directory = Path(directory)
    rows = read_rows(directory / "stability.csv")
    try:
        info = json.loads((directory / "stability.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        info = {}
    out = Path(out) if out is not None else directory / "figures"
    out.mkdir(parents=True, exist_ok=True)  # an OSError is a write error (exit code 4)
    methods = [m for m in ("picard", "newton", "direct") if any(r["method"] == m for r in rows)]
    return [stability_figure(rows, m, info, out / f"stability_{m}.{format}")
            for m in methods]
