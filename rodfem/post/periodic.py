"""The figures of ``rodfem periodic``, from its directory's files: the orbit's u(1) and contact
force over one period beside the last period of the time run it was started from
(``orbit.csv``, ``settled.csv``), and with a continuation the period and amplitude against the
value (``periodic.csv``: stable orbits solid, unstable dashed, undecided as crosses). Drawn with
matplotlib, as :mod:`rodfem.post.steady`."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from matplotlib.figure import Figure

from rodfem.output import figures
from rodfem.output.names import KEYS, key_label
from rodfem.post import style
from rodfem.post.runs import PlotError

ORBIT_FIGURE = "orbit.png"
BRANCH_FIGURE = "periodic.png"
STYLES = {True: "-", False: "--"}


def read_table(path: Path) -> list[dict]:
    """The rows of one of the directory's tables: numbers as floats (an empty cell nan), the
    flags and words as they are written."""
    try:
        with open(path, encoding="utf-8", newline="") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError) as err:
        raise PlotError(f"cannot read {path}: {err}") from None
    return [{k: _typed(v) for k, v in row.items()} for row in rows]


def _typed(value: str):
    if value in ("true", "false"):
        return value == "true"
    try:
        return float(value) if value != "" else math.nan
    except ValueError:
        return value


def plot_orbit(out: Path, gap: float | None = None, format: str = "png") -> list[Path]:
    """figures/orbit.png: u(1) and the contact force p over one period of the orbit
    (orbit.csv) and of the time run's last period (settled.csv, where written), against the
    time since u(1) passed u* upward."""
    orbit = read_table(out / "orbit.csv")
    settled = read_table(out / "settled.csv") if (out / "settled.csv").exists() else []
    with style.mpl_fonts():
        fig = Figure(figsize=(style.MPL_SIZE[0], 1.3 * style.MPL_SIZE[1]), dpi=style.MPL_DPI,
                     layout="constrained")
        top, bottom = fig.subplots(2, 1, sharex=True)
        t = [r["t"] for r in orbit]
        top.plot(t, [r["u_1"] for r in orbit], color=style.colour(0),
                 linewidth=style.MPL_LINE_WIDTH, label=f"orbit, period {t[-1]:.6g}")
        bottom.plot(t, [r["p"] for r in orbit], color=style.colour(0),
                    linewidth=style.MPL_LINE_WIDTH)
        if settled:
            t0 = settled[0]["t"]
            ts = [r["t"] - t0 for r in settled]
            top.plot(ts, [r["u_1"] for r in settled], color=style.colour(1), linestyle="--",
                     linewidth=style.MPL_LINE_WIDTH,
                     label=f"time run, {t0:.5g} ≤ t ≤ {settled[-1]['t']:.5g}")
            bottom.plot(ts[1:], [r["p"] for r in settled[1:]], color=style.colour(1),
                        linestyle="--", linewidth=style.MPL_LINE_WIDTH)
        if gap is not None:
            top.axhline(gap, color="0.6", linewidth=1.0, label="gap g")
        top.set_ylabel("$u(1)$")
        bottom.set_ylabel("contact force $p$")
        bottom.set_xlabel("time since $u(1)$ passed $u^*$ upward")
        top.set_title("The periodic orbit over one period")
        top.legend(fontsize=style.MPL_LEGEND_SIZE)
        for ax in (top, bottom):
            ax.grid(True, color="0.9")
        return [_save(fig, out, ORBIT_FIGURE, format)]


def plot_continuation(out: Path, key: str, format: str = "png") -> list[Path]:
    """figures/periodic.png: the period and the amplitude max |u(1) − u*| of the orbits
    against the value (periodic.csv); stable solid, unstable dashed, undecided crosses."""
    rows = [r for r in read_table(out / "periodic.csv") if r["found"] == "yes"]
    if not rows:
        return []
    with style.mpl_fonts():
        fig = Figure(figsize=(style.MPL_SIZE[0], 1.3 * style.MPL_SIZE[1]), dpi=style.MPL_DPI,
                     layout="constrained")
        axes = fig.subplots(2, 1, sharex=True)
        for ax, name, label in zip(axes, ("period", "amplitude"),
                                   ("period $T$", r"$\max |u(1) - u^*|$"), strict=True):
            for stable, part in _runs(rows):
                x, y = [r["parameter"] for r in part], [r[name] for r in part]
                if stable is None:
                    ax.plot(x, y, "x", color=style.colour(0))
                else:
                    ax.plot(x, y, STYLES[stable], marker="o", markersize=3,
                            color=style.colour(0), linewidth=style.MPL_LINE_WIDTH)
            ax.set_ylabel(label)
            ax.grid(True, color="0.9")
        axes[-1].set_xlabel(key_label(key) if key in KEYS else key)
        axes[0].set_title("Periodic orbits: stable solid, unstable dashed")
        return [_save(fig, out, BRANCH_FIGURE, format)]


def _runs(rows: list[dict]) -> list[tuple[bool | None, list[dict]]]:
    """Neighbouring rows of one stability (None: undecided, ``stable`` empty) together."""
    runs: list[tuple[bool | None, list[dict]]] = []
    for row in rows:
        stable = row["stable"] if isinstance(row["stable"], bool) else None
        if runs and runs[-1][0] == stable:
            runs[-1][1].append(row)
        else:
            runs.append((stable, [row]))
    return runs


def _save(fig: Figure, out: Path, name: str, format: str) -> Path:
    path = out / "figures" / Path(name).with_suffix(f".{format}").name
    path.parent.mkdir(exist_ok=True)
    return figures.save(fig, path, dpi=style.MPL_DPI)
