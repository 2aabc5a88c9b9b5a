"""The methods that solve a step of the time scheme, by name (``solver.method``).

* ``direct``: the step in one solve and a scalar equation, exact (:mod:`.direct`);
* ``newton``: PETSc SNES, semismooth Newton, and a variational inequality for the rigid obstacle
  (:mod:`.newton`);
* ``picard``: the paper's iteration (3.3)–(3.4) (:mod:`.picard`).

Each is a :class:`~rodfem.solver.methods.base.Method`; :func:`make_method` asks this registry.
Newton's (PETSc's SNES) is imported when first asked for: the others' runs need no petsc4py
where their operators are NumPy's (:mod:`rodfem.discrete.arrays`).
"""

from __future__ import annotations

from rodfem.solver.methods.base import Method
from rodfem.solver.methods.direct import DirectMethod
from rodfem.solver.methods.picard import PicardMethod


class _Registry(dict):
    """Method classes by name; a module's name (Newton's) is imported on first use."""

    def __getitem__(self, name: str) -> type[Method]:
        found = super().__getitem__(name)
        if isinstance(found, str):
            import importlib

            module, _, cls = found.partition(":")
            found = getattr(importlib.import_module(module), cls)
            self[name] = found
        return found


REGISTRY: dict[str, type[Method]] = _Registry({
    "direct": DirectMethod,
    "newton": "rodfem.solver.methods.newton:NewtonMethod",
    "picard": PicardMethod,
})


def make_method(disc, dt: float | None = None) -> Method:
    """The method of the scene's ``solver.method``, set up on ``disc`` for its Δt, or for a step
    ``dt`` (an adaptive run's other steps: made inside ``disc.at_step(dt)``)."""
    return REGISTRY[disc.scene["solver.method"]](disc, dt)


def __getattr__(name: str):
    if name == "NewtonMethod":
        return REGISTRY["newton"]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["REGISTRY", "DirectMethod", "Method", "NewtonMethod", "PicardMethod", "make_method"]
