"""Quick figures for a notebook or a script: a run's history against t (``Result.plot``) and a
sweep's measure against a swept key (``SweepResult.plot``), on matplotlib's pyplot axes, which a
notebook shows inline and ``matplotlib.pyplot.show()`` opens elsewhere. ``rodfem plot`` draws
the finished figures (:mod:`rodfem.post`); these are for looking, and need matplotlib alone (not
VTK, which importing :mod:`rodfem.post` loads).
"""

from __future__ import annotations

import numpy as np

from rodfem.output.names import TIME_LABEL, key_label, key_symbol, measure_label, series_label

MAIN = ("u_1", "sigma_1", "energy")  # the curves Result.plot draws by default


def _caption(meaning: str) -> str:
    """A column's meaning up to its first aside outside brackets: "contact stress σ(1, tⁿ)" of
    "contact stress σ(1, tⁿ) = −φ'(u(1)) of the obstacle's law (…)"."""
    depth = 0
    for i, char in enumerate(meaning):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth == 0 and meaning.startswith((" = ", ", ", " (", ": ", "; "), i):
            return meaning[:i]
    return meaning


def _symbol(key: str) -> str:
    """A swept key in a legend: the paper's symbol where it has one."""
    symbol = key_symbol(key)
    return f"${symbol}$" if symbol else key


def _new_axes(panels: int):
    import matplotlib.pyplot as plt

    _, axes = plt.subplots(panels, 1, sharex=True, squeeze=False, layout="constrained",
                           figsize=(7.5, 1.2 + 2.0 * panels))
    return axes[:, 0]


def history(history: np.ndarray, meanings: dict[str, str], title: str, gap: float,
            columns=None, ax=None):
    """The columns of a history against t: one panel each (an array of Axes), or all on ``ax``
    (returned). u(1, t) is drawn with the gap g, the obstacle's position."""
    columns = list(MAIN if columns is None else [columns] if isinstance(columns, str)
                   else columns)
    unknown = [name for name in columns if name == "t" or name not in history.dtype.names]
    if unknown:
        raise KeyError(f"no column {unknown[0]!r} to plot against t; the history has "
                       f"{', '.join(history.dtype.names[1:])}")
    t = history["t"]
    panels = [ax] * len(columns) if ax is not None else _new_axes(len(columns))
    for panel, name in zip(panels, columns, strict=True):
        panel.plot(t, history[name], label=name)
        if name == "u_1":
            panel.axhline(gap, color="0.5", linestyle="--", linewidth=1, label="gap g")
        if ax is None:
            panel.set_ylabel(series_label(name))
            panel.set_title(_caption(meanings.get(name, name)), loc="left", fontsize="medium")
            if name == "u_1":
                panel.legend(loc="best", fontsize="small")
    panels[-1].set_xlabel(TIME_LABEL)
    panels[0].figure.suptitle(title)
    if ax is not None:
        ax.legend(loc="best", fontsize="small")
        return ax
    return panels


def measure(columns: dict[str, np.ndarray], axes: tuple[str, ...], name: str, x=None, ax=None,
            declared: dict | None = None):
    """A sweep's measure ``name`` against the swept key ``x`` (default: the first), a line for
    each combination of the other swept keys' values, over the complete scenes; a log axis for
    positive values spanning two decades or more; the measure's axis labelled as ``rodfem plot``
    labels it (``declared``: the declared measures' specs, whose units it names). Returns the
    Axes."""
    x = axes[0] if x is None else x
    measures = [c for c in columns if c not in ("index", "status", "error", *axes)]
    if name not in measures:
        raise KeyError(f"no measure {name!r}; the sweep has {', '.join(measures)}")
    if x not in axes:
        raise KeyError(f"{x!r} is not a swept key; the sweep's are {', '.join(axes)}")
    if ax is None:
        ax = _new_axes(1)[0]
    complete = columns["status"] == "complete"
    others = [key for key in axes if key != x]
    groups = dict.fromkeys(tuple(columns[key][i] for key in others)
                           for i in np.flatnonzero(complete))
    many = len(groups) > 10  # a sampled design: points, no legend
    for group in groups:
        rows = complete.copy()
        for key, value in zip(others, group, strict=True):
            rows &= columns[key] == value
        order = np.argsort(columns[x][rows], kind="stable")
        label = ", ".join(f"{_symbol(key)} = {value:g}" if isinstance(value, float) else
                          f"{_symbol(key)} = {value}" for key, value in zip(others, group,
                                                                             strict=True))
        ax.plot(columns[x][rows][order], columns[name][rows][order], "o" if many else "o-",
                label=label or None, markersize=4)
    values = columns[x][complete]
    if values.dtype.kind in "if" and len(values) and values.min() > 0 \
            and values.max() >= 100 * values.min():
        ax.set_xscale("log")
    ax.set_xlabel(key_label(x))
    ax.set_ylabel(measure_label(name, declared))
    if others and not many:
        ax.legend(loc="best", fontsize="small")
    return ax


def save(axes, path, format: str | None, scene) -> None:
    """Write the figure of ``axes`` (an Axes or an array of them) to ``path`` in ``format``
    (:func:`rodfem.output.figures.target`: else the path's suffix, else the scene's
    ``output.figure_format``), its texts fitted to the canvas."""
    from rodfem.output import figures as formats

    if path is None:
        raise ValueError("format= is the format of the file written to path=: give path too")
    fig = np.ravel(axes)[0].figure
    formats.save(fig, formats.target(path, format, scene), dpi=fig.dpi)
