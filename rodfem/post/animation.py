"""``rod.gif``: the rod moving against the obstacle, coloured by temperature.

The rod is drawn at its deformed position, the material point x at x + s u(x, t), as a strip
coloured by θ(x, t), with a tick every tenth of its length so that strain shows as the ticks
crowd and spread. It is clamped at x = 0 (the wall on the left); the obstacle's face is at
x = 1 + s g, so that the end x = 1 touches it exactly where u(1, t) > g, and the penalty lets it
go in by s (u(1, t) − g) = −s ε σ(1, t).

The model is linear: its displacements need not be small against the rod's length (in the
paper's first experiment the midpoint moves by 0.6 and u_x reaches −1.56). Drawn as they are,
material points would pass each other; the scale s (1, 0.5, 0.2, 0.1, ...) keeps every piece of
the drawn rod at least half its length, 1 + s u_x ≥ 1/2, and the title states it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyvista as pv
from PIL import Image
from vtkmodules.util.numpy_support import numpy_to_vtk

from rodfem.output.atomic import replacing
from rodfem.post import style
from rodfem.post.runs import Run

MAX_FRAMES = 120
SECONDS = 10.0  # how long the animation plays, about
WINDOW = (960, 420)
HALF_WIDTH = 0.04  # half the strip's height, world units (the rod has length 1)
WALL, OBSTACLE = 0.08, 0.25  # widths of the clamp and of the obstacle
TICKS = np.linspace(0.0, 1.0, 11)
CONTACT_COLOUR, TEXT_COLOUR = "tab:red", "black"


def frame_indices(count: int, limit: int = MAX_FRAMES) -> np.ndarray:
    """Every k-th saved step (k as small as keeps at most ``limit`` frames), and the last one."""
    stride = max(1, math.ceil(count / limit))
    indices = np.arange(0, count, stride)
    if indices[-1] != count - 1:
        indices = np.append(indices[: limit - 1], count - 1)
    return indices


def displacement_scale(fields_x: np.ndarray, u: np.ndarray) -> float:
    """The largest of 1, 0.5, 0.2, 0.1, 0.05, ... with 1 + s u_x ≥ 1/2 at every saved step."""
    compression = float(-(np.diff(u, axis=1) / np.diff(fields_x)).min())
    if compression <= 0.5:
        return 1.0
    bound = 0.5 / compression
    decade = 10.0 ** math.floor(math.log10(bound))
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= bound)


def _strip(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points of the rod's strip: the lower edge then the upper edge, at x + u."""
    position = x + u
    lower = np.column_stack([position, np.full_like(x, -HALF_WIDTH), np.full_like(x, 0.01)])
    upper = lower * [1, -1, 1]
    return np.vstack([lower, upper])


def _ticks(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """End points of the material ticks below the strip."""
    position = np.interp(TICKS, x, x + u)
    top = np.column_stack([position, np.full_like(position, -HALF_WIDTH),
                           np.full_like(position, 0.02)])
    bottom = top - [0, 0.035, 0]
    return np.vstack([top, bottom])


def _rod_mesh(x: np.ndarray, u: np.ndarray, theta: np.ndarray) -> pv.PolyData:
    n = x.size
    quads = np.array([[4, i, i + 1, n + i + 1, n + i] for i in range(n - 1)]).ravel()
    rod = pv.PolyData(_strip(x, u), faces=quads)
    rod.point_data["θ"] = np.concatenate([theta, theta])
    return rod


def _tick_mesh(x: np.ndarray, u: np.ndarray) -> pv.PolyData:
    m = TICKS.size
    lines = np.array([[2, i, m + i] for i in range(m)]).ravel()
    return pv.PolyData(_ticks(x, u), lines=lines)


def _box(x0: float, x1: float, half_height: float) -> pv.PolyData:
    return pv.Rectangle([[x0, -half_height, 0.0], [x1, -half_height, 0.0],
                         [x1, half_height, 0.0]])


def _label(plotter: pv.Plotter, x: float, y: float, text: str, justify: str = "center") -> None:
    plotter.add_point_labels(
        np.array([[x, y, 0.05]]), [text], show_points=False, shape=None, font_size=16,
        text_color="black", always_visible=True, justification_horizontal=justify,
    )


def _scene(plotter: pv.Plotter, face: float, gap: float) -> pv.Actor:
    """Clamp, obstacle (face at x = ``face``), the rod's rest end x = 1 and the gap; returns the
    actor of the obstacle's face."""
    plotter.add_mesh(_box(-WALL, 0.0, 0.15), color="dimgray", lighting=False)
    plotter.add_mesh(_box(face, face + OBSTACLE, 0.15), color="silver", opacity=0.6,
                     lighting=False)
    face_actor = plotter.add_mesh(pv.Line((face, -0.15, 0.03), (face, 0.15, 0.03)),
                                  color="black", line_width=3)
    plotter.add_mesh(pv.Line((1.0, -0.2, 0.0), (1.0, 0.2, 0.0)), color="gray", line_width=1)
    plotter.add_mesh(pv.Line((1.0, 0.17, 0.0), (face, 0.17, 0.0)), color="black", line_width=2)
    _label(plotter, 1.0, -0.24, "x = 1")
    _label(plotter, face + 0.5 * OBSTACLE, 0.19, "obstacle")
    _label(plotter, 1.0 - 0.01, 0.19, f"gap g = {gap:g}", justify="right")
    return face_actor


def rod_animation(run: Run, run_label: str, path: Path) -> Path:
    """Write the animation of one run as a GIF.

    Args:
        run: the run.
        run_label: the run, for the title (plain text, drawn on every frame).
        path: the GIF to write.
    """
    fields, gap = run.fields, run.gap
    x, frames = fields.x, frame_indices(fields.t.size)
    scale = displacement_scale(x, fields.u)
    theta_range = [float(fields.theta.min()), float(fields.theta.max())]
    if theta_range[0] == theta_range[1]:
        theta_range[1] += 1.0

    plotter = pv.Plotter(window_size=WINDOW, off_screen=True)
    plotter.disable_anti_aliasing()  # 8 samples per pixel would triple the software render time
    plotter.set_background("white")
    rod = _rod_mesh(x, scale * fields.u[0], fields.theta[0])
    ticks = _tick_mesh(x, scale * fields.u[0])
    rod_actor = plotter.add_mesh(rod, scalars="θ", cmap="coolwarm", clim=theta_range,
                                 lighting=False, show_scalar_bar=False)
    plotter.add_mesh(ticks, color="black", line_width=2)
    face_actor = _scene(plotter, 1.0 + scale * gap, gap)
    bar = plotter.add_scalar_bar(
        title="θ(x, t)", mapper=rod_actor.mapper, vertical=False, position_x=0.25,
        position_y=0.02, width=0.5, height=0.14, title_font_size=18, label_font_size=16,
        color="black", fmt="%.3g",
    )
    style.use_font(bar.GetTitleTextProperty())
    bar.SetTextPositionToPrecedeScalarBar()  # tick labels below the bar, the title above
    bar.SetUseCustomLabels(True)
    bar.SetCustomLabels(numpy_to_vtk(style.ticks(*theta_range, count=6)))
    scaled = "" if scale == 1 else f", displacement drawn ×{scale:g}"
    texts = [plotter.add_text(text, position=(12, WINDOW[1] - 32 * (i + 1)), font_size=12,
                              color="black")
             for i, text in enumerate([run_label + scaled, "", ""])]
    for text in texts:
        style.use_font(text.GetTextProperty())
    clock, status = texts[1:]

    plotter.enable_parallel_projection()
    centre = (0.5 * (1 + OBSTACLE - WALL), 0.0, 0.0)
    plotter.camera.focal_point = centre
    plotter.camera.position = (centre[0], centre[1], 10.0)
    plotter.camera.up = (0.0, 1.0, 0.0)
    plotter.camera.parallel_scale = 0.36

    images, palette = [], None
    for k in frames:
        u, end = scale * fields.u[k], fields.u[k][-1]
        rod.points[:] = _strip(x, u)
        rod.point_data["θ"][:] = np.concatenate([fields.theta[k], fields.theta[k]])
        ticks.points[:] = _ticks(x, u)
        contact = end > gap
        colour = CONTACT_COLOUR if contact else TEXT_COLOUR
        clock.SetInput(f"t = {fields.t[k]:.3f}")
        status.SetInput(f"u(1, t) = {end:.3f}" + (" > g: in contact" if contact else ""))
        status.GetTextProperty().SetColor(pv.Color(colour).float_rgb)
        face_actor.prop.color = colour
        plotter.render()
        rgb = plotter.screenshot(return_img=True)[..., :3]
        if palette is None:
            palette = _palette(rgb)
        images.append(Image.fromarray(rgb).quantize(palette=palette, dither=Image.Dither.NONE))
    plotter.close()
    fps = min(20.0, max(4.0, len(images) / SECONDS))
    with replacing(path, "wb") as file:  # whole or not at all
        images[0].save(file, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    return path


def _palette(first: np.ndarray) -> Image.Image:
    """One palette of 256 colours for every frame, from the first frame (its colour bar holds
    every colour the rod can take) and the contact colour (which it may not show)."""
    red = np.array(pv.Color(CONTACT_COLOUR).int_rgb, dtype=np.uint8)
    strip = np.broadcast_to(red, (8, first.shape[1], 3))
    return Image.fromarray(np.vstack([first, strip])).quantize(
        colors=256, method=Image.Quantize.MEDIANCUT
    )
