"""The branches of steady states over a scene value (``rodfem steady --continue``), from
``branches.csv``: u(1), the contact pressure −σ(1) and θ(1) against the value, so that folds
(where a stable and an unstable branch meet and end) show. A legend says what is what: the colour
is contact (states in contact with the obstacle) or free; the line is the stability, stable solid,
unstable dashed, neutral states open circles, states whose stability is not resolved crosses.
u(1) of a state in contact lies on the gap line (a rigid obstacle), so its panel is left out where
every state is in contact there, and the pressure panel, which tells such states apart, is drawn
wherever one is in contact. Drawn with matplotlib, as the curves of :mod:`rodfem.post.curves`."""

from __future__ import annotations

import csv
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rodfem.output import figures
from rodfem.output.names import KEYS, key_label, with_unit
from rodfem.post import style
from rodfem.post.runs import PlotError

FLAGS = ("contact", "stable", "tangential")
WORDS = ("trust", "key")  # read as they are written
FIGURE = "branches.png"
POINTS = "points.csv"
POINT_WORDS = ("kind", "before", "after", "asymptotic", "key", "criticality")
# The located points' marks: (marker, colour, legend).
MARKS = {"fold": ("o", "k", "fold"), "grazing": ("^", "tab:green", "grazing (touches the obstacle)"),
         "hopf": ("*", "tab:purple", "Hopf point")}
# The symbols of the keys a continuation runs over (rodfem.output.names).
# stable, unstable, not decided (neutral, unresolved, or not a state to round-off: markers)
STYLES = {True: "-", False: "--", None: "none"}
CONTACT, FREE = "tab:red", "tab:blue"  # the colours of states in contact and free
# The panels: (history column, label, what the column becomes).
PANELS = {"u_1": with_unit("$u(1)$", "L"),
          "pressure": with_unit(r"contact pressure $-\sigma(1)$", "E"),
          "theta_1": r"$\theta(1)$"}
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


def read_points(path: Path) -> list[dict]:
    """The rows of points.csv (none where the diagram was sampled: no such file)."""
    if not path.exists():
        return []
    try:
        with open(path, encoding="utf-8", newline="") as f:
            return [{k: (v if k in POINT_WORDS else v == "true" if k == "turns" else
                         int(v) if k == "branch" else float(v)) for k, v in raw.items()}
                    for raw in csv.DictReader(f)]
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None


def _order(row: dict):
    """A row's place along its branch: its ``point`` (its parameter in older files)."""
    point = row.get("point")
    return row["parameter"] if point is None else point


def _typed(name: str, value: str):
    """A cell of branches.csv: flags true or false (``stable`` empty, None, where its trust is
    not ok), the branch a whole number, ``trust`` and ``key`` words, the rest reals."""
    if name in WORDS:
        return value
    if name in FLAGS:
        return None if value == "" else value == "true"
    return int(value) if name in ("branch", "point") else float(value)


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


def _value(row: dict, panel: str) -> float:
    """A state's value in a panel: the contact pressure is −σ(1) (0 for a free state)."""
    return -row["sigma_1"] if panel == "pressure" else row[panel]


def _segments(rows: list[dict]) -> list[tuple[bool | None, bool, list[dict]]]:
    """A branch's rows cut where its stability or contact changes: (stable, contact, rows),
    each segment joined to the one before (:func:`_runs`); its colour is its contact."""
    found = []
    for stable, part in _runs(rows):
        start = 0
        for i in range(1, len(part) + 1):
            if i == len(part) or bool(part[i]["contact"]) != bool(part[start]["contact"]):
                chunk = part[max(start - 1, 0):i] if start else part[start:i]
                found.append((stable, bool(part[min(start, len(part) - 1)]["contact"]), chunk))
                start = i
    return found


def panels(rows: list[dict], gap: float | None) -> list[str]:
    """The panels drawn: u(1) unless every state is in contact on the gap line; the pressure
    wherever a state is in contact; θ(1)."""
    touching = [r for r in rows if r["contact"]]
    flat = len(touching) == len(rows) and gap is not None and all(
        abs(r["u_1"] - gap) <= 1e-9 * max(1.0, abs(gap)) for r in touching)
    return [*([] if flat else ["u_1"]), *(["pressure"] if touching else []), "theta_1"]


def _legend(ax, rows: list[dict], gap: float | None, shown: list[str],
            kinds: set[str] = frozenset()) -> None:
    """What the colours, lines and marks stand for, beside the panels."""
    trusts = {r["trust"] for r in rows if r["stable"] is None}
    entries = [(Line2D([], [], color=CONTACT, lw=style.MPL_LINE_WIDTH), "in contact"),
               (Line2D([], [], color=FREE, lw=style.MPL_LINE_WIDTH), "free"),
               (Line2D([], [], color="k"), "stable"),
               (Line2D([], [], color="k", linestyle="--"), "unstable")]
    if "neutral" in trusts:
        entries.append((Line2D([], [], color="k", ls="none", marker="o", mfc="none"), "neutral"))
    if trusts - {"neutral"}:
        entries.append((Line2D([], [], color="k", ls="none", marker="x"), "unresolved"))
    if any(r["tangential"] for r in rows) and "fold" not in kinds:
        entries.append((Line2D([], [], color="k", ls="none", marker="o"), "fold"))
    for kind, (marker, colour, label) in MARKS.items():
        if kind in kinds:
            entries.append((Line2D([], [], color=colour, ls="none", marker=marker,
                                   markersize=8), label))
    if _folds(rows):
        entries.append((Line2D([], [], color="0.4", linestyle=":"), "across a fold"))
    if gap is not None and "u_1" in shown:
        entries.append((Line2D([], [], color="0.6"), "gap $g$"))
    ax.legend(*zip(*entries, strict=True), loc="upper left", bbox_to_anchor=(1.01, 1.0),
              borderaxespad=0.0, fontsize=style.MPL_LEGEND_SIZE, frameon=False)


def plot_branches(out: Path, key: str, gap: float | None = None,
                  format: str = "png") -> list[Path]:
    """figures/branches.png (or .pdf, .svg: ``format``) of ``out``/branches.csv, continued over
    ``key``."""
    rows = read_branches(out / "branches.csv")
    shown = panels(rows, gap)
    with style.mpl_fonts():
        fig = Figure(figsize=(style.MPL_SIZE[0], 1.6 + 2.6 * len(shown)), dpi=style.MPL_DPI,
                     layout="constrained")
        axes = dict(zip(shown, fig.subplots(len(shown), 1, sharex=True, squeeze=False)[:, 0],
                        strict=True))
        for label in sorted({row["branch"] for row in rows}):
            branch = sorted((r for r in rows if r["branch"] == label), key=_order)
            for stable, contact, part in _segments(branch):
                x = [r["parameter"] for r in part]
                for name, ax in axes.items():
                    y = [_value(r, name) for r in part]
                    colour = CONTACT if contact else FREE
                    if stable is None:
                        for row, xv, yv in zip(part, x, y, strict=True):
                            neutral = row["trust"] == "neutral"
                            ax.plot([xv], [yv], color=colour, linestyle="none",
                                    marker="o" if neutral else "x",
                                    mfc="none" if neutral else colour)
                    else:
                        ax.plot(x, y, color=colour, linestyle=STYLES[stable],
                                linewidth=style.MPL_LINE_WIDTH)
            folds = [r for r in branch if r["tangential"]]
            for name, ax in axes.items():
                ax.plot([r["parameter"] for r in folds], [_value(r, name) for r in folds], "ko")
        located = read_points(out / POINTS)
        for kind, (marker, colour, _) in MARKS.items():
            here = [r for r in located if r["kind"] == kind]
            for name, ax in axes.items():
                ax.plot([r["parameter"] for r in here], [_value(r, name) for r in here],
                        linestyle="none", marker=marker, color=colour, markersize=8, zorder=5)
        for pair in _folds(rows):
            for name, ax in axes.items():
                ax.plot([r["parameter"] for r in pair], [_value(r, name) for r in pair],
                        color="0.4", linestyle=":", linewidth=style.MPL_LINE_WIDTH)
        if gap is not None and "u_1" in axes:
            axes["u_1"].axhline(gap, color="0.6", linewidth=1.0)
        for name, ax in axes.items():
            ax.set_ylabel(PANELS[name])
            ax.grid(True, color="0.9")
        last = axes[shown[-1]]
        last.set_xlabel(key_label(key) if key in KEYS else key)
        first = axes[shown[0]]
        first.set_title(f"Steady states over ${KEYS[key][0]}$" if key in KEYS else
                        f"Steady states over {key}")
        _legend(first, rows, gap, shown, {r["kind"] for r in located})
        path = out / "figures" / Path(FIGURE).with_suffix(f".{format}").name
        path.parent.mkdir(exist_ok=True)
        return [figures.save(fig, path, dpi=style.MPL_DPI)]
