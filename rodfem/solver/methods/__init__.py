"""The methods that solve a step of the time scheme, by name (``solver.method``).

* ``direct``: the step in one solve and a scalar equation, exact (:mod:`.direct`);
* ``newton``: PETSc SNES, semismooth Newton, and a variational inequality for the rigid obstacle
  (:mod:`.newton`);
* ``picard``: the paper's iteration (3.3)–(3.4) (:mod:`.picard`).

Each is a :class:`~rodfem.solver.methods.base.Method`; :func:`make_method` asks this registry.
"""

from __future__ import annotations

from rodfem.solver.methods.base import Method
from rodfem.solver.methods.direct import DirectMethod
from rodfem.solver.methods.newton import NewtonMethod
from rodfem.solver.methods.picard import PicardMethod

REGISTRY: dict[str, type[Method]] = {
    "direct": DirectMethod,
    "newton": NewtonMethod,
    "picard": PicardMethod,
}


def make_method(disc, dt: float | None = None) -> Method:
    """The method of the scene's ``solver.method``, set up on ``disc`` for its Δt, or for a step
    ``dt`` (an adaptive run's other steps: made inside ``disc.at_step(dt)``)."""
    return REGISTRY[disc.scene["solver.method"]](disc, dt)


__all__ = ["REGISTRY", "DirectMethod", "Method", "NewtonMethod", "PicardMethod", "make_method"]
