"""Log–log figures of ``rodfem verify``, from its JSON file (``rodfem work-precision``'s are in
:mod:`rodfem.post.workprecision`), drawn with matplotlib: vectors in PDF and SVG.

``orders_<scene>.png`` (or .pdf, .svg): a row per error measure, the error against h (left) and
against Δt (right; for a scene file of adaptive steps, against their tolerance, slopes 1/2 and 1),
a line per (method, time scheme), with reference slopes 1 and 2; for a scene whose ladder refines
h and Δt together (the impact), one column, against h = Δt, with slopes 1/2 and 1 (its solution
has kinks: orders below 1).
``measures_<scene>.png`` (a scene file's): a row per measure that changes from run to run, the
difference between successive runs of each ladder against the step, with slopes 1 and 2.
Every axis of a quantity with a dimension names its unit (:mod:`rodfem.output.names`): h in L,
Δt in t₀, the errors in the units of their norms. Reads the commands' files only; imports nothing
from the solver side.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output import figures
from rodfem.output.names import MEASURES, with_unit
from rodfem.post import style
from rodfem.post.runs import PlotError

# The errors (absolute, against a reference or exact solution) and the units of their norms: x in
# L, t in t₀, θ without a scale.
LABELS = {"u1_max": with_unit(r"$\max_t \vert u(1,t) - u_{ref}(1,t)\vert$", "L"),
          "u1_l1": with_unit(r"$\Vert u(1,\cdot) - u_{ref}(1,\cdot)\Vert_{L^1(0,T)}$",
                             r"L\,t_0"),
          "u1_l2": with_unit(r"$\Vert u(1,\cdot) - u_{ref}(1,\cdot)\Vert_{L^2(0,T)}$",
                             r"L\,t_0^{1/2}"),
          "u_T": with_unit(r"$\Vert u(\cdot,T) - u_{ref}(\cdot,T)\Vert_{L^2}$", "L^{3/2}"),
          "theta_T": with_unit(r"$\Vert\theta(\cdot,T) - \theta_{ref}(\cdot,T)\Vert_{L^2}$",
                               "L^{1/2}")}
ROWS = ("u1_max", "u1_l1", "u_T", "theta_T")
# The ladders' directions, in the order of the figure's columns, and their axes.
DIRECTIONS = ("h", "dt", "h=dt", "tol")
X_LABELS = {"h": with_unit("$h$", "L"), "dt": with_unit(r"$\Delta t$", "t_0"),
            "h=dt": with_unit("$h$", "L") + " " + with_unit(r"$= \Delta t$", "t_0"),
            "tol": "tolerance of the adaptive steps"}
NAMES = {"h": "h", "dt": "Δt", "h=dt": "h = Δt", "tol": "the tolerance"}
# Reference slopes other than 1 and 2: the impact's kinks (h = Δt), and a tolerance (the errors
# of paper5's soft obstacle fall as its power 0.4 to 0.6, docs/accuracy.md).
SLOPES = {"h=dt": (0.5, 1), "tol": (0.5, 1)}
LINE_STYLES = {"paper": "-", "crank-nicolson": "--"}
# The methods solve the same scheme, so their lines coincide: their markers differ in shape and
# size (points), the largest below, so that all show.
MARKERS = {"direct": ("o", 10), "newton": ("s", 7), "picard": ("d", 4.5)}
PANEL = (6.4, 4.7)  # inches per panel
# The notes of measures whose differences are not drawn: they do not change, or are set by the
# steps (rodfem.studies.asymptotic.STEPPED), so that no slope applies to them.
NO_FIGURE = ("integer", "the same in every run", "set by the steps, no order")


def read(path: Path) -> dict:
    """A command's JSON, nulls (non-finite numbers) back to nan."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None
    for p in (*data.get("points", []), *data.get("measures", []),
              *data.get("measure_orders", [])):
        for k, v in p.items():
            if v is None:
                p[k] = math.nan
    return data


def log_axes(ax, x_range: tuple[float, float], y_range: tuple[float, float]) -> None:
    """Both axes logarithmic over the ranges given, with a light grid."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(*x_range)
    ax.set_ylim(*y_range)
    ax.grid(True, which="major", alpha=0.3)


def value_range(values: list[float], pad: float) -> tuple[float, float] | None:
    """[min / pad, max · pad] of the finite positive values (None if there are none)."""
    v = np.array([x for x in values if math.isfinite(x) and x > 0])
    if v.size == 0:
        return None
    return float(v.min()) / pad, float(v.max()) * pad


def adaptive(point: dict) -> bool:
    """Whether a work-precision point is of adaptive steps: it has a tolerance (a fixed-step
    point's is null in the file, nan once read)."""
    tolerance = point.get("tolerance")
    return tolerance is not None and math.isfinite(tolerance)



def _choices(points: list[dict]) -> list[tuple[str, str]]:
    return list(dict.fromkeys((p["method"], p["scheme"]) for p in points))


def series(ax, x: np.ndarray, y: np.ndarray, i: int, method: str, scheme: str,
           label: str) -> None:
    """A line of the finite positive values, coloured by ``i``, styled by the scheme and marked
    by the method."""
    keep = np.isfinite(y) & (y > 0)
    if not keep.any():
        return
    marker, size = MARKERS.get(method, ("x", 7))
    ax.plot(x[keep], y[keep], color=style.colour(i), linewidth=style.MPL_LINE_WIDTH,
            linestyle=LINE_STYLES.get(scheme, "-."), marker=marker, markersize=size,
            markerfacecolor="none" if method == "direct" else style.colour(i), label=label)


def slopes(ax, x_range: tuple[float, float], anchor: float,
           powers: tuple[float, float] = (1, 2)) -> None:
    """Reference lines C x^p, p in ``powers``, through (largest x, ``anchor``)."""
    x = np.array(x_range)
    for p, dash, colour in zip(powers, (":", "-."), ("black", "gray"), strict=True):
        ax.plot(x, anchor * (x / x[1]) ** p, color=colour, linewidth=1.5, linestyle=dash,
                label=f"slope {'1/2' if p == 0.5 else f'{p:g}'}")


def _step(point: dict, refined: str) -> float:
    """The step a ladder refines at a point: h, Δt, or the tolerance of adaptive steps."""
    if refined == "tol":
        return point["tolerance"]
    return point["dt"] if refined == "dt" else 1.0 / point["cells"]


def _panel(ax, points: list[dict], measure: str, refined: str, legend: bool, title: str,
           exact: bool) -> bool:
    """One measure's errors against one ladder's step into ``ax``; False if it has none."""
    points = [p for p in points if p["refined"] == refined]
    steps = lambda ps: np.array([_step(p, refined) for p in ps])  # noqa: E731
    y_range = value_range([p[measure] for p in points], 3.0)
    if not points or y_range is None:
        return False
    x_all = steps(points)
    x_range = (float(x_all.min()) / 1.3, float(x_all.max()) * 1.3)
    for i, (method, scheme) in enumerate(_choices(points)):
        mine = [p for p in points if (p["method"], p["scheme"]) == (method, scheme)]
        series(ax, steps(mine), np.array([p[measure] for p in mine]), i, method, scheme,
               f"{method}, {scheme}")
    coarsest = [p[measure] for p in points if steps([p])[0] == x_all.max()
                and math.isfinite(p[measure])]
    if coarsest:
        slopes(ax, x_range, 1.5 * max(coarsest), SLOPES.get(refined, (1, 2)))
    log_axes(ax, x_range, y_range)
    ax.set_title(title)
    ax.set_xlabel(X_LABELS[refined])
    ax.set_ylabel(LABELS[measure].replace("{ref}", "{exact}") if exact else LABELS[measure])
    if legend:
        ax.legend(loc="lower right", fontsize=style.MPL_TICK_SIZE)
    return True


def orders_figure(data: dict, scene: str, path: Path) -> Path:
    """A scene's errors against h and Δt (or h = Δt), a row per measure."""
    points = [p for p in data["points"] if p["scene"] == scene and p["status"] == "complete"]
    rows = [m for m in ROWS if any(math.isfinite(p.get(m, math.nan)) for p in points)]
    columns = [d for d in DIRECTIONS if any(p["refined"] == d for p in points)]
    plan = data["plan"]
    exact = scene in data.get("exact", ["manufactured"])
    if scene in data.get("user", []):  # a scene file's own ladders
        fixed = _user_fixed(data["scenes"][scene])
    elif exact and scene != "impact":  # a manufactured solution's ladders
        fixed = {"h": f"Δt = {plan['mms_h_dt']:g}", "dt": f"{plan['mms_dt_cells']} cells"}
    else:
        fixed = {"h": f"Δt = {plan['h_dt']:g}", "dt": f"{plan['dt_cells']} cells"}
    fixed["h=dt"] = f"T = {plan.get('impact_end', plan['end']):g}, exact solution"
    return _grid(rows, columns, path, lambda ax, measure, refined, first: _panel(
        ax, points, measure, refined, first,
        f"{scene}: refining {NAMES[refined]}, {fixed[refined]}", exact))


def _grid(rows: list[str], columns: list[str], path: Path, draw) -> Path:
    """A figure of panels, a row per measure and a column per direction refined:
    ``draw(ax, measure, refined, first)`` fills one (False: the panel is left out)."""
    with style.mpl_fonts():
        fig = Figure(figsize=(len(columns) * PANEL[0], max(len(rows), 1) * PANEL[1]),
                     dpi=style.MPL_DPI, layout="constrained")
        axes = fig.subplots(max(len(rows), 1), max(len(columns), 1), squeeze=False)
        for i, measure in enumerate(rows):
            for j, refined in enumerate(columns):
                if not draw(axes[i, j], measure, refined, (i, j) == (0, 0)):
                    axes[i, j].set_axis_off()
        return figures.save(fig, path, dpi=style.MPL_DPI)


def _user_fixed(s: dict) -> dict[str, str]:
    """What a scene file's ladders keep fixed, for the panels' titles."""
    h_tolerance = s.get("h_tolerance", s["tolerance"])  # older files: the scene's own
    return {"h": f"tolerance {h_tolerance:g}" if s["adaptive"] else f"Δt = {s['dt']:g}",
            "dt": f"{s['cells']} cells", "tol": f"{s['cells']} cells"}


def _differences(rows: list[dict], refined: str) -> tuple[np.ndarray, np.ndarray]:
    """A ladder's |m_k+1 − m_k| against the step of run k (nan where a run has no value)."""
    x = np.array([_step(r, refined) for r in rows[:-1]])
    values = np.array([r["value"] if r["status"] == "complete" else math.nan for r in rows],
                      float)
    return x, np.abs(np.diff(values))


def difference_label(measure: str) -> str:
    """The axis of a measure's differences, in the measure's unit (a built-in measure's, from
    :mod:`rodfem.output.names`; a declared measure's is its column's, which orders.json does
    not hold, so the axis says so)."""
    text = r"$\vert m_{k+1} - m_k\vert$"
    if measure in MEASURES:
        return with_unit(text, MEASURES[measure][1])
    return text + " (in the measure's unit)"


def _measure_panel(ax, rows: list[dict], order: dict, refined: str, title: str,
                   legend: bool) -> bool:
    """One measure's differences between successive runs of a ladder, log-log, with slopes,
    into ``ax``; False if there is nothing to draw."""
    x, d = _differences(rows, refined)
    y_range = value_range(list(d), 3.0)
    if x.size == 0 or y_range is None:
        return False
    x_range = (float(x.min()) / 1.3, float(x.max()) * 1.3)
    # the note on a line of its own: a panel is too narrow for both
    told = f"no order\n({order['note']})" if not math.isfinite(order["order"]) else \
        f"order {order['order']:.2f}" + (f"\n({order['note']})" if order["note"] else "")
    series(ax, x, d, 0, rows[0]["method"], rows[0]["scheme"],
           f"{rows[0]['method']}, {rows[0]['scheme']}")
    if np.isfinite(d[0]) and d[0] > 0:
        slopes(ax, x_range, 1.5 * float(d[0]), SLOPES.get(refined, (1, 2)))
    log_axes(ax, x_range, y_range)
    ax.set_title(f"{order['measure']}: {told}")
    ax.set_xlabel(f"{X_LABELS[refined]} ({title})")
    ax.set_ylabel(difference_label(order["measure"]))
    if legend:
        ax.legend(loc="lower right", fontsize=style.MPL_TICK_SIZE)
    return True


def measures_figure(data: dict, scene: str, path: Path) -> Path | None:
    """A scene file's measures: for each measure that changes from run to run (a row) and each
    ladder (a column), the difference between successive runs against the step, log-log, with
    slopes 1 and 2: a measure of order p falls along slope p. None if no measure changes."""
    orders = [r for r in data.get("measure_orders", []) if r["scene"] == scene]
    measured = [r for r in data.get("measures", []) if r["scene"] == scene]
    columns = [d for d in DIRECTIONS if any(r["refined"] == d for r in orders)]
    rows = [m for m in dict.fromkeys(r["measure"] for r in orders)
            if any(r["measure"] == m and r["note"] not in NO_FIGURE for r in orders)]
    if not rows or not columns:
        return None
    fixed = _user_fixed(data["scenes"][scene])

    def draw(ax, measure: str, refined: str, first: bool) -> bool:
        mine = [r for r in measured if (r["measure"], r["refined"]) == (measure, refined)]
        order = next(r for r in orders if (r["measure"], r["refined"]) == (measure, refined))
        return _measure_panel(ax, mine, order, refined, fixed[refined], first)

    return _grid(rows, columns, path, draw)


def scene_figures(directory: Path, name: str, draw, prefix: str,
                  format: str = "png") -> list[Path]:
    """``draw(data, scene, path)`` for each scene with a complete point in ``directory``/``name``,
    into figures/<prefix>_<scene>.<format>."""
    data = read(Path(directory) / name)
    out = Path(directory) / "figures"
    out.mkdir(exist_ok=True)  # an OSError is a write error (exit code 4)
    scenes = dict.fromkeys(p["scene"] for p in data["points"] if p["status"] == "complete")
    return [draw(data, s, out / f"{prefix}_{s}.{format}") for s in scenes]


def plot_orders(directory: Path, format: str = "png") -> list[Path]:
    """orders_<scene>.png for every scene in ``directory``/orders.json, into figures/, and
    measures_<scene>.png for every scene file's measures (or .pdf, .svg: ``format``)."""
    written = scene_figures(directory, "orders.json", orders_figure, "orders", format)
    data = read(Path(directory) / "orders.json")
    for scene in data.get("user", []):
        path = measures_figure(data, scene, Path(directory) / "figures"
                                / f"measures_{scene}.{format}")
        written += [path] if path is not None else []
    return written
