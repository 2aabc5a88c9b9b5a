"""A sweep's scenes overlaid (``rodfem plot SWEEPDIR --overlay``): the histories the sweep kept
(``rodfem sweep --histories``, ``histories.h5``) drawn as the curves of runs overlaid are
(:mod:`rodfem.post.curves`), each scene named by its swept values.

    sweep_scenes_contact.png   u(1, t) with the gap, u(0.5, t), u_t(1, t), σ(1, t)
    sweep_scenes_energy.png    ln(Ê + 0.01) against t

Over one numeric axis the scenes are coloured by its value (a sequential map and a colour bar, on
a log scale where the values span decades); otherwise each has its colour and a legend entry
naming its swept values in symbols (``scene 3: ζ = 0.2, ε = 0.001``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rodfem.post import curves
from rodfem.post.runs import PlotError, Run, _flatten, legend_labels

# The file of the histories ``rodfem sweep --histories`` keeps (rodfem.studies.sweepfiles writes
# it, a layer above the figures; tests/test_sweep_figures.py checks the two names agree).
HISTORIES = "histories.h5"
FIGURES = ("sweep_scenes_contact.png", "sweep_scenes_energy.png")


@dataclass(frozen=True)
class Overlay:
    """The scenes to draw, their legend labels (none when coloured by ``colour_by``)."""

    runs: list[Run]
    labels: list[str]
    colour_by: str | None
    window: tuple[float, float] | None


def _histories(path: Path) -> dict[int, tuple[np.ndarray, tuple[str, ...]]]:
    """The rows and column names of every scene's history in histories.h5, by index."""
    import h5py  # here: imported before dolfinx, Debian's serial h5py aborts an MPI run

    file = path / HISTORIES
    if not file.is_file():
        raise PlotError(f"--overlay: {path} kept no histories (run the sweep with "
                        "--histories)")
    try:
        with h5py.File(file, "r") as data:
            return {int(i): (dataset[...], tuple(str(dataset.attrs["columns"]).split(",")))
                    for i, dataset in data["scenes"].items()}
    except (OSError, KeyError, ValueError) as err:
        raise PlotError(f"--overlay: cannot read {file}: {' '.join(str(err).split())}") \
            from None


def plan(path: Path, sweep, columns: dict[str, np.ndarray],
         window: tuple[float, float] | None = None) -> Overlay:
    """Read the scenes' histories and make their runs (checked before anything is drawn)."""
    from rodfem.output.readers import History

    histories = _histories(path)
    meta = json.loads((path / "sweep.json").read_text(encoding="utf-8"))
    base = _flatten(meta.get("base") or {})
    runs = []
    for row, index in enumerate(columns["index"]):
        if int(index) not in histories:
            continue
        rows, names = histories[int(index)]
        scene = {**base, **{axis: _value(columns[axis][row]) for axis in sweep.axes}}
        runs.append(Run(path, f"scene {int(index)}", History(rows, names), scene, None))
    if not runs:
        raise PlotError(f"--overlay: {path / HISTORIES} holds no scene's history")
    if window is not None and window[0] >= max(float(r.history.t[-1]) for r in runs):
        raise PlotError(f"--window starts at t = {window[0]:g}, after the scenes end")
    numeric = len(sweep.axes) == 1 and all(
        isinstance(run.scene[sweep.axes[0]], float) for run in runs) and len(runs) > 1 \
        and len({run.scene[sweep.axes[0]] for run in runs}) > 1
    colour_by = sweep.axes[0] if numeric else None
    return Overlay(runs, [] if numeric else legend_labels(runs), colour_by, window)


def _value(value):
    """A swept value from results.csv: numbers as floats, text as it is."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    return str(value)


def draw(overlay: Overlay, out: Path) -> list[Path]:
    """The overlaid curves, in ``out``."""
    shared = dict(window=overlay.window, colour_by=overlay.colour_by)
    labels = overlay.labels or [run.name for run in overlay.runs]
    return [curves.contact_figure(overlay.runs, labels, out / FIGURES[0], **shared),
            curves.energy_figure(overlay.runs, labels, out / FIGURES[1], **shared)]
