"""Figures of rodfem runs, drawn off-screen (matplotlib; the animations with pyvista):
``rodfem plot DIR [DIR ...]``.

The end of the chain scene → forms → solver → output → post: it reads a run's files
(``history.h5``, ``scene.toml``, ``fields.xdmf``) and imports nothing from the solver side.
"""

from rodfem.post import backend  # noqa: F401 (loads VTK before anything else: see there)
from rodfem.post.plot import plot
from rodfem.post.runs import PlotError, Run, RunDirectoryError, load_run

__all__ = ["PlotError", "Run", "RunDirectoryError", "load_run", "plot"]
