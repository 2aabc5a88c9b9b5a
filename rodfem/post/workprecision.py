"""Work-precision figures of ``rodfem work-precision`` (``workprecision_<scene>.png``, or .pdf,
.svg), drawn with matplotlib from workprecision.json: the error of u(1, ·) against the wall time
of the run, a line per (method, time scheme); for the impact, whose ladders also differ in the
mass matrix, a line per (mass, time scheme, method): the colour the mass, the line style the
scheme, the marker the method, the key beside the plot. The error is in L (its maximum over
[0, T]) or L·t₀ (its L¹(0, T) norm), the time in seconds. Reads the command's file only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from rodfem.output import figures
from rodfem.post import style
from rodfem.post.runs import PlotError
from rodfem.post.verify import LABELS, adaptive, log_axes, scene_figures, series, value_range

TIME = r"wall time of the run, set-up + time loop [$\mathrm{s}$]"
# The impact's mass matrices, each a colour of its own (where the file does not list them).
MASSES = ("lumped", "consistent", "redistributed", "redistributed-lumped", "dispersion-free")


def figure(data: dict, scene: str, path: Path) -> Path:
    """The scene's work-precision figure: the impact's, or that of any other scene."""
    if scene == "impact":
        return impact_work_precision_figure(data, path)
    return work_precision_figure(data, scene, path)


def work_precision_figure(data: dict, scene: str, path: Path) -> Path:
    """Error of u(1, ·) (max over [0, T]) against wall time, a line per (method, scheme), of
    fixed steps or adaptive ones."""
    points = [p for p in data["points"] if p["scene"] == scene and p["status"] == "complete"]
    x_range = value_range([p["seconds"] for p in points], 1.4)
    y_range = value_range([p["u1_max"] for p in points], 2.0)
    if x_range is None or y_range is None:
        raise PlotError(f"no completed run of {scene} to draw")
    target = data.get("target")
    aimed = bool(target) and scene in data.get("target_scenes", [])
    if aimed:
        y_range = (min(y_range[0], target / 2), max(y_range[1], target * 2))
    with style.mpl_fonts():
        fig = Figure(figsize=(11.0, 8.0), dpi=style.MPL_DPI, layout="constrained")
        ax = fig.subplots()
        ladder = lambda p: (p["method"], p["scheme"], adaptive(p))  # noqa: E731
        for i, (method, scheme, steps) in enumerate(dict.fromkeys(map(ladder, points))):
            mine = [p for p in points if ladder(p) == (method, scheme, steps)]
            series(ax, np.array([p["seconds"] for p in mine]),
                   np.array([p["u1_max"] for p in mine]), i, method, scheme,
                   f"{method}, {scheme}" + (", adaptive" if steps else ""))
        if aimed:
            ax.plot(x_range, [target, target], color="black", linewidth=1.5, linestyle=":",
                    label=f"error {target:g}")
        log_axes(ax, x_range, y_range)
        ax.set_title(f"{scene}, T = {data['end']:g}: error of u(1, ·) against wall time")
        ax.set_xlabel(TIME)
        ax.set_ylabel(LABELS["u1_max"])
        ax.legend(loc="upper right", fontsize=style.MPL_LEGEND_SIZE)
        return figures.save(fig, path, dpi=style.MPL_DPI)


def impact_work_precision_figure(data: dict, path: Path) -> Path:
    """The impact's error u(1, ·) in L¹(0, T) against its exact solution, against wall time, a
    line per (mass, scheme, method): the colour the mass (adaptive steps a colour of their own),
    the line style the scheme, the marker the method; the key in a strip on the right."""
    points = [p for p in data["points"] if p["scene"] == "impact" and p["status"] == "complete"]
    x_range = value_range([p["seconds"] for p in points], 1.4)
    y_range = value_range([p["u1_l1"] for p in points], 2.0)
    if x_range is None or y_range is None:
        raise PlotError("no completed run of impact to draw")
    end = data.get("plan", {}).get("impact_end", 3.0)
    masses = list(data.get("plan", {}).get("impact_masses", MASSES))
    with style.mpl_fonts():
        fig = Figure(figsize=(15.0, 8.5), dpi=style.MPL_DPI, layout="constrained")
        ax, strip = fig.subplots(1, 2, gridspec_kw={"width_ratios": (3, 1.4)})
        choice = lambda p: (p["mass"], p["scheme"], p["method"], adaptive(p))  # noqa: E731
        for mass, scheme, method, steps in dict.fromkeys(choice(p) for p in points):
            mine = [p for p in points if choice(p) == (mass, scheme, method, steps)]
            colour = len(masses) + 1 if steps else \
                masses.index(mass) if mass in masses else len(masses)
            series(ax, np.array([p["seconds"] for p in mine]),
                   np.array([p["u1_l1"] for p in mine]), colour, method, scheme,
                   f"{mass}, {scheme}, {method}" + (", adaptive" if steps else ""))
        log_axes(ax, x_range, y_range)
        ax.set_title(f"impact, T = {end:g}, h = Δt: error of u(1, ·) against wall time")
        ax.set_xlabel(TIME)
        ax.set_ylabel(LABELS["u1_l1"].replace("{ref}", "{exact}"))
        strip.set_axis_off()
        strip.legend(*ax.get_legend_handles_labels(), loc="center left",
                     fontsize=style.MPL_TICK_SIZE, frameon=False,
                     title="colour: mass; line: scheme;\nmarker: method (○ direct, ■ newton, "
                           "◆ picard)", title_fontsize=style.MPL_TICK_SIZE)
        return figures.save(fig, path, dpi=style.MPL_DPI)


def plot_work_precision(directory: Path, format: str = "png") -> list[Path]:
    """workprecision_<scene>.png (or .pdf, .svg: ``format``) for every scene in
    ``directory``/workprecision.json."""
    return scene_figures(directory, "workprecision.json", figure, "workprecision", format)
