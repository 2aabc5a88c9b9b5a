"""A run directory as the figures see it: ``history.h5``, ``scene.toml`` and ``fields.xdmf``.

Everything a figure needs is read and checked here, before any figure is drawn, so that a bad
directory stops ``rodfem plot`` with one line and no half-written figures.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path
from typing import Any

from rodfem.output.names import CHOICES, KEYS
from rodfem.output.readers import (  # noqa: F401 (the errors and History are read here)
    FUNCTIONS,
    Fields,
    FieldsError,
    History,
    PlotError,
    RunDirectoryError,
    history_path,
    read_fields,
    read_history,
)
from rodfem.scene import BUILTIN, SceneError
from rodfem.scene import load as load_scene
from rodfem.scene.expressions import shorten

# The paper's symbols of scene values (rodfem.output.names), in mathtext (typeset by matplotlib, for
# the charts) and in Unicode (for text drawn many times, as in the animation, where typesetting
# would cost seconds).
PARAMETERS = {key: (math, text) for key, (math, text, _) in KEYS.items()}
# A legend names at most this many of the values in which runs differ.
LEGEND_KEYS = 4
PAPER_PARAMETERS = ("model.zeta", "obstacle.epsilon", "model.k")
# What makes a scene one of the paper's experiments: its equations and data, not how finely or
# how long it is solved (mesh, time step, end, solver and outputs may differ).
EXPERIMENT_SECTIONS = ("model.", "obstacle.", "initial.", "source.")


@dataclass(frozen=True)
class Run:
    """One run directory, read whole.

    Attributes:
        path: the directory.
        name: its name, used in legends and in per-run file names.
        history: ``history.h5`` (or an earlier rodfem's ``history.csv``).
        scene: ``scene.toml``, flattened to ``section.key`` → value.
        fields: ``fields.xdmf``.
    """

    path: Path
    name: str
    history: History
    scene: dict[str, Any]
    fields: Fields

    @property
    def gap(self) -> float:
        """The obstacle's gap g: the rod is in contact where u(1, t) > g."""
        return float(self.scene["obstacle.gap"])

    @property
    def experiment(self) -> int | None:
        """The number of the paper's experiment (Section 6) this run solves, or None."""
        data = {k: v for k, v in self.scene.items() if k.startswith(EXPERIMENT_SECTIONS)}
        for number, experiment in enumerate(_experiments(), start=1):
            if data == experiment:
                return number
        return None

    def parameter(self, key: str, math: bool = True) -> str:
        """``symbol = value``, e.g. ``$\\zeta = 0.2$`` in mathtext or ``ζ = 0.2`` in Unicode; a law
        or a method in words (``contact law power``); another key as ``key = value``."""
        value = self.scene[key]
        if key == "obstacle.epsilon" and self.scene.get("obstacle.kind") == "rigid":
            return "rigid obstacle"  # ε is not used
        if key == "obstacle.kind":
            return f"{value} obstacle"
        if key in CHOICES:
            if isinstance(value, bool):
                return f"{'adaptive' if value else 'fixed'} steps"
            return f"{CHOICES[key]} {value}"
        text = shorten(value, 24) if isinstance(value, str) else f"{value:g}"
        if key not in PARAMETERS:
            return (f"{key} = {text}".replace("$", r"\$") if math else f"{key} = {text}")
        math_symbol, symbol = PARAMETERS[key]
        return f"${math_symbol} = {text}$" if math else f"{symbol} = {text}"


def _flatten(table: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    flat = {}
    for key, value in table.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[prefix + key] = value
    return flat


@cache
def _experiments() -> tuple[dict[str, Any], ...]:
    """The equations and data of the paper's experiments, from the built-in scenes."""
    return tuple({k: v for k, v in _flatten(load_scene(name).data()).items()
                  if k.startswith(EXPERIMENT_SECTIONS)}
                 for name in BUILTIN if name.startswith("paper"))


def load_run(path: Path) -> Run:
    """Read a run directory written by ``rodfem run``.

    Args:
        path: the directory holding ``history.h5``, ``scene.toml`` and ``fields.xdmf``.

    Raises:
        RunDirectoryError: ``path`` is not a directory, or a file is missing or unreadable.
    """
    path = Path(path)
    if not path.is_dir():
        raise RunDirectoryError(f"{path} is not a directory")
    for name in (history_path(path).name, "scene.toml", "fields.xdmf"):
        if not (path / name).is_file():
            raise RunDirectoryError(f"{path} is not a rodfem run directory (it has no {name})")
    history = read_history(history_path(path))
    try:  # the resolved scene, checked as any scene is (it may have been edited)
        scene = _flatten(load_scene(str(path / "scene.toml")).data())
    except SceneError as err:
        raise RunDirectoryError(f"{path / 'scene.toml'}: {err}") from None
    try:
        fields = read_fields(path / "fields.xdmf")
    except FieldsError as err:
        raise RunDirectoryError(str(err)) from None
    return Run(path, path.resolve().name, history, scene, fields)


def differing(scenes: list[dict[str, Any]]) -> list[str]:
    """The scene keys (of the sections that set a run, not its outputs) whose values differ
    between the scenes, or that some scenes have and others not, in the scenes' order: at most
    ``LEGEND_KEYS``, first those that tell the scenes apart (each time the key that splits them
    most, a law or a method before a key with a symbol in the paper, before any other key), then
    the other laws, methods and symbols that differ."""
    keys = list(dict.fromkeys(k for scene in scenes for k in scene))
    keys = [k for k in keys if "." in k and not k.startswith("output.")
            and len({repr(scene.get(k)) for scene in scenes}) > 1]
    rank = {k: (0 if k in CHOICES else 1 if k in KEYS else 2, i) for i, k in enumerate(keys)}

    def groups(chosen: list[str]) -> int:
        return len({tuple(repr(scene.get(k)) for k in chosen) for scene in scenes})

    chosen: list[str] = []
    while len(chosen) < LEGEND_KEYS and groups(chosen) < groups(keys):
        chosen.append(min((k for k in keys if k not in chosen),
                          key=lambda k: (-groups([*chosen, k]), rank[k])))
    for key in sorted(keys, key=rank.__getitem__):
        if len(chosen) < LEGEND_KEYS and key not in chosen and rank[key][0] < 2:
            chosen.append(key)
    return [k for k in keys if k in chosen]


def legend_labels(runs: list[Run], math: bool = True) -> list[str]:
    """One label per run: its name and the scene values that set it apart from the others
    (:func:`differing`: the law or the method included where it differs; the paper's ζ, ε, k
    for a single run, or when nothing differs); in mathtext or in Unicode."""
    keys = differing([run.scene for run in runs]) \
        or [key for key in PAPER_PARAMETERS if all(key in r.scene for r in runs)]
    # A "$" in a directory name would start mathtext: escape it.
    names = [run.name.replace("$", r"\$") if math else run.name for run in runs]
    labels = []
    for name, run in zip(names, runs, strict=True):
        parts = [run.parameter(key, math) for key in keys if key in run.scene]
        labels.append(f"{name}: " + ", ".join(dict.fromkeys(parts)))
    return labels


def file_suffixes(runs: list[Run]) -> list[str]:
    """Suffixes for per-run figure names: none for one run, ``_<name>`` for several (made unique
    with the run's position when two directories share a name)."""
    if len(runs) == 1:
        return [""]
    names = [run.name for run in runs]
    return [f"_{name}" if names.count(name) == 1 else f"_{name}-{i + 1}"
            for i, name in enumerate(names)]


def fields_in_window(fields: Fields, window: tuple[float, float] | None) -> Fields:
    """The saved steps with t0 ≤ t ≤ t1 (all without a window; none is possible)."""
    if window is None:
        return fields
    keep = (fields.t >= window[0]) & (fields.t <= window[1])
    return replace(fields, t=fields.t[keep], **{name: getattr(fields, name)[keep]
                                               for name in FUNCTIONS
                                               if getattr(fields, name) is not None})
