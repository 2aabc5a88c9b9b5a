"""Figures of a sweep directory (``rodfem sweep``): one per measure, from ``results.csv``.

``sweep_<measure>.png`` for every informative measure of the table (the built-in ones of
:mod:`rodfem.output.measures` and those declared, chosen by :mod:`rodfem.post.choice`), or those
asked for, drawn by how the sweep was swept (``sweep.json``), axes named by their symbols and
units (:mod:`rodfem.output.names`), on a log scale where the design or the values call for one:

* one axis (grid, zip or sample): the measure against the axis, a line with markers;
* two grid axes or more: a map over the first two grid axes, one cell per pair of values, each
  coloured by the measure (and labelled with it), with a colour bar; with further axes, at their
  first values, which the title states. With exactly two axes, also ``sweep_<measure>_lines.png``:
  the measure against the first axis, one line per value of the second;
* two axes or more otherwise (zipped lists, samples): the scenes as points over the first two
  axes, coloured by the measure.

A scene that failed or was interrupted, or whose measure is nan, is left out of lines and shown
as a hatched grey cell in maps (a grey cross among points). Scenes whose fixed step was coarse
for their contact (results.csv's ``coarse``) are ringed in red, with a legend entry "step coarse
for the contact", and, where the table has an ``accuracy_met`` column, those with 0 there are
boxed in black, "accuracy target not met" (:data:`MARKS`), and a measure held to a target is drawn
with its estimated error as error bars (``<measure>_error``). The scenes' histories themselves, kept
with ``--histories``, are overlaid by :mod:`rodfem.post.scenes`. Reads the sweep's files only and
draws with matplotlib, off-screen (its figures are not pyplot's: nothing to close, no backend).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from rodfem.output import figures as formats
from rodfem.output import journal, names, results
from rodfem.post import choice
from rodfem.post.runs import PlotError

SIZE, DPI = (6.4, 4.8), 100
MISSING = dict(facecolor="lightgrey", edgecolor="grey", hatch="//", linewidth=0)
# The scenes marked in every figure of a measure: the column, the value that marks a scene, the
# legend's words and the mark (hollow, over the scene's point or cell). A column the table does
# not have marks nothing (accuracy_met: the tables of sweeps that set no accuracy target).
MARKS = (("coarse", 1, "step coarse for the contact", dict(marker="o", color="tab:red")),
         ("accuracy_met", 0, "accuracy target not met", dict(marker="s", color="black")))


@dataclasses.dataclass(frozen=True)
class Layout:
    """What sweep.json says of a sweep's axes: their order, how each was swept ("grid", "zip",
    "sample"), the grid's values per grid axis, the axes laid out logarithmically, and the
    measures declared (name → column, reduce, window)."""

    axes: tuple[str, ...]
    design: dict[str, str]
    grid: dict[str, list]
    logs: frozenset[str] = frozenset()
    declared: dict = dataclasses.field(default_factory=dict)
    figure_format: str | None = None  # the base scene's output.figure_format


class SweepDirectoryError(PlotError):
    """A path given to ``rodfem plot`` is not a readable sweep directory."""


def load_sweep(path: Path) -> tuple[Layout, dict[str, np.ndarray]]:
    """The axes of ``sweep.json`` and the columns of ``results.csv``, checked against them."""
    try:
        meta = json.loads((path / "sweep.json").read_text(encoding="utf-8"))
        output = (meta.get("base") or {}).get("output") or {}
        sweep = Layout(tuple(meta["axes"]), dict(meta["design"]),
                       {key: list(values) for key, values in meta["grid"].items()},
                       choice.log_design(meta), choice.declared(meta),
                       output.get("figure_format") if isinstance(output, dict) else None)
        if journal.exists(path):  # a stopped sweep: its rows so far
            records = journal.read(path)
            axes, columns = results.parse(results.text(
                sweep.axes, [records[i].line for i in sorted(records)],
                tuple(meta.get("measures", ()))))
        else:
            axes, columns = results.read(path / results.NAME)
    except (OSError, ValueError) as err:  # ResultsError and json's are ValueErrors
        reason = getattr(err, "strerror", None) or err
        raise SweepDirectoryError(" ".join(f"{path} is not a readable sweep directory: "
                                           f"{reason}".split())) from None
    except (KeyError, TypeError):
        raise SweepDirectoryError(f"{path}/sweep.json is not a sweep's") from None
    if not sweep.axes:
        raise SweepDirectoryError(f"{path} is a sweep without swept keys: nothing to draw over")
    if tuple(axes) != sweep.axes:
        raise SweepDirectoryError(f"{path}/results.csv's axes are not those of its sweep.json")
    if len(columns["index"]) == 0:
        raise SweepDirectoryError(f"{path}/results.csv holds no scenes")
    return sweep, columns


def _key(value) -> float | str:
    """A value as a comparable key, the same from sweep.json as from results.csv, which reads a
    column of text that all looks like numbers (expressions such as "0" and "1") as numbers:
    numbers, and text that reads as one, as floats; anything else as its text in the table."""
    if isinstance(value, (bool, np.bool_)):
        return str(value).lower()
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def _positions(values) -> tuple[np.ndarray, list | None]:
    """Numeric values as they are; others at 0, 1, ... in order of appearance, with labels."""
    keys = [_key(v) for v in values]
    if all(isinstance(k, float) for k in keys):
        return np.asarray(keys, dtype=float), None
    labels = list(dict.fromkeys(keys))
    return np.array([labels.index(k) for k in keys], dtype=float), labels


def _shown(value) -> str:
    """A swept value as a label shows it: 0.6, not 0.6000000000000001 (linspace's)."""
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _scale(ax, which: str, values: np.ndarray, labels: list | None, key: str,
           log: bool = False) -> None:
    """An axis of a swept key: its symbol and unit, categories as ticks, or a log scale where
    the design or the values call for one (:func:`rodfem.post.choice.logarithmic`)."""
    getattr(ax, f"set_{which}label")(names.key_label(key))
    if labels is not None:
        getattr(ax, f"set_{which}ticks")(range(len(labels)), [_shown(v) for v in labels])
    elif choice.logarithmic(values, log):
        getattr(ax, f"set_{which}scale")("log")


def _norm(values: np.ndarray):
    """The colour scale of a measure: logarithmic where its values span decades."""
    finite = values[np.isfinite(values)]
    low, high = (finite.min(), finite.max()) if finite.size else (0.0, 1.0)
    return LogNorm(low, high) if choice.logarithmic(finite) else Normalize(low, high)


def _save(fig: Figure, path: Path) -> Path:
    """Whole or not at all, in the format of the path's suffix (:mod:`rodfem.output.figures`)."""
    return formats.save(fig, path, dpi=DPI)


def _marks(columns) -> list[tuple[np.ndarray, str, dict]]:
    """The rows each of :data:`MARKS` marks, with its words and mark, of the columns the table
    has."""
    return [(np.asarray(columns[name]) == value, words, style)
            for name, value, words, style in MARKS if name in columns]


def _lines(ax, x, labels, key, log, y, ok, groups, marks=(), errors=None) -> None:
    """The measure against x, one line per (label, rows) of ``groups``, valid rows only; y on a
    log scale where the drawn values span decades; the rows of ``marks`` (:func:`_marks`)
    ringed; ``errors``: each row's estimated error, drawn as its error bar (an accuracy
    target's)."""
    drawn = np.zeros(len(y), dtype=bool)
    for label, rows in groups:
        keep = rows & ok
        drawn |= keep
        order = np.argsort(x[keep], kind="stable") if labels is None else slice(None)
        if errors is None:
            ax.plot(x[keep][order], y[keep][order], marker="o", label=label)
        else:
            bars = np.where(np.isfinite(errors), errors, 0.0)[keep][order]
            ax.errorbar(x[keep][order], y[keep][order], yerr=bars, marker="o", capsize=3,
                        label=label)
    for rows, words, style in marks:
        if (rows & drawn).any():
            ax.plot(x[rows & drawn], y[rows & drawn], linestyle="none", marker=style["marker"],
                    markersize=12, markerfacecolor="none", markeredgecolor=style["color"],
                    markeredgewidth=1.5, label=words)
    _scale(ax, "x", x, labels, key, log)
    if choice.logarithmic(y[ok]):
        ax.set_yscale("log")
    ax.grid(True, color="0.9")
    if not ok.any():
        ax.text(0.5, 0.5, "no complete scene", transform=ax.transAxes, ha="center")


def _map(ax, fig, sweep, columns, label, y, ok, rows, marks=()) -> None:
    """The measure over the first two grid axes, at the rows ``rows``; the cells of ``marks``
    (:func:`_marks`) outlined."""
    first, second = [a for a in sweep.axes if sweep.design[a] == "grid"][:2]
    xs, ys = ([_key(v) for v in sweep.grid[a]] for a in (first, second))
    grid = np.full((len(ys), len(xs)), np.nan)
    for r in np.flatnonzero(rows & ok):
        grid[ys.index(_key(columns[second][r])), xs.index(_key(columns[first][r]))] = y[r]
    norm = _norm(grid)
    image = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", norm=norm,
                      cmap="viridis")
    for j, i in np.argwhere(~np.isfinite(grid)):
        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, **MISSING))
    if grid.size <= 100:
        for (j, i), value in np.ndenumerate(grid):
            if np.isfinite(value):
                light = norm(value) > 0.6
                ax.text(i, j, f"{value:.3g}", ha="center", va="center", fontsize=8,
                        color="black" if light else "white")
    for which, axis in (("x", first), ("y", second)):
        _scale(ax, which, np.array([]), sweep.grid[axis], axis)
    fig.colorbar(image, ax=ax, label=label)
    inset = 0.06
    for k, (marked, words, style) in enumerate(marks):
        for n, r in enumerate(np.flatnonzero(marked & rows & ok)):
            i = xs.index(_key(columns[first][r]))
            j = ys.index(_key(columns[second][r]))
            d = 0.5 - inset * (k + 1)  # one inside the other where a cell has both
            ax.add_patch(Rectangle((i - d, j - d), 2 * d, 2 * d, fill=False, linewidth=2,
                                   edgecolor=style["color"], label=words if n == 0 else None))
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize="small")


def _scatter(ax, fig, sweep, columns, label, y, ok, marks=()) -> None:
    (x, xl), (z, zl) = (_positions(columns[a]) for a in sweep.axes[:2])
    points = ax.scatter(x[ok], z[ok], c=y[ok], cmap="viridis", norm=_norm(y[ok]),
                        edgecolors="black")
    ax.scatter(x[~ok], z[~ok], marker="x", color="grey", label="failed or nan")
    for rows, words, style in marks:
        if (rows & ok).any():
            ax.scatter(x[rows & ok], z[rows & ok], s=200, marker=style["marker"],
                       facecolors="none", edgecolors=style["color"], linewidths=1.5,
                       label=words)
    _scale(ax, "x", x, xl, sweep.axes[0], sweep.axes[0] in sweep.logs)
    _scale(ax, "y", z, zl, sweep.axes[1], sweep.axes[1] in sweep.logs)
    fig.colorbar(points, ax=ax, label=label)
    if (~ok).any() or any((rows & ok).any() for rows, _, _ in marks):
        ax.legend(loc="best")


def _figure(title: str) -> tuple[Figure, object]:
    fig = Figure(figsize=SIZE, layout="constrained")
    ax = fig.add_subplot()
    ax.set_title(title)
    return fig, ax


def _symbol(key: str) -> str:
    """A swept key in a title: its symbol, or the key."""
    symbol = names.key_symbol(key)
    return f"${symbol}$" if symbol else key


def _where(columns, others: list[str]) -> str:
    return ", ".join(f"{_symbol(a)} = {_shown(columns[a][0])}" for a in others)


def _files(out: Path, drawn: list[str], lines: bool, fmt: str) -> list[Path]:
    return [out / f for name in drawn
            for f in (f"sweep_{name}.{fmt}", *((f"sweep_{name}_lines.{fmt}",) if lines else ()))]


def plot_sweep(path: Path, out: Path | None = None, force: bool = False,
               measures: list[str] | None = None, overlay: bool = False,
               window: tuple[float, float] | None = None, note=None,
               option: str = "--measures", format: str | None = None) -> list[Path]:
    """Draw the figures of a sweep directory (``results.csv`` and ``sweep.json``).

    Args:
        path: the directory written by ``rodfem sweep``; read and checked first.
        out: the figure directory, created if need be (default: ``path/figures``, whose
            figures are drawn again; in ``out`` only with ``force``).
        force: replace figures of the same names in ``out`` (no other file is touched).
        measures: the measures to draw (default: the informative ones; with ``overlay``, none).
        overlay: also draw the scenes' histories overlaid (:mod:`rodfem.post.scenes`), from
            the histories the sweep kept (``--histories``).
        window: the time window of the overlaid histories.
        note: called with a line naming the measures left out by default, if any.
        option: the option that chose ``measures``, as its errors name it.
        format: the figures' format, png, pdf or svg (default: the base scene's
            ``output.figure_format``, else png).

    Returns:
        The files written: per measure (in the table's order) ``sweep_<measure>.png`` (or
        .pdf, .svg), then ``sweep_<measure>_lines.png`` if there is one; then the overlays.

    Raises:
        SweepDirectoryError: the directory is not a readable sweep directory (nothing written).
        PlotError: an unknown measure, no history kept for ``overlay``, or figures in ``out``
            without ``force``.
    """
    from rodfem.post import scenes  # here: the curves load VTK, which the measures never need

    path = Path(path)
    sweep, columns = load_sweep(path)
    drawn, skipped = ([], None) if overlay and measures is None \
        else choice.choose(columns, measures, option)
    overlaid = scenes.plan(path, sweep, columns, window) if overlay else None
    given = out is not None
    out = Path(out) if given else path / "figures"
    axes, grid_axes = sweep.axes, [a for a in sweep.axes if sweep.design[a] == "grid"]
    lines = len(axes) == 2 and len(grid_axes) == 2
    fmt = formats.chosen(format, {formats.SCENE_KEY: sweep.figure_format})
    overlays = [(out / f).with_suffix(f".{fmt}") for f in scenes.FIGURES] if overlay else []
    files = _files(out, drawn, lines, fmt) + overlays
    existing = [file for file in files if file.exists()]
    if given and existing and not force:
        more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
        raise PlotError(f"{existing[0]} exists{more}: --force replaces the figures rodfem "
                        "draws there")
    if skipped and note is not None:
        note(skipped)
    out.mkdir(parents=True, exist_ok=True)  # an OSError is a write error (exit code 4)
    written = [_measure(out, sweep, columns, name, fmt) for name in drawn]
    written = [file for pair in written for file in pair]
    return written + (scenes.draw(overlaid, overlays) if overlay else [])


def _measure(out: Path, sweep: Layout, columns, name: str, fmt: str = "png") -> list[Path]:
    """The figures of one measure: ``sweep_<name>.png`` (and ``_lines`` over two grid axes)."""
    axes, grid_axes = sweep.axes, [a for a in sweep.axes if sweep.design[a] == "grid"]
    others = [a for a in axes if a not in grid_axes[:2]]
    at = np.ones(len(columns["status"]), dtype=bool)
    for axis in others if len(grid_axes) >= 2 else ():
        at &= np.array([_key(v) == _key(columns[axis][0]) for v in columns[axis]])
    y = np.asarray(columns[name], dtype=float)
    ok = (columns["status"] == "complete") & np.isfinite(y)
    label = names.measure_label(name, sweep.declared)
    title = names.measure_title(name, sweep.declared)
    first, marks = axes[0], _marks(columns)
    errors = columns.get(f"{name}{results.ERROR_SUFFIX}")  # an accuracy target's estimates
    errors = None if errors is None else np.asarray(errors, dtype=float)
    barred = label if errors is None else f"{label}, bars: its estimated error"
    if len(axes) == 1:
        fig, ax = _figure(f"{title} against {_symbol(first)}")
        _lines(ax, *_positions(columns[first]), first, first in sweep.logs, y, ok, [(None, at)],
               marks, errors)
        ax.set_ylabel(barred)
        if ax.get_legend_handles_labels()[0]:  # the marks'
            ax.legend(loc="best")
    elif len(grid_axes) >= 2:
        fig, ax = _figure(f"{title} over {_symbol(grid_axes[0])} and {_symbol(grid_axes[1])}"
                          + (f"\nat {_where(columns, others)}" if others else ""))
        _map(ax, fig, sweep, columns, label, y, ok, at, marks)
    else:
        fig, ax = _figure(f"{title} over {_symbol(first)} and {_symbol(axes[1])}")
        _scatter(ax, fig, sweep, columns, label, y, ok, marks)
    written = [_save(fig, out / f"sweep_{name}.{fmt}")]
    if len(axes) == 2 and len(grid_axes) == 2:
        fig, ax = _figure(f"{title} against {_symbol(first)}")
        keys = [_key(v) for v in columns[axes[1]]]
        groups = [(f"{_symbol(axes[1])} = {_shown(v)}", np.array([k == _key(v) for k in keys]))
                  for v in sweep.grid[axes[1]]]
        _lines(ax, *_positions(columns[first]), first, first in sweep.logs, y, ok, groups,
               marks, errors)
        ax.set_ylabel(barred)
        # beside the axes, not over them: "best" still covers lines where every corner has one
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
                  fontsize="small")
        written.append(_save(fig, out / f"sweep_{name}_lines.{fmt}"))
    return written
