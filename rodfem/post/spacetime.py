"""Space-time maps of the saved fields: u, θ and σ coloured over (t, x).

Time runs to the right and the rod's coordinate x upwards, so that the top edge of each map is
the end x = 1 that meets the obstacle. θ and u are P1 (linear between nodes: point data); σ is
constant per cell (cell data on cells that span the nodes in x and reach halfway to the
neighbouring saved times in t).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista as pv
from vtkmodules.util.numpy_support import numpy_to_vtk

from rodfem.post import backend, style
from rodfem.post.fields import CELL_FUNCTIONS, Fields

ASPECT = 1.35  # width / height of the map
# name: title, colour-bar title, colour map, centred on zero. Diverging maps are centred on zero,
# where zero means something: no stress, no velocity, no heat flux, and for θ the reference
# temperature, at which the rod is free of thermal stress (σ = u_x + ζu_xt − aθ) and which the
# medium at x = 1 has (−θ_x(1) = kθ(1)): red is warmer than it, blue colder. u is drawn on a
# sequential map: its sign is a direction, not a departure from a state.
MAPS = {
    "u": ("displacement u", "u(x, t)", "viridis", False),
    "theta": ("temperature θ", "θ(x, t)", "coolwarm", True),
    "sigma": ("stress σ", "σ(x, t)", "RdBu_r", True),
    "velocity": ("velocity u_t", "u_t(x, t)", "PuOr_r", True),
    "heat_flux": ("heat flux −θ_x", "−θ_x(x, t)", "PiYG", True),
}


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres: midpoints between them, the ends kept."""
    if centres.size == 1:
        return np.array([centres[0], centres[0] + 1.0])
    mid = 0.5 * (centres[1:] + centres[:-1])
    return np.concatenate([[centres[0]], mid, [centres[-1]]])


def _grid(fields: Fields, name: str, t0: float, t_scale: float) -> pv.RectilinearGrid:
    if name in CELL_FUNCTIONS:
        grid = pv.RectilinearGrid((_edges(fields.t) - t0) * t_scale, fields.x, np.zeros(1))
        # VTK orders cells (and points) with the first coordinate fastest: index = i_t + n_t i_x.
        grid.cell_data[name] = getattr(fields, name).ravel(order="F")
    else:
        grid = pv.RectilinearGrid((fields.t - t0) * t_scale, fields.x, np.zeros(1))
        grid.point_data[name] = getattr(fields, name).ravel(order="F")
    return grid


def spacetime_figure(fields: Fields, name: str, run_label: str, path: Path) -> Path:
    """Draw one field over (t, x) with labelled axes and a colour bar.

    Args:
        fields: the run's saved fields (those of a time window: :func:`fields_in_window`).
        name: a field of :data:`MAPS` the run saved.
        run_label: the run, for the title.
        path: the PNG to write.
    """
    title, bar_title, cmap, centred = MAPS[name]
    t0 = float(fields.t[0])
    t_end = float(fields.t[-1]) if fields.t[-1] > t0 else t0 + 1.0
    t_scale = ASPECT / (t_end - t0)
    grid = _grid(fields, name, t0, t_scale)
    values = getattr(fields, name)
    clim = [float(values.min()), float(values.max())]
    if centred:
        bound = max(abs(clim[0]), abs(clim[1]), 1e-300)
        clim = [-bound, bound]

    # No multisampling: the map's cells and axes are aligned with the pixels, and text is
    # smoothed by FreeType, so 8 samples a pixel would cost half the drawing for no change.
    plotter = pv.Plotter(window_size=style.WINDOW, off_screen=True)
    plotter.disable_anti_aliasing()
    plotter.set_background("white")
    plotter.add_mesh(grid, scalars=name, cmap=cmap, clim=clim, lighting=False,
                     show_scalar_bar=False)
    bar = plotter.add_scalar_bar(
        title=bar_title, vertical=True, position_x=0.84, position_y=0.14, height=0.72,
        width=0.05, title_font_size=style.LABEL_SIZE, label_font_size=style.TICK_SIZE,
        color="black", fmt="%.3g",
    )
    style.use_font(bar.GetTitleTextProperty()).SetItalic(True)
    bar.SetUseCustomLabels(True)
    bar.SetCustomLabels(numpy_to_vtk(style.ticks(*clim)))
    axes = plotter.show_bounds(
        bounds=[0, ASPECT, 0, 1, 0, 0], axes_ranges=[t0, t_end, 0, 1, 0, 0],
        xtitle="t", ytitle="x", show_zaxis=False, location="outer", color="black",
        font_size=style.TICK_SIZE, bold=False, n_xlabels=9, n_ylabels=6, fmt="%.3g",
        use_2d=True, ticks="outside",
    )
    for i in (0, 1):
        axes.GetTitleTextProperty(i).SetFontSize(style.LABEL_SIZE)
        axes.GetTitleTextProperty(i).SetItalic(True)
    text = plotter.add_text(f"{title}: {run_label}", position="upper_edge", font_size=12,
                            color="black")
    style.use_font(text.GetTextProperty())
    # Parallel projection framed on the map with room for the axis labels (left, below) and the
    # colour bar (right); VTK's parallel scale is half the visible height in world units.
    left, right, bottom, top = 0.14, 0.40, 0.14, 0.14
    width = ASPECT + left + right
    aspect = style.WINDOW[0] / style.WINDOW[1]
    centre = (0.5 * (ASPECT + right - left), 0.5 * (1 + top - bottom), 0.0)
    plotter.enable_parallel_projection()
    plotter.camera.focal_point = centre
    plotter.camera.position = (centre[0], centre[1], 10.0)
    plotter.camera.up = (0.0, 1.0, 0.0)
    plotter.camera.parallel_scale = max(width / aspect, 1 + top + bottom) / 2
    backend.save_image(plotter, path)
    plotter.close()
    return path
