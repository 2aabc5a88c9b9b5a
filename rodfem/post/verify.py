"""Log–log figures of ``rodfem verify`` and ``rodfem work-precision``, from their JSON files.

``orders_<scene>.png``: a row per error measure, the error against h (left) and against Δt
(right; for a scene file of adaptive steps, against their tolerance, slopes 1/2 and 1), a line
per (method, time scheme), with reference slopes 1 and 2; for a scene whose
ladder refines h and Δt together (the impact), one column, against h = Δt, with slopes 1/2 and 1
(its solution has kinks: orders below 1).
``measures_<scene>.png`` (a scene file's): a row per measure that changes from run to run, the
difference between successive runs of each ladder against the step, with slopes 1 and 2.
``workprecision_<scene>.png``: the error of u(1, ·) against the wall time of the run, a line per
(method, time scheme); for the impact, whose ladders also differ in the mass matrix, a line per
(mass, time scheme, method): the colour the mass, the line style the scheme, the marker the
method. Reads the commands' files only; imports nothing from the solver side.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyvista as pv

from rodfem.post import backend, style
from rodfem.post.runs import PlotError

# No "|" in a label: VTK's mathtext reads it as a column separator.
LABELS = {"u1_max": r"$\max_t \vert u(1,t) - u_{ref}(1,t)\vert$",
          "u1_l1": r"$\Vert u(1,\cdot) - u_{ref}(1,\cdot)\Vert_{L^1(0,T)}$",
          "u1_l2": r"$\Vert u(1,\cdot) - u_{ref}(1,\cdot)\Vert_{L^2(0,T)}$",
          "u_T": r"$\Vert u(\cdot,T) - u_{ref}(\cdot,T)\Vert_{L^2}$",
          "theta_T": r"$\Vert\theta(\cdot,T) - \theta_{ref}(\cdot,T)\Vert_{L^2}$"}
ROWS = ("u1_max", "u1_l1", "u_T", "theta_T")
# The ladders' directions, in the order of the figure's columns, and their axes.
DIRECTIONS = ("h", "dt", "h=dt", "tol")
X_LABELS = {"h": "$h$", "dt": r"$\Delta t$", "h=dt": r"$h = \Delta t$",
            "tol": "tolerance of the adaptive steps"}
NAMES = {"h": "h", "dt": "Δt", "h=dt": "h = Δt", "tol": "the tolerance"}
# Reference slopes other than 1 and 2: the impact's kinks (h = Δt), and a tolerance (the errors
# of paper5's soft obstacle fall as its power 0.4 to 0.6, docs/accuracy.md).
SLOPES = {"h=dt": (0.5, 1), "tol": (0.5, 1)}
LINE_STYLES = {"paper": "-", "crank-nicolson": "--"}
# The methods solve the same scheme, so their lines coincide: their markers differ in shape and
# size, the largest below, so that all show.
MARKERS = {"direct": ("o", 15), "newton": ("s", 10), "picard": ("d", 6)}
PANEL = (640, 470)


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


def _log_axis(axis, lo: float, hi: float) -> None:
    """A log axis over [lo, hi], ticks at the powers of ten (a log axis takes its tick
    positions as log10 of the values)."""
    axis.log_scale = True
    axis.range = [lo, hi]
    ticks = 10.0 ** np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)
    ticks = ticks[(ticks >= lo * (1 - 1e-9)) & (ticks <= hi * (1 + 1e-9))]
    if ticks.size < 4:  # a few decades: ticks at 1, 2, 5 of each
        ticks = np.array([m * 10.0 ** e for e in range(int(np.floor(np.log10(lo))),
                                                       int(np.ceil(np.log10(hi))) + 1)
                          for m in (1, 2, 5)])
        ticks = ticks[(ticks >= lo) & (ticks <= hi)]
    axis.tick_locations = np.log10(ticks)
    axis.tick_labels = [f"{t:.0e}".replace("e-0", "e-").replace("e+00", "").replace("e+0", "e")
                        for t in ticks]


def _range(values: list[float], pad: float) -> tuple[float, float] | None:
    v = np.array([x for x in values if math.isfinite(x) and x > 0])
    if v.size == 0:
        return None
    return float(v.min()) / pad, float(v.max()) * pad


def _adaptive(point: dict) -> bool:
    """Whether a work-precision point is of adaptive steps: it has a tolerance (a fixed-step
    point's is null in the file, nan once read)."""
    tolerance = point.get("tolerance")
    return tolerance is not None and math.isfinite(tolerance)


def _choices(points: list[dict]) -> list[tuple[str, str]]:
    return list(dict.fromkeys((p["method"], p["scheme"]) for p in points))


def _series(chart: pv.Chart2D, x: np.ndarray, y: np.ndarray, i: int, method: str,
            scheme: str, label: str) -> None:
    keep = np.isfinite(y) & (y > 0)
    if not keep.any():
        return
    chart.line(x[keep], y[keep], color=style.colour(i), width=style.LINE_WIDTH,
               style=LINE_STYLES.get(scheme, "-."), label=label)
    marker, size = MARKERS.get(method, ("x", 10))
    chart.scatter(x[keep], y[keep], color=style.colour(i), size=size, style=marker)


def _slopes(chart: pv.Chart2D, x_range: tuple[float, float], anchor: float,
            powers: tuple[float, float] = (1, 2)) -> None:
    """Reference lines C x^p, p in ``powers``, through (largest x, ``anchor``)."""
    x = np.array(x_range)
    for p, dash, colour in zip(powers, (":", "-."), ("black", "gray"), strict=True):
        chart.line(x, anchor * (x / x[1]) ** p, color=colour, width=2.0, style=dash,
                   label=f"slope {'1/2' if p == 0.5 else f'{p:g}'}")


def _step(point: dict, refined: str) -> float:
    """The step a ladder refines at a point: h, Δt, or the tolerance of adaptive steps."""
    if refined == "tol":
        return point["tolerance"]
    return point["dt"] if refined == "dt" else 1.0 / point["cells"]


def _panel(points: list[dict], measure: str, refined: str, legend: bool, title: str,
           exact: bool) -> pv.Chart2D | None:
    points = [p for p in points if p["refined"] == refined]
    steps = lambda ps: np.array([_step(p, refined) for p in ps])  # noqa: E731
    y_range = _range([p[measure] for p in points], 3.0)
    if not points or y_range is None:
        return None
    x_all = steps(points)
    x_range = (float(x_all.min()) / 1.3, float(x_all.max()) * 1.3)
    x_label = X_LABELS[refined]
    y_label = LABELS[measure].replace("{ref}", "{exact}") if exact else LABELS[measure]
    chart = style.chart(title, x_label, y_label)
    style.use_font(chart.GetTitleProperties())
    for i, (method, scheme) in enumerate(_choices(points)):
        mine = [p for p in points if (p["method"], p["scheme"]) == (method, scheme)]
        _series(chart, steps(mine), np.array([p[measure] for p in mine]), i, method, scheme,
                f"{method}, {scheme}")
    coarsest = [p[measure] for p in points if steps([p])[0] == x_all.max()
                and math.isfinite(p[measure])]
    if coarsest:
        _slopes(chart, x_range, 1.5 * max(coarsest), SLOPES.get(refined, (1, 2)))
    _log_axis(chart.x_axis, *x_range)
    _log_axis(chart.y_axis, *y_range)
    chart.legend_visible = legend
    if legend:
        chart.GetLegend().SetVerticalAlignment(chart.GetLegend().BOTTOM)
        chart.GetLegend().SetHorizontalAlignment(chart.GetLegend().RIGHT)
    return chart


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
    return _grid(rows, columns, path, lambda measure, refined, first: _panel(
        points, measure, refined, first, f"{scene}: refining {NAMES[refined]}, {fixed[refined]}",
        exact))


def _grid(rows: list[str], columns: list[str], path: Path, chart_of) -> Path:
    """A figure of panels, a row per measure and a column per direction refined:
    ``chart_of(measure, refined, first)`` draws one (None: the panel stays empty)."""
    plotter = pv.Plotter(shape=(len(rows), len(columns)),
                         window_size=(len(columns) * PANEL[0], len(rows) * PANEL[1]),
                         off_screen=True)
    for i, measure in enumerate(rows):
        for j, refined in enumerate(columns):
            chart = chart_of(measure, refined, (i, j) == (0, 0))
            if chart is not None:
                plotter.subplot(i, j)
                plotter.add_chart(chart)
    backend.save_image(plotter, path)
    plotter.close()
    return path


def _user_fixed(s: dict) -> dict[str, str]:
    """What a scene file's ladders keep fixed, for the panels' titles."""
    return {"h": f"tolerance {s['tolerance']:g}" if s["adaptive"] else f"Δt = {s['dt']:g}",
            "dt": f"{s['cells']} cells", "tol": f"{s['cells']} cells"}


def _differences(rows: list[dict], refined: str) -> tuple[np.ndarray, np.ndarray]:
    """A ladder's |m_k+1 − m_k| against the step of run k (nan where a run has no value)."""
    x = np.array([_step(r, refined) for r in rows[:-1]])
    values = np.array([r["value"] if r["status"] == "complete" else math.nan for r in rows],
                      float)
    return x, np.abs(np.diff(values))


def _measure_panel(rows: list[dict], order: dict, refined: str, title: str,
                   legend: bool) -> pv.Chart2D | None:
    """One measure's differences between successive runs of a ladder, log-log, with slopes."""
    x, d = _differences(rows, refined)
    y_range = _range(list(d), 3.0)
    if x.size == 0 or y_range is None:
        return None
    x_range = (float(x.min()) / 1.3, float(x.max()) * 1.3)
    told = f"order {order['order']:.2f}" if math.isfinite(order["order"]) else \
        f"no order\n({order['note']})"  # on a line of its own: a panel is too narrow for both
    chart = style.chart(f"{order['measure']}: {told}", f"{X_LABELS[refined]} ({title})",
                        r"$\vert m_{k+1} - m_k\vert$")
    style.use_font(chart.GetTitleProperties())
    _series(chart, x, d, 0, rows[0]["method"], rows[0]["scheme"],
            f"{rows[0]['method']}, {rows[0]['scheme']}")
    if np.isfinite(d[0]) and d[0] > 0:
        _slopes(chart, x_range, 1.5 * float(d[0]), SLOPES.get(refined, (1, 2)))
    _log_axis(chart.x_axis, *x_range)
    _log_axis(chart.y_axis, *y_range)
    chart.legend_visible = legend
    return chart


def measures_figure(data: dict, scene: str, path: Path) -> Path | None:
    """A scene file's measures: for each measure that changes from run to run (a row) and each
    ladder (a column), the difference between successive runs against the step, log-log, with
    slopes 1 and 2: a measure of order p falls along slope p. None if no measure changes."""
    orders = [r for r in data.get("measure_orders", []) if r["scene"] == scene]
    measured = [r for r in data.get("measures", []) if r["scene"] == scene]
    columns = [d for d in DIRECTIONS if any(r["refined"] == d for r in orders)]
    rows = [m for m in dict.fromkeys(r["measure"] for r in orders)
            if any(r["measure"] == m and r["note"] not in ("integer", "the same in every run")
                   for r in orders)]
    if not rows or not columns:
        return None
    fixed = _user_fixed(data["scenes"][scene])

    def chart_of(measure: str, refined: str, first: bool) -> pv.Chart2D | None:
        mine = [r for r in measured if (r["measure"], r["refined"]) == (measure, refined)]
        order = next(r for r in orders if (r["measure"], r["refined"]) == (measure, refined))
        return _measure_panel(mine, order, refined, fixed[refined], first)

    return _grid(rows, columns, path, chart_of)


def work_precision_figure(data: dict, scene: str, path: Path) -> Path:
    """Error of u(1, ·) (max over [0, T]) against wall time, a line per (method, scheme), of
    fixed steps or adaptive ones."""
    points = [p for p in data["points"] if p["scene"] == scene and p["status"] == "complete"]
    x_range = _range([p["seconds"] for p in points], 1.4)
    y_range = _range([p["u1_max"] for p in points], 2.0)
    if x_range is None or y_range is None:
        raise PlotError(f"no completed run of {scene} to draw")
    target = data.get("target")
    if target and scene in data.get("target_scenes", []):
        y_range = (min(y_range[0], target / 2), max(y_range[1], target * 2))
    chart = style.chart(f"{scene}, T = {data['end']:g}: error of u(1, ·) against wall time",
                        "wall time of the run (s): set-up + time loop", LABELS["u1_max"])
    style.use_font(chart.GetTitleProperties())
    ladder = lambda p: (p["method"], p["scheme"], _adaptive(p))  # noqa: E731
    for i, (method, scheme, adaptive) in enumerate(dict.fromkeys(map(ladder, points))):
        mine = [p for p in points if ladder(p) == (method, scheme, adaptive)]
        _series(chart, np.array([p["seconds"] for p in mine]),
                np.array([p["u1_max"] for p in mine]), i, method, scheme,
                f"{method}, {scheme}" + (", adaptive" if adaptive else ""))
    if target and scene in data.get("target_scenes", []):
        chart.line(list(x_range), [target, target], color="black", width=2.0, style=":",
                   label=f"error {target:g}")
    _log_axis(chart.x_axis, *x_range)
    _log_axis(chart.y_axis, *y_range)
    chart.GetLegend().SetVerticalAlignment(chart.GetLegend().TOP)
    chart.GetLegend().SetHorizontalAlignment(chart.GetLegend().RIGHT)
    return _save(chart, path, (1100, 800))


def _save(chart, path: Path, size: tuple[int, int]) -> Path:
    """One chart drawn off-screen into ``path``."""
    plotter = pv.Plotter(window_size=size, off_screen=True)
    plotter.add_chart(chart)
    backend.save_image(plotter, path)
    plotter.close()
    return path


# The impact's mass matrices, each a colour of its own (where the file does not list them).
MASSES = ("lumped", "consistent", "redistributed", "redistributed-lumped", "dispersion-free")


def impact_work_precision_figure(data: dict, path: Path) -> Path:
    """The impact's error u(1, ·) in L¹(0, T) against its exact solution, against wall time, a
    line per (mass, scheme, method): the colour the mass (adaptive steps a colour of their own),
    the line style the scheme, the marker the method."""
    points = [p for p in data["points"] if p["scene"] == "impact" and p["status"] == "complete"]
    x_range = _range([p["seconds"] for p in points], 1.4)
    y_range = _range([p["u1_l1"] for p in points], 2.0)
    if x_range is None or y_range is None:
        raise PlotError("no completed run of impact to draw")
    # a legend of a dozen lines: the data in the top 3/5 of the plot, the legend below them
    y_range = (y_range[1] * (y_range[0] / y_range[1]) ** (5 / 3), y_range[1])
    end = data.get("plan", {}).get("impact_end", 3.0)
    chart = style.chart(f"impact, T = {end:g}, h = Δt: error of u(1, ·) against wall time\n"
                        "colour: mass; line: scheme; marker: method (● direct, ■ newton, "
                        "◆ picard)",
                        "wall time of the run (s): set-up + time loop",
                        LABELS["u1_l1"].replace("{ref}", "{exact}"))
    style.use_font(chart.GetTitleProperties())
    masses = list(data.get("plan", {}).get("impact_masses", MASSES))
    choice = lambda p: (p["mass"], p["scheme"], p["method"], _adaptive(p))  # noqa: E731
    for mass, scheme, method, adaptive in dict.fromkeys(choice(p) for p in points):
        mine = [p for p in points if choice(p) == (mass, scheme, method, adaptive)]
        colour = len(masses) + 1 if adaptive else \
            masses.index(mass) if mass in masses else len(masses)
        _series(chart, np.array([p["seconds"] for p in mine]),
                np.array([p["u1_l1"] for p in mine]), colour, method, scheme,
                f"{mass}, {scheme}, {method}" + (", adaptive" if adaptive else ""))
    _log_axis(chart.x_axis, *x_range)
    _log_axis(chart.y_axis, *y_range)
    chart.GetLegend().SetVerticalAlignment(chart.GetLegend().BOTTOM)
    chart.GetLegend().SetHorizontalAlignment(chart.GetLegend().LEFT)
    return _save(chart, path, (1300, 950))


def _work_precision(data: dict, scene: str, path: Path) -> Path:
    if scene == "impact":
        return impact_work_precision_figure(data, path)
    return work_precision_figure(data, scene, path)


def _figures(directory: Path, name: str, draw, prefix: str, format: str = "png") -> list[Path]:
    data = read(Path(directory) / name)
    out = Path(directory) / "figures"
    out.mkdir(exist_ok=True)  # an OSError is a write error (exit code 4)
    backend.off_screen()
    scenes = dict.fromkeys(p["scene"] for p in data["points"] if p["status"] == "complete")
    return [draw(data, s, out / f"{prefix}_{s}.{format}") for s in scenes]


def plot_orders(directory: Path, format: str = "png") -> list[Path]:
    """orders_<scene>.png for every scene in ``directory``/orders.json, into figures/, and
    measures_<scene>.png for every scene file's measures (or .pdf, .svg: ``format``)."""
    written = _figures(directory, "orders.json", orders_figure, "orders", format)
    data = read(Path(directory) / "orders.json")
    for scene in data.get("user", []):
        path = measures_figure(data, scene, Path(directory) / "figures"
                                / f"measures_{scene}.{format}")
        written += [path] if path is not None else []
    return written


def plot_work_precision(directory: Path, format: str = "png") -> list[Path]:
    """workprecision_<scene>.png (or .pdf, .svg: ``format``) for every scene in
    ``directory``/workprecision.json."""
    return _figures(directory, "workprecision.json", _work_precision, "workprecision", format)
