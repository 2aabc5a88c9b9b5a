"""The file formats of the still figures, and the saving of a matplotlib figure into one.

Every still figure rodfem draws comes as PNG (a raster, 100 to 120 dots per inch), PDF or SVG
(vectors: text and lines stay sharp at any size; a map's coloured cells are embedded as an image).
The format is chosen by ``--format`` on the command line, else by the scene's
``output.figure_format``, else PNG; the figure's file ends in it (``contact.pdf``). Animations
stay GIF.

Before a figure is saved its texts are made to fit the canvas: a title or label that reaches
beyond an edge is set smaller (and, if that is not enough, wrapped) until every text lies inside
(:func:`outside` finds them from matplotlib's renderer extents).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from rodfem.output.readers import PlotError
from rodfem.scene.schema import FIGURE_FORMATS

FORMATS = FIGURE_FORMATS  # the scene's output.figure_format allows these
DEFAULT = FORMATS[0]
SCENE_KEY = "output.figure_format"
SMALLEST = 7.0  # points: a text is not set smaller than this to fit
# Metadata left out of vector files, so that drawing the same figure twice writes the same bytes.
_STABLE = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}


class FormatError(PlotError):
    """A figure format that rodfem does not write: the message names the allowed ones."""


def checked(value, option: str = "format") -> str:
    """A format name (``png``, ``pdf``, ``svg``; any case) checked, lower-cased."""
    name = str(value).strip().lower()
    if name not in FORMATS:
        raise FormatError(f"{option}: unknown figure format {str(value)!r}; the formats are "
                          f"{', '.join(FORMATS)}")
    return name


def chosen(given: str | None, scene=None) -> str:
    """The format of a figure: the one ``given`` (the command line's, a ``format=`` argument),
    else the scene's ``output.figure_format``, else PNG."""
    if given is not None:
        return checked(given)
    if scene is not None:
        try:
            value = scene[SCENE_KEY]
        except (KeyError, TypeError):
            value = None
        if value is not None:
            return checked(value, SCENE_KEY)
    return DEFAULT


def of(path: Path) -> str:
    """The format a figure's file is written in, from its suffix (PNG for any other)."""
    suffix = Path(path).suffix[1:].lower()
    return suffix if suffix in FORMATS else DEFAULT


def written(directory: Path, stem: str) -> Path | None:
    """The file a figure ``stem`` (``fit``) was written to in ``directory``, in whichever format
    it has (the newest, if it is there in several); None if it is in none."""
    found = [p for p in (Path(directory) / f"{stem}.{f}" for f in FORMATS) if p.is_file()]
    return max(found, key=lambda p: p.stat().st_mtime_ns) if found else None


def outside(fig, tolerance: float = 1.0) -> list:
    """The visible, non-empty texts of ``fig`` whose drawn extent reaches beyond the canvas by
    more than ``tolerance`` pixels (titles, labels, tick labels, legends, notes)."""
    from matplotlib.text import Text

    if not hasattr(fig.canvas, "get_renderer"):  # a Figure() of its own: measured by Agg
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)  # the layout (constrained or not) as it will be saved
    box = fig.bbox
    hidden = _undrawn_tick_labels(fig)
    found = []
    for text in fig.findobj(Text):
        if not text.get_visible() or not text.get_text().strip() or text.figure is None \
                or id(text) in hidden:
            continue
        extent = text.get_window_extent(renderer)
        if extent.x0 < box.x0 - tolerance or extent.y0 < box.y0 - tolerance \
                or extent.x1 > box.x1 + tolerance or extent.y1 > box.y1 + tolerance:
            found.append(text)
    return found


def _undrawn_tick_labels(fig) -> set[int]:
    """The tick labels that an axis keeps but does not draw: of ticks outside its view, or of
    an axis turned off (a strip that holds a legend)."""
    hidden = set()
    for ax in fig.axes:
        for axis in ax._axis_map.values() if hasattr(ax, "_axis_map") else (ax.xaxis, ax.yaxis):
            shown = ax.axison and ax.get_visible() and axis.get_visible()
            drawn = {id(label) for tick in (axis._update_ticks() if shown else ())
                     for label in (tick.label1, tick.label2)}
            hidden |= {id(label) for tick in (*axis.majorTicks, *axis.minorTicks)
                       for label in (tick.label1, tick.label2) if id(label) not in drawn}
    return hidden


def make_room(fig, texts: list) -> bool:
    """Where ``texts`` outside the canvas (:func:`outside`) hold tick or axis labels that reach
    beyond its left or right edge (the wide tick labels of a narrow range, 4.8600 … 4.8450,
    push the y label off), move the axes in: every axes' horizontal extent mapped by one affine
    map that takes the overflow back inside, so that the panels, the legend's strip and the
    colour bar keep their proportions. Not for a figure with a layout engine, which places its
    axes itself. Returns whether the axes moved."""
    if fig.get_layout_engine() is not None:
        return False
    labels = {id(t) for ax in fig.axes for axis in (ax.xaxis, ax.yaxis)
              for t in (axis.label, *axis.get_ticklabels(which="both"))}
    renderer, box = fig.canvas.get_renderer(), fig.bbox
    left = right = 0.0  # the overflow, a fraction of the canvas's width
    for text in texts:
        if id(text) in labels:
            extent = text.get_window_extent(renderer)
            left = max(left, (box.x0 - extent.x0 + 2.0) / box.width)
            right = max(right, (extent.x1 - box.x1 + 2.0) / box.width)
    if (left <= 0.0 and right <= 0.0) or left + right >= 0.25:  # none, or more than a little
        return False
    left, right = max(left, 0.0), max(right, 0.0)
    for ax in fig.axes:
        x0, y0, width, height = ax.get_position().bounds
        scale = 1.0 - left - right
        ax.set_position((left + x0 * scale, y0, width * scale, height))
    return True


def fit_texts(fig) -> bool:
    """Make room for tick and axis labels beyond the canvas's sides (:func:`make_room`), then set
    each text that still reaches beyond it smaller, down to :data:`SMALLEST` points, and then
    wrap it at its words, until it lies inside (or cannot be made to). Returns whether the
    canvas holds the figure as it is now (drawn last with every text inside)."""
    for _ in range(2):
        texts = outside(fig)
        if not texts or not make_room(fig, texts):
            break
    for _ in range(12):
        texts = outside(fig)
        if not texts:
            return True
        changed = False
        for text in texts:
            size = text.get_fontsize()
            if size > SMALLEST:
                text.set_fontsize(max(SMALLEST, 0.88 * size))
                changed = True
            elif "$" not in text.get_text():  # mathtext is not cut: "$" pairs must stay whole
                lines = text.get_text().split("\n")
                width = max(8, int(0.8 * max(len(line) for line in lines)))
                wrapped = "\n".join(textwrap.fill(line, width) for line in lines)
                changed |= wrapped != text.get_text()
                text.set_text(wrapped)
        if not changed:  # as small and as wrapped as they can be: drawing again changes nothing
            return False
    return False


def target(path, format: str | None = None, scene=None) -> Path:
    """The file a ``.plot(path=..., format=...)`` writes: ``path`` in the format given, else in
    the format its suffix names, else in the scene's (or PNG), the suffix added where it has
    none; a suffix that names another format than ``format`` is refused (:class:`FormatError`)."""
    path = Path(path)
    suffix = path.suffix[1:].lower()
    if format is None and suffix in FORMATS:
        return path
    fmt = chosen(format, scene)
    if suffix in FORMATS and suffix != fmt:
        raise FormatError(f"format={format!r} but the file {path.name} ends in .{suffix}: "
                          "give one of them")
    return path if suffix == fmt else path.with_name(f"{path.name}.{fmt}")


def save(fig, path: Path, dpi: float = 100) -> Path:
    """Write a matplotlib figure to ``path`` in the format its suffix names, whole or not at
    all, its texts first made to fit the canvas (:func:`fit_texts`). A PNG is the picture that
    fitting drew (at ``dpi``), not drawn a second time."""
    from rodfem.output.atomic import replacing

    fmt = of(path)
    shown = fig.get_dpi()
    fig.set_dpi(dpi)  # the texts are measured (and a PNG drawn) as they will be written
    try:
        drawn = fit_texts(fig)
        with replacing(Path(path), "wb") as file:
            if fmt == "png" and drawn and hasattr(fig.canvas, "buffer_rgba"):
                from PIL import Image

                pixels = np.asarray(fig.canvas.buffer_rgba())
                Image.fromarray(pixels).save(file, format="PNG", dpi=(dpi, dpi))
            else:
                import matplotlib

                # SVG's clip paths and markers get random ids unless salted: the same figure
                # drawn twice (a resumed study's, say) is then the same bytes
                with matplotlib.rc_context({"svg.hashsalt": "rodfem"}):
                    fig.savefig(file, format=fmt, dpi=dpi, metadata=_STABLE.get(fmt))
    finally:
        fig.set_dpi(shown)
    return Path(path)
