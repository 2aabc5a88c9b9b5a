"""The branches of steady states over a scene value (``rodfem steady --continue``), from
``branches.csv``: u(1) and θ(1) against the value, stable states solid, unstable dashed, each
branch in its colour, so that folds (where a stable and an unstable branch meet and end) show.
Drawn with matplotlib, as the curves of :mod:`rodfem.post.curves`."""

from __future__ import annotations

import csv
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rodfem.output.atomic import replacing
from rodfem.output.names import KEYS
from rodfem.post import style
from rodfem.post.runs import PlotError

FLAGS = ("contact", "stable", "tangential")
WORDS = ("trust", "key")  # read as they are written
FIGURE = "branches.png"
# The symbols of the keys a continuation runs over (rodfem.output.names).
# stable, unstable, not decided (neutral, unresolved, or not a state to round-off: crosses)
STYLES = {True: "-", False: "--", None: "none"}
SYMBOLS = {key: symbol for key, (_, symbol, _) in KEYS.items()}


def read_branches(path: Path) -> list[dict]:
    """The rows of branches.csv, typed back."""
    try:
        with open(path, encoding="utf-8", newline="") as f:
            rows = [{k: _typed(k, v) for k, v in raw.items()} for raw in csv.DictReader(f)]
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None
    if not rows:
        raise PlotError(f"{path} holds no states")
    return rows


def _typed(name: str, value: str):
    """A cell of branches.csv: flags true or false (``stable`` empty, None, where its trust is
    not ok), the branch a whole number, ``trust`` and ``key`` words, the rest reals."""
    if name in WORDS:
        return value
    if name in FLAGS:
        return None if value == "" else value == "true"
    return int(value) if name == "branch" else float(value)


def _runs(rows: list[dict]) -> list[tuple[bool, list[dict]]]:
    """A branch's rows cut where stability changes: (stable, rows); the segment across a change
    is drawn as unstable, and a row whose stability is not earned (None) as neither."""
    runs: list[tuple[bool, list[dict]]] = []
    for row in rows:
        if runs and runs[-1][0] == row["stable"]:
            runs[-1][1].append(row)
        elif runs and row["stable"]:  # unstable to stable: the unstable run reaches this row
            runs[-1][1].append(row)
            runs.append((True, [row]))
        else:  # stable to unstable: the unstable run starts at the last stable row
            runs.append((row["stable"], [runs[-1][1][-1], row] if runs else [row]))
    return runs


def _folds(rows: list[dict]) -> list[tuple[dict, dict]]:
    """Two branches that begin (or end) at the same value, inside the range, met at a fold
    between it and the value before (after): their first (last) states, to be joined."""
    values = sorted({r["parameter"] for r in rows})
    ends: dict[tuple[str, float], list[dict]] = {}
    for label in {r["branch"] for r in rows}:
        branch = sorted((r for r in rows if r["branch"] == label), key=lambda r: r["parameter"])
        for which, row in (("first", branch[0]), ("last", branch[-1])):
            ends.setdefault((which, row["parameter"]), []).append(row)
    pairs = []
    for (which, value), found in ends.items():
        inside = value != (values[0] if which == "first" else values[-1])
        if inside and len(found) == 2:
            pairs.append(tuple(sorted(found, key=lambda r: r["u_1"])))
    return pairs


def plot_branches(out: Path, key: str, gap: float | None = None) -> list[Path]:
    """figures/branches.png of ``out``/branches.csv, continued over ``key``."""
    rows = read_branches(out / "branches.csv")
    symbol = SYMBOLS.get(key, key)
    with style.mpl_fonts():
        fig = Figure(figsize=style.MPL_SIZE, dpi=style.MPL_DPI)
        top, bottom = fig.subplots(2, 1, sharex=True)
        for label in sorted({row["branch"] for row in rows}):
            branch = sorted((r for r in rows if r["branch"] == label),
                            key=lambda r: r["parameter"])
            for stable, part in _runs(branch):
                x = [r["parameter"] for r in part]
                for ax, name in ((top, "u_1"), (bottom, "theta_1")):
                    ax.plot(x, [r[name] for r in part], color=style.colour(label),
                            linestyle=STYLES[stable], linewidth=style.MPL_LINE_WIDTH,
                            marker="x" if stable is None else None)
            folds = [r for r in branch if r["tangential"]]
            for ax, name in ((top, "u_1"), (bottom, "theta_1")):
                ax.plot([r["parameter"] for r in folds], [r[name] for r in folds], "ko")
        for pair in _folds(rows):
            for ax, name in ((top, "u_1"), (bottom, "theta_1")):
                ax.plot([r["parameter"] for r in pair], [r[name] for r in pair], color="0.4",
                        linestyle=":", linewidth=style.MPL_LINE_WIDTH)
        if gap is not None:
            top.axhline(gap, color="0.6", linewidth=1.0)
        top.set_ylabel("$u(1)$")
        bottom.set_ylabel(r"$\theta(1)$")
        bottom.set_xlabel(f"{symbol} ({key})" if symbol != key else key)
        top.set_title(f"Steady states over {symbol}: stable solid, unstable dashed")
        for ax in (top, bottom):
            ax.grid(True, color="0.9")
        top.legend([Line2D([], [], color="k"), Line2D([], [], color="k", linestyle="--"),
                    Line2D([], [], color="0.4", linestyle=":")]
                   + ([Line2D([], [], color="k", linestyle="none", marker="x")]
                      if any(r["stable"] is None for r in rows) else [])
                   + ([Line2D([], [], color="0.6")] if gap is not None else []),
                   ["stable", "unstable", "across a fold"]
                   + (["not decided"] if any(r["stable"] is None for r in rows) else [])
                   + (["gap g"] if gap is not None else []),
                   loc="best", fontsize=style.MPL_LEGEND_SIZE)
        fig.tight_layout()
        path = out / "figures" / FIGURE
        path.parent.mkdir(exist_ok=True)
        with replacing(path, "wb") as file:
            fig.savefig(file, format="png", dpi=style.MPL_DPI)
    return [path]
