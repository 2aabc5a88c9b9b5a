"""The heat the rod exchanges with the obstacle at x = 1: one module per law, and the registry.

The boundary condition is −θ_x(1, t) = h (θ(1, t) − θ_O), θ_O the obstacle's temperature
(``obstacle.temperature``), with h = k + q: k the paper's constant (``model.k``) and q ≥ 0 what
the contact adds, a function of the end's state (``[heat_exchange]``):

* ``constant``: q = 0, the paper's (1.3) (:mod:`.law`);
* ``pressure``: q = k₁ p^m, p = −σ(1) ≥ 0 the contact pressure, Barber's condition
  (:mod:`.pressure`);
* ``gap``: q = k₁ exp(min(u(1) − g, 0)/ℓ), which falls off with the gap and is k₁ in contact,
  Kuttler and Shillor's (:mod:`.gap`).

The scheme keeps k where the paper has it (its operators, the Robin shift of the temperature) and
adds q's flux q (θ(1) − θ_O) at x = 1 as a load that depends on the step (forms.copetti.exchange).
"""

from __future__ import annotations

from rodfem.model.exchange.gap import GapLaw
from rodfem.model.exchange.law import ConstantLaw, ExchangeLaw
from rodfem.model.exchange.pressure import PressureLaw

LAWS: dict[str, type[ExchangeLaw]] = {"constant": ConstantLaw, "pressure": PressureLaw,
                                      "gap": GapLaw}


def of_scene(scene) -> ExchangeLaw:
    """The heat-exchange law of a validated scene."""
    name = scene["heat_exchange.law"]
    k, temperature = scene["model.k"], scene["obstacle.temperature"]
    if name == "pressure":
        return PressureLaw(k, temperature, scene["heat_exchange.k1"],
                           scene["heat_exchange.exponent"])
    if name == "gap":
        return GapLaw(k, temperature, scene["heat_exchange.k1"], scene["obstacle.gap"],
                      scene["heat_exchange.length"])
    return ConstantLaw(k, temperature)


__all__ = ["LAWS", "ConstantLaw", "ExchangeLaw", "GapLaw", "PressureLaw", "of_scene"]
