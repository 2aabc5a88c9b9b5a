"""The obstacle at x = 1: one module per contact law, and the registry that picks one for a scene.

An elastic obstacle stores an energy φ(u) in the rod's end displacement u = u(1) and pushes back
with φ'(u), so σ(1) = −φ'(u(1)). Each law (:class:`~rodfem.model.contact.law.ContactLaw`) gives
φ, φ', φ'', the discrete gradient (φ(y) − φ(c))/(y − c) that Crank–Nicolson uses, and the one
scalar equation a step of the direct method solves, y + w p(y) = s. The compiled loops share the
same laws in ``rodfem/solver/compiled/contact.h``, law by law.

* ``linear``: the paper's (1.5), φ = [u − g]₊²/(2ε) (:mod:`.linear`, closed forms);
* ``power``: normal compliance, φ = [u − g]₊^{m+1}/((m + 1)ε), m ≥ 1 (:mod:`.power`);
* the rigid obstacle, Signorini's u(1) ≤ g (:mod:`.rigid`): a multiplier, no energy.
"""

from __future__ import annotations

from rodfem.model.contact.law import ContactLaw
from rodfem.model.contact.linear import LinearLaw
from rodfem.model.contact.power import PowerLaw
from rodfem.model.contact.rigid import RigidObstacle

LAWS: dict[str, type[ContactLaw]] = {"linear": LinearLaw, "power": PowerLaw}


def obstacle(kind: str, law: str, gap: float, epsilon: float,
             exponent: float = 1.0) -> ContactLaw | RigidObstacle:
    """The obstacle a scene names (``obstacle.kind``, ``.law``, ``.gap``, ``.epsilon``,
    ``.exponent``). The power law with m = 1 is the linear law, and is given as it (its closed
    forms), so that it reproduces the paper's runs exactly."""
    if kind == "rigid":
        return RigidObstacle(gap)
    if law == "power" and exponent == 1.0:
        law = "linear"
    return LAWS[law](gap, epsilon, exponent)


def of_scene(scene) -> ContactLaw | RigidObstacle:
    """The obstacle of a validated scene."""
    return obstacle(scene["obstacle.kind"], scene["obstacle.law"], scene["obstacle.gap"],
                    scene["obstacle.epsilon"], scene["obstacle.exponent"])


__all__ = ["LAWS", "ContactLaw", "LinearLaw", "PowerLaw", "RigidObstacle", "obstacle",
           "of_scene"]
