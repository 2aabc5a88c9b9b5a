"""``rod.gif``: the rod moving against the obstacle, coloured by temperature.

The rod is drawn at its deformed position, the material point x at x + s u(x, t), as a strip
coloured by θ(x, t), with a tick every tenth of its length so that strain shows as the ticks
crowd and spread. It is clamped at x = 0 (the wall on the left). The obstacle's free face is at
x = 1 + s g, so that the end x = 1 touches it exactly where u(1, t) > g; the elastic obstacle
(the penalty) then gives way by s (u(1, t) − g) = −s ε σ(1, t): its face moves with the end,
its block, held at the right, is compressed (its hatching crowds), and a dashed line keeps the
face's rest position, so that the penetration is the gap between the two. The block is at least
twice as wide as the deepest penetration, so that it never closes.

The model is linear: its displacements need not be small against the rod's length (in the
paper's first experiment the midpoint moves by 0.6 and u_x reaches −1.56). Drawn as they are,
material points would pass each other; the scale s (1, 0.5, 0.2, 0.1, ...) keeps every piece of
the drawn rod at least half its length, 1 + s u_x ≥ 1/2, and the title states it.

Everything is opaque: translucency would make VTK peel depth layers, four times the cost of a
frame.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np
import pyvista as pv
from PIL import Image
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonCore import VTK_FONT_FILE
from vtkmodules.vtkRenderingCore import vtkTextProperty

from rodfem.output.atomic import replacing
from rodfem.post import style
from rodfem.post.runs import Run, fields_in_window

MAX_FRAMES = 60  # the paper's 161 saves: every third, 54 frames over SECONDS
SECONDS = 10.0  # how long the animation plays, about
WINDOW = (960, 420)
HALF_WIDTH = 0.04  # half the strip's height, world units (the rod has length 1)
WALL, OBSTACLE = 0.08, 0.25  # widths of the clamp and (at least) of the obstacle at rest
BLOCK = 0.15  # half the height of the clamp and of the obstacle
# Plain text with Greek letters (ζ, θ, σ) is drawn in matplotlib's DejaVu Sans: VTK's own fonts
# have none.
FONT_FILE = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
HATCHES = 9  # lines across the obstacle, evenly spaced between its face and its support
TICKS = np.linspace(0.0, 1.0, 11)
CONTACT_COLOUR, TEXT_COLOUR = "tab:red", "black"


def use_font(prop: vtkTextProperty) -> vtkTextProperty:
    """Draw a text property's plain (non-mathtext) text in DejaVu Sans, when matplotlib has it."""
    if FONT_FILE.is_file():
        prop.SetFontFamily(VTK_FONT_FILE)
        prop.SetFontFile(str(FONT_FILE))
    return prop


def frame_indices(times: np.ndarray | int, limit: int = MAX_FRAMES) -> np.ndarray:
    """The saved steps drawn: at most ``limit``, evenly spaced in time, and the last one.

    ``times``: the saved times (increasing), or their count for evenly spaced ones. Evenly spaced
    saves give every k-th (k as small as keeps at most ``limit``); saves at uneven times (an
    adaptive run's, crowded at contact events) give the one nearest each of as many times evenly
    spaced over the same span, each once."""
    t = np.arange(times, dtype=float) if np.ndim(times) == 0 else np.asarray(times, float)
    count = t.size
    stride = max(1, math.ceil(count / limit))
    indices = np.arange(0, count, stride)
    span = t[-1] - t[0] if count else 0.0
    if count > 1 and span > 0.0:
        wanted = t[0] + indices * (span / (count - 1))
        right = np.clip(np.searchsorted(t, wanted), 1, count - 1)
        nearer_left = wanted - t[right - 1] <= t[right] - wanted
        indices = np.unique(np.where(nearer_left, right - 1, right))
    if indices[-1] != count - 1:
        indices = np.append(indices[: limit - 1], count - 1)
    return indices


def frame_durations(times: np.ndarray, frames: np.ndarray) -> list[int] | int:
    """How long each frame shows, ms, given the saved ``times`` and the ``frames`` drawn of them:
    SECONDS over them all (between 4 and 20 frames a second), one number where the saves are
    evenly spaced; where they are not, each frame as long as the time it stands for (until the
    next frame; the last as long as the mean)."""
    fps = min(20.0, max(4.0, len(frames) / SECONDS))
    each = round(1000 / fps)
    saves = np.diff(np.asarray(times, float))
    if saves.size == 0 or np.allclose(saves, saves.mean(), rtol=1e-6, atol=0.0):
        return each
    gaps = np.diff(np.asarray(times, float)[frames])
    gaps = np.append(gaps, gaps.mean())
    # in GIF's unit, 10 ms, at least 2 (browsers show shorter frames for 100 ms)
    return [10 * max(2, round(each * len(frames) * gap / gaps.sum() / 10)) for gap in gaps]


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


class _Obstacle:
    """The obstacle: a block from its face to its support at ``back``, hatched, whose face
    follows the rod's end where the end goes in (u(1, t) > g)."""

    def __init__(self, plotter: pv.Plotter, rest: float, back: float):
        self.rest, self.back = rest, back
        self.block = _box(rest, back, BLOCK)
        self.front = self.block.points[:, 0] < 0.5 * (rest + back)  # the face's corners
        plotter.add_mesh(self.block, color="lightgray", lighting=False)
        self.hatch = pv.PolyData(self._hatch_points(rest),
                                 lines=np.array([[2, i, HATCHES + i] for i in range(HATCHES)]))
        plotter.add_mesh(self.hatch, color="gray", line_width=1, lighting=False)
        self.face = pv.Line((rest, -BLOCK, 0.03), (rest, BLOCK, 0.03))
        self.face_actor = plotter.add_mesh(self.face, color="black", line_width=3)

    def _hatch_points(self, face: float) -> np.ndarray:
        x = np.linspace(face, self.back, HATCHES + 2)[1:-1]
        return np.vstack([np.column_stack([x, np.full_like(x, y), np.full_like(x, 0.02)])
                          for y in (-BLOCK, BLOCK)])

    def move(self, face: float, colour: str) -> None:
        """Put the face at ``face`` (≥ its rest position) and draw it in ``colour``."""
        self.block.points[self.front, 0] = face
        self.hatch.points[:] = self._hatch_points(face)
        self.face.points[:, 0] = face
        self.face_actor.prop.color = colour


def _scene(plotter: pv.Plotter, rest: float, back: float, gap: float, kind: str) -> _Obstacle:
    """Clamp, obstacle (face at rest at x = ``rest``, support at ``back``), the rod's rest end
    x = 1 and the gap."""
    plotter.add_mesh(_box(-WALL, 0.0, BLOCK), color="dimgray", lighting=False)
    plotter.add_mesh(_box(back, back + 0.5 * WALL, BLOCK), color="dimgray", lighting=False)
    obstacle = _Obstacle(plotter, rest, back)
    dashes = np.linspace(-BLOCK - 0.03, BLOCK + 0.03, 12)
    plotter.add_mesh(pv.PolyData(np.column_stack([np.full(12, rest), dashes, np.full(12, 0.04)]),
                                 lines=np.array([[2, 2 * i, 2 * i + 1] for i in range(6)])),
                     color="black", line_width=1)  # the face at rest, dashed
    plotter.add_mesh(pv.Line((1.0, -0.165, 0.0), (1.0, 0.2, 0.0)), color="gray", line_width=1)
    plotter.add_mesh(pv.Line((1.0, 0.17, 0.0), (rest, 0.17, 0.0)), color="black", line_width=2)
    _label(plotter, 1.0, -0.185, "x = 1")  # above the colour bar
    _label(plotter, 0.5 * (rest + back), 0.19, f"{kind} obstacle")
    _label(plotter, 1.0 - 0.01, 0.19, f"gap g = {gap:g}", justify="right")
    return obstacle


def _theta_range(theta: np.ndarray) -> list[float]:
    """The colour range of θ, centred on the reference temperature θ = 0 (as the map of θ:
    see :data:`rodfem.post.spacetime.MAPS`)."""
    bound = float(np.abs(theta).max())
    return [-bound, bound] if bound > 0 else [-1.0, 1.0]


def rod_animation(run: Run, run_label: str, path: Path,
                  window: tuple[float, float] | None = None) -> Path:
    """Write the animation of one run as a GIF.

    Args:
        run: the run.
        run_label: the run, for the title (plain text, drawn on every frame).
        path: the GIF to write.
        window: the interval of time shown (its saved steps), or None for the whole run.
    """
    fields, gap = fields_in_window(run.fields, window), run.gap
    x, frames = fields.x, frame_indices(fields.t)
    scale = displacement_scale(x, fields.u)
    theta_range = _theta_range(fields.theta)
    rest = 1.0 + scale * gap
    depth = scale * max(0.0, float(fields.u[:, -1].max()) - gap)  # the deepest penetration
    back = rest + max(OBSTACLE, 2.0 * depth)

    plotter = pv.Plotter(window_size=WINDOW, off_screen=True)
    plotter.disable_anti_aliasing()  # 8 samples per pixel would triple the software render time
    plotter.set_background("white")
    rod = _rod_mesh(x, scale * fields.u[0], fields.theta[0])
    ticks = _tick_mesh(x, scale * fields.u[0])
    rod_actor = plotter.add_mesh(rod, scalars="θ", cmap="coolwarm", clim=theta_range,
                                 lighting=False, show_scalar_bar=False)
    plotter.add_mesh(ticks, color="black", line_width=2)
    kind = "rigid" if run.scene.get("obstacle.kind") == "rigid" else "elastic"
    obstacle = _scene(plotter, rest, back, gap, kind)
    bar = plotter.add_scalar_bar(
        title="θ(x, t)", mapper=rod_actor.mapper, vertical=False, position_x=0.25,
        position_y=0.02, width=0.5, height=0.14, title_font_size=18, label_font_size=16,
        color="black", fmt="%.3g",
    )
    use_font(bar.GetTitleTextProperty())
    bar.SetTextPositionToPrecedeScalarBar()  # tick labels below the bar, the title above
    bar.SetUseCustomLabels(True)
    bar.SetCustomLabels(numpy_to_vtk(style.ticks(*theta_range, count=6)))
    scaled = "" if scale == 1 else f", displacement drawn ×{scale:g}"
    texts = [plotter.add_text(text, position=(12, WINDOW[1] - 32 * (i + 1)), font_size=12,
                              color="black")
             for i, text in enumerate([run_label + scaled, "", ""])]
    for text in texts:
        use_font(text.GetTextProperty())
    clock, status = texts[1:]

    # Framed on [−clamp, support] with a margin; the parallel scale is half the visible height.
    # The centre is a little above the rod, so that the labels above the obstacle stay below
    # the three lines of text and "x = 1" above the colour bar.
    plotter.enable_parallel_projection()
    left, right = -WALL - 0.06, back + 0.5 * WALL + 0.06
    centre = (0.5 * (left + right), 0.045, 0.0)
    plotter.camera.focal_point = centre
    plotter.camera.position = (centre[0], centre[1], 10.0)
    plotter.camera.up = (0.0, 1.0, 0.0)
    plotter.camera.parallel_scale = max(0.36, 0.5 * (right - left) * WINDOW[1] / WINDOW[0])

    images, palette = [], None
    for k in frames:
        u, end = scale * fields.u[k], fields.u[k][-1]
        rod.points[:] = _strip(x, u)
        rod.point_data["θ"][:] = np.concatenate([fields.theta[k], fields.theta[k]])
        ticks.points[:] = _ticks(x, u)
        contact = end > gap
        colour = CONTACT_COLOUR if contact else TEXT_COLOUR
        clock.SetInput(f"t = {fields.t[k]:.3f}")
        status.SetInput(f"u(1, t) = {end:.3f}" + (f" > g: in contact, the obstacle gives way by "
                                                  f"u(1, t) − g = {end - gap:.3f}"
                                                  if contact else ""))
        status.GetTextProperty().SetColor(pv.Color(colour).float_rgb)
        obstacle.move(max(rest, 1.0 + u[-1]), colour)
        plotter.render()
        rgb = plotter.screenshot(return_img=True)[..., :3]
        if palette is None:
            palette = _palette(rgb)
        images.append(Image.fromarray(rgb).quantize(palette=palette, dither=Image.Dither.NONE))
    plotter.close()
    with replacing(path, "wb") as file:  # whole or not at all
        images[0].save(file, format="GIF", save_all=True, append_images=images[1:],
                       duration=frame_durations(fields.t, frames), loop=0)
    return path


def _palette(first: np.ndarray) -> Image.Image:
    """One palette of 256 colours for every frame, from the first frame (its colour bar holds
    every colour the rod can take) and the contact colour (which it may not show)."""
    red = np.array(pv.Color(CONTACT_COLOUR).int_rgb, dtype=np.uint8)
    strip = np.broadcast_to(red, (8, first.shape[1], 3))
    return Image.fromarray(np.vstack([first, strip])).quantize(
        colors=256, method=Image.Quantize.MEDIANCUT
    )
