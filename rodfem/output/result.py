"""A run as Python holds it (:class:`Result`) and a run directory read back into one (:func:`load`,
``rodfem.load``): below the API and the studies, which both give and read runs.

    >>> r = rodfem.load("out")
    >>> r.history["u_1"][-1], r.fields.theta[:, 0]      # θ(0, t) = θ_A at every saved step

Labelled data are NumPy's own: the history is a structured array (a column per name, e.g.
``r.history["u_1"]``, ``r.history.dtype.names``), the fields a small dataclass of arrays with
their coordinates (:class:`rodfem.output.readers.Fields`). The bridges give them to pandas and
xarray, imported only when called (:mod:`rodfem.output.frames`): ``r.to_pandas()``,
``r.fields.to_xarray()``; ``r.plot()`` draws the main curves. The reprs are a few lines.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rodfem.output.columns import COLUMNS, for_scene
from rodfem.output.frames import history_frame, number, scene_attrs
from rodfem.output.measures import measures as _measures
from rodfem.output.readers import Fields
from rodfem.scene import Scene, SceneError
from rodfem.scene import load as load_scene
from rodfem.scene.expressions import shorten
from rodfem.scene.scene import wrapped

# The measures a Result's repr shows (with those the scene declares).
SHOWN = ("u_1_final", "max_penetration", "contact_fraction", "energy_final")


@dataclass(frozen=True)
class Result:
    """A run: what :func:`simulate` did, or what :func:`load` read.

    Attributes:
        scene: the resolved scene (every key, defaults filled in): ``r.scene["model.k"]``.
        summary: what ``summary.json`` holds: status, steps, iterations, seconds, versions…
        history: the rows of ``history.h5``, one per kept step n = 0 … N (every step, or every
            n-th with ``output.history_every``), as a structured array:
            ``r.history["u_1"]`` (the default columns :data:`rodfem.output.columns.COLUMNS`,
            then those the scene's ``output.history`` and ``output.probes`` add). The times are
            ``r.history["t"]`` as the run wrote them: an adaptive run's steps vary, so a row's
            time is never to be taken as n·Δt.
        saved_fields: the fields, or what reads them (for :attr:`fields`).
        path: the run directory, or None for a run in memory.
    """

    scene: Scene
    summary: dict
    history: np.ndarray
    saved_fields: Fields | Callable[[], Fields | None] | None = dataclasses.field(
        default=None, repr=False)
    path: Path | None = None

    @functools.cached_property
    def fields(self) -> Fields | None:
        """The saved fields (``output.fields``: θ, the physical temperature, u and σ by
        default) at every saved step, with ``t``, ``x`` and ``x_cells``
        (:class:`rodfem.output.readers.Fields`); None where none were saved. A run directory's
        are read when first asked for."""
        fields = self.saved_fields() if callable(self.saved_fields) else self.saved_fields
        return None if fields is None else dataclasses.replace(fields,
                                                               attrs=scene_attrs(self.scene))

    @property
    def status(self) -> str:
        """complete, failed or interrupted (for a directory read by :func:`load`: also
        ``gone``, a run killed before it could say how it ended, or ``running``)."""
        return self.summary["status"]

    @property
    def measures(self) -> dict[str, float | int]:
        """The run's measures by name, as a sweep records them (the built-in ones of
        :mod:`rodfem.output.measures`, then those the scene declares, :mod:`rodfem.scene.measures`);
        empty for a run with no step on the disk."""
        if len(self.history) == 0:
            return {}
        columns = {name: self.history[name] for name in self.history.dtype.names}
        return _measures(columns, self.scene, self.summary)

    @property
    def errors(self) -> dict[str, float]:
        """The estimated absolute error of each measure held to an accuracy target
        (``[accuracy]``: summary.json's ``errors``); empty for a run without one."""
        return dict(self.summary.get("errors") or {})

    def to_pandas(self):
        """The history as a ``pandas.DataFrame`` indexed by t (a row per kept step, as
        :attr:`history`), a column per other name with the history's own values and dtype
        (``frame.reset_index()`` makes t a column again); ``frame.attrs`` names the scene
        (``scene``, ``description``, ``scene_toml``). Needs pandas."""
        return history_frame(self.history, scene_attrs(self.scene))

    def plot(self, columns=None, ax=None, path=None, format=None):
        """The history's main curves against t with matplotlib's pyplot: u(1, t) with the gap,
        σ(1, t) and the energy Ê, a panel each, their axes labelled with units. ``columns``:
        other history columns, a panel each; ``ax``: draw them all on that Axes instead;
        ``path``: also write the figure there, as PNG, PDF or SVG (``format``, else the path's
        suffix, else the scene's ``output.figure_format``). Returns the Axes (an array of them,
        one per panel, without ``ax``)."""
        from rodfem import quicklook

        meanings = {c.name: c.meaning for c in for_scene(self.scene)}
        axes = quicklook.history(self.history, meanings, _title(self),
                                 self.scene["obstacle.gap"], columns, ax)
        if path is not None or format is not None:
            quicklook.save(axes, path, format, self.scene)
        return axes

    def __repr__(self) -> str:
        rows, names = len(self.history), self.history.dtype.names
        steps = f"{self.summary['steps']} steps, " if "steps" in self.summary else ""
        reached = (f"t = {number(self.history['t'][-1])} of {number(self.scene['time.end'])}"
                   if rows else "no step recorded")
        lines = [f"<rodfem.Result {self.status}: {_title(self)}, {steps}{reached}; history of "
                 f"{rows} rows × {len(names)} columns>"]
        if self.summary.get("error"):
            lines.append(f"    error: {shorten(str(self.summary['error']), 120)}")
        measures = self.measures
        shown = [*SHOWN, *(d.name for d in getattr(self.scene, "measures", ()))]
        shown = [name for name in shown if name in measures]
        if shown:
            lines += wrapped([*(f"{name} = {number(measures[name])}" for name in shown[:8]),
                              *(["…"] if len(shown) > 8 else [])], "    measures: ")
        if self.path is not None:
            lines.append(f"    path: {self.path}")
        return "\n".join(lines)


def _title(result: Result) -> str:
    """The scene a result is of: where it came from (a built-in name, a path)."""
    return result.scene.source or "(a scene)"


def named_history(rows: np.ndarray, columns=COLUMNS) -> np.ndarray:
    """Rows of a history (steps × columns) as a structured array with the columns' names."""
    dtype = [(c.name, np.int64 if c.integer else np.float64) for c in columns]
    history = np.empty(len(rows), dtype=dtype)
    for i, column in enumerate(columns):
        history[column.name] = rows[:, i]
    return history


def load(path: str | Path) -> Result:
    """The :class:`Result` of a run directory of ``rodfem run`` (complete, failed,
    interrupted, or killed: what its files hold). The history is read at once, by the names its
    file holds, and must be the scene's; the fields when first asked for (``result.fields``).

    Raises:
        rodfem.output.readers.RunDirectoryError: ``path`` is not a readable run directory (a
            directory of another command is named with its loader), or its scene.toml does not
            describe its history (edited).
    """
    from rodfem.output.directories import read_marker, state
    from rodfem.output.kinds import other_kind
    from rodfem.output.readers import RunDirectoryError, history_path, read_history

    path = Path(path)
    if (other := other_kind(path, "run")) is not None:
        raise RunDirectoryError(other)
    if not (path / "scene.toml").is_file() or read_marker(path) is None:
        raise RunDirectoryError(f"{path} is not a rodfem run directory (it has no scene.toml "
                                "or rodfem.json)")
    try:
        scene = load_scene(str(path / "scene.toml"))
    except SceneError as err:
        raise RunDirectoryError(f"{path / 'scene.toml'}: {err}") from None
    columns = for_scene(scene)
    names = tuple(c.name for c in columns)
    history_file = history_path(path)
    if history_file.exists():
        history = read_history(history_file, empty=True)
        if history.names != names:
            raise RunDirectoryError(
                f"{path / 'scene.toml'} does not describe {history_file} (the scene records "
                f"{','.join(names)}; the file holds {','.join(history.names)}): was it edited?")
        rows = history.rows
    else:  # killed before its first checkpoint: no step on the disk yet
        rows = np.zeros((0, len(columns)))
    try:
        summary = json.loads((path / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        summary = {}
    status = state(path) or summary.get("status", "gone")
    if status in ("running", "gone"):  # summary.json, if any, is of an earlier stop: its
        # records of every step end there, so the measures are the history's
        summary = {k: v for k, v in summary.items() if k not in ("measures", "contact")}
    summary = {**summary, "status": status}
    if isinstance(summary.get("scene"), str):  # the scene it was run from, not scene.toml
        scene = dataclasses.replace(scene, source=summary["scene"])
    iterations = rows[:, names.index("iterations")]
    summary.setdefault("iterations_max", int(iterations.max()) if len(rows) else 0)
    summary.setdefault("loop_seconds", float("nan"))
    fields = _fields_of(path) if (path / "fields.xdmf").is_file() else None
    return Result(scene, summary, named_history(rows, columns), fields, path)


def _fields_of(path: Path) -> Callable[[], Fields]:
    """What reads a run directory's fields.xdmf when called (RunDirectoryError, one line)."""

    def read() -> Fields:
        from rodfem.output.readers import FieldsError, RunDirectoryError, read_fields

        try:
            return read_fields(path / "fields.xdmf")
        except FieldsError as err:
            raise RunDirectoryError(str(err)) from None

    return read
