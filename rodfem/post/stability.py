"""Figures of a stability map (``rodfem stability``): one per method, from ``stability.csv``.

Each figure has one panel per (a, ζ): the (Δt, ε) plane on log axes, each point marked as
converged with a non-increasing energy, converged with an energy increase, or failed, and the two
predicted boundaries of Picard's iteration, the paper's ε = Δt/ζ (Δt < εζ) and the compliance's
ε = w(Δt) (w/ε < 1). Reads the map's files only; imports nothing from the solver side.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pyvista as pv

from rodfem.post import backend, style
from rodfem.post.runs import PlotError

TEXT = {"method", "status", "error"}
FLAGS = {"converged", "energy_non_increasing", "paper_predicts", "w_predicts"}
TITLES = {"picard": "Picard iteration (3.3)-(3.4)", "newton": "Newton's method (SNES)",
          "direct": "direct solve"}
# marker: (label, colour, chart style, Unicode symbol for the key)
MARKERS = {
    "good": ("converged, energy non-increasing", "tab:green", "o", "●"),
    "rising": ("converged, energy increases", "tab:orange", "d", "◆"),
    "failed": ("failed", "tab:red", "x", "✕"),
}
PAPER_LINE = ("paper's condition: ε = Δt/ζ  (Δt < εζ above it)", "black")
W_LINE = ("compliance: ε = w(Δt)  (w/ε < 1 above it)", "tab:blue")
PANEL = (620, 560)  # pixels per panel
KEY_HEIGHT = 170
MARKER_SIZE = 12


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


def _decades(lo: float, hi: float) -> np.ndarray:
    return 10.0 ** np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)


def _log_axis(axis, lo: float, hi: float) -> None:
    """A log axis over [lo, hi] with ticks at the powers of ten, labelled 1e-4 … (a log axis
    takes its tick positions as log10 of the values)."""
    axis.log_scale = True
    axis.range = [lo, hi]
    ticks = _decades(lo, hi)
    ticks = ticks[(ticks >= lo) & (ticks <= hi)]
    axis.tick_locations = np.log10(ticks)
    axis.tick_labels = [f"{t:.0e}".replace("e-0", "e-").replace("e+00", "") for t in ticks]


def _panel(rows: list[dict], zeta: float, a: float, x_range, y_range) -> pv.Chart2D:
    title = f"ζ = {zeta:g}, a = {a:g}"
    if zeta == 0:
        title += "  (Δt < εζ never holds)"
    chart = style.chart(title, r"$\Delta t$", r"$\varepsilon$")
    style.use_font(chart.GetTitleProperties())
    _log_axis(chart.x_axis, *x_range)
    _log_axis(chart.y_axis, *y_range)
    for name, (label, colour, marker, _) in MARKERS.items():
        chosen = [r for r in rows if _category(r) == name]
        if chosen:
            points = chart.scatter([r["dt"] for r in chosen], [r["epsilon"] for r in chosen],
                                   color=colour, size=MARKER_SIZE, style=marker, label=label)
            points.pen.width = 2.5  # the lines of the crosses
    # Picard's two predicted boundaries, on every method's map for comparison
    dts = np.array(sorted({r["dt"] for r in rows}))
    w = np.array([next(r["w"] for r in rows if r["dt"] == dt) for dt in dts])
    chart.line(dts, w, color=W_LINE[1], width=style.LINE_WIDTH, label=W_LINE[0])
    if zeta > 0:  # ε = Δt/ζ, clipped to the plot's ε range
        lo, hi = max(x_range[0], zeta * y_range[0]), min(x_range[1], zeta * y_range[1])
        if lo < hi:
            chart.line([lo, hi], [lo / zeta, hi / zeta], color=PAPER_LINE[1],
                       width=style.LINE_WIDTH, style="--", label=PAPER_LINE[0])
    chart.legend_visible = False
    return chart


def _key(plotter: pv.Plotter, title: str, subtitle: str) -> None:
    """The figure's title, and the key to its markers (one row) and lines (another), in the top
    strip."""
    width = plotter.window_size[0]
    rows = [(title, 0, KEY_HEIGHT - 38, 16, "black"), (subtitle, 0, KEY_HEIGHT - 68, 11, "black")]
    markers = [(f"{symbol}  {label}", colour) for label, colour, _, symbol in MARKERS.values()]
    lines = [("- - -  " + PAPER_LINE[0], PAPER_LINE[1]), ("——  " + W_LINE[0], W_LINE[1])]
    for y, entries in ((44, markers), (10, lines)):
        step = (width - 40) // len(entries)
        rows += [(text, i * step, y, 11, colour) for i, (text, colour) in enumerate(entries)]
    for text, x, y, size, colour in rows:
        actor = plotter.add_text(text, position=(20 + x, y), font_size=size, color=colour)
        style.use_font(actor.GetTextProperty())


def stability_figure(rows: list[dict], method: str, info: dict, path: Path) -> Path:
    """One method's map: a panel per (a, ζ), rows of a, columns of ζ."""
    rows = [r for r in rows if r["method"] == method]
    zetas = sorted({r["zeta"] for r in rows})
    alphas = sorted({r["a"] for r in rows})
    dts = [r["dt"] for r in rows]
    eps = [r["epsilon"] for r in rows]
    x_range = [min(dts) / 1.6, max(dts) * 1.6]
    y_range = [min(eps) / 2.5, max(eps) * 2.5]
    n_rows, n_cols = len(alphas) + 1, len(zetas)
    size = (max(PANEL[0] * n_cols, 1500), PANEL[1] * len(alphas) + KEY_HEIGHT)
    weights = [KEY_HEIGHT / PANEL[1]] + [1.0] * len(alphas)
    groups = [(0, np.s_[:])] if n_cols > 1 else None
    plotter = pv.Plotter(shape=(n_rows, n_cols), window_size=size, off_screen=True,
                         row_weights=weights, groups=groups, border=False)
    plotter.set_background("white")
    plotter.subplot(0, 0)
    converged = sum(r["converged"] for r in rows)
    _key(plotter, f"{TITLES.get(method, method)}: where it solves the scheme (3.1)-(3.2)",
         f"{info.get('scene', '')}, T = {info.get('grid', {}).get('end', '?')}, "
         f"{info.get('cells', '?')} cells, Picard tol {info.get('tol', '?')}, at most "
         f"{info.get('max_iterations', '?')} iterations per step; converged at {converged} of "
         f"{len(rows)} points")
    for i, a in enumerate(alphas):
        for j, zeta in enumerate(zetas):
            plotter.subplot(i + 1, j)
            panel = [r for r in rows if r["a"] == a and r["zeta"] == zeta]
            plotter.add_chart(_panel(panel, zeta, a, x_range, y_range))
    backend.save_image(plotter, path)
    plotter.close()
    return path


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
    backend.off_screen()
    methods = [m for m in ("picard", "newton", "direct") if any(r["method"] == m for r in rows)]
    return [stability_figure(rows, m, info, out / f"stability_{m}.{format}")
            for m in methods]
