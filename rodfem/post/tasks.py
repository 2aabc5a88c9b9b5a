"""One figure to draw (:class:`Task`) and the drawing of it (:func:`draw`): what
:mod:`rodfem.post.plot` plans and what it, or a worker process of :mod:`rodfem.post.pool`,
carries out."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rodfem.post import backend
from rodfem.post.runs import Run, fields_in_window


@dataclass(frozen=True)
class Task:
    """One figure to draw: its kind (``contact``, ``energy``, ``spacetime``, ``rod``), the runs
    it shows with their labels, the file, the field of a map, and the window and colouring."""

    kind: str
    runs: tuple[Run, ...]
    labels: tuple[str, ...]
    path: Path
    field: str | None = None
    window: tuple[float, float] | None = None
    colour_by: str | None = None


def draw(task: Task) -> Path:
    """Draw one figure (in this process or a worker's) and return its file."""
    from rodfem.post.animation import rod_animation
    from rodfem.post.curves import contact_figure, energy_figure
    from rodfem.post.spacetime import spacetime_figure

    backend.off_screen()
    runs, labels = list(task.runs), list(task.labels)
    if task.kind == "contact":
        return contact_figure(runs, labels, task.path, task.window, task.colour_by)
    if task.kind == "energy":
        return energy_figure(runs, labels, task.path, task.window, task.colour_by)
    if task.kind == "spacetime":
        fields = fields_in_window(runs[0].fields, task.window)
        return spacetime_figure(fields, task.field, labels[0], task.path, runs[0].history,
                                runs[0].gap)
    return rod_animation(runs[0], labels[0], task.path, task.window)
