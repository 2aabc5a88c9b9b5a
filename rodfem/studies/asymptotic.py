"""Whether an observed order of ``rodfem verify`` can be trusted, and what it may be used for.

* **The expected orders**: P1 elements converge at order 2 in h (u and θ in L², and the smooth
  functionals of them); a time scheme at its own order in Δt
  (:attr:`rodfem.solver.time_schemes.TimeScheme.order`: 1 for "paper", 2 for "crank-nicolson");
  adaptive steps, which hold the error of each step to the tolerance, at q/(q + 1) in the
  tolerance for a scheme of order q (1/2 and 2/3: each step's error of order Δt^(q+1) is the
  tolerance, the steps number tol^(−1/(q+1)), and the global error is tol^(q/(q+1))). The impact's
  ladder h = Δt, against a solution with kinks, has no expected order.
* **The band** (:data:`BAND`): an observed order within ±0.25 of the expected one is in the
  asymptotic range. Outside it the error is not yet the leading term of its expansion, and any
  extrapolation from it is a guess: the tables say "pre-asymptotic: refine further" and give no
  Richardson estimate. Why 0.25: three rungs refined by 2 measure an order from two differences,
  and the next term of the expansion moves it by (m₁ − m₀)/(m₂ − m₁)'s share of that term; at
  the sizes of the quick ladders it moves it by 0.01 to 0.08 on smooth scenes
  (tests/test_verify_scene.py), so 0.25 is three times the largest seen where the expansion
  holds, and a quarter of the smallest expected order in Δt (0.5 in a tolerance excepted).
* **Richardson's estimate** within the band uses the expected order, not the observed one: with
  the true order the estimate cancels the leading term of the error exactly, and what is left is
  of the next order; with the observed order it leaves a part of the leading term itself.
* **Measures set by the steps** (:func:`stepped`) have no order at all: a count, a fraction of
  the steps, the time of a step. Their values move by whole steps as a ladder refines, so that
  their differences neither shrink at a rate nor extrapolate.
"""

from __future__ import annotations

import math

from rodfem.scene.measures import (SMOOTH_REDUCTIONS, STEPPED_COLUMNS,  # noqa: F401
                                   STEPPED_REDUCTIONS)

# P1 elements: the order of u and θ in L² and of smooth functionals of them.
SPACE_ORDER = 2
# An observed order within this of the expected one is in the asymptotic range (the docstring).
BAND = 0.25
PRE_ASYMPTOTIC = "pre-asymptotic: refine further"
STEPPED = "set by the steps, no order"
# The built-in measures (rodfem.output.measures.MEASURES) set by the steps in every run: the time
# reached, and counts. With fixed steps, the contact's fraction of the steps and the time of
# the step where it last changed are too; an adaptive run locates each contact event (to 1e-10
# in time) and weighs its steps by their lengths, so that its contact times and fraction follow
# the solution and converge with it.
STEPPED_MEASURES = ("t_final", "contact_intervals", "iterations_max")
FIXED_STEP_MEASURES = ("contact_fraction", "last_contact_change")
# The built-in measures that follow the solution: their order is checked.
SMOOTH_MEASURES = ("u_1_final", "sigma_1_final", "max_penetration", "energy_final")
# Declared measures: which are set by the steps is the scene layer's (Declared.stepped).
# With adaptive steps the h ladder runs at the tolerance ladder's finest tolerance, whose time
# error that ladder measures (against its reference): where it is more than this fraction of the
# smallest difference an order in h rests on (the finest rung's error; a measure's last
# difference), the order in h is flagged. At a twentieth it moves an error's order by
# log2((1 + 1/80)/(1 − 1/20)) = 0.09 at most, and a measure's (each value off by at most a
# twentieth of the last difference) by log2((1 + 1/40)/(1 − 1/10)) = 0.19: inside the band.
POLLUTION = 0.05
TIME_ERROR = "the adaptive steps' time error: tighten time.tolerance"


def expected(refined: str, scheme: str) -> float:
    """The expected order of a ladder refining ``refined`` ("h", "dt", "tol" or "h=dt") with
    the time scheme ``scheme``; nan where none is expected (h = Δt, the impact's kinks)."""
    from rodfem.solver.time_schemes import TIME_SCHEMES

    q = TIME_SCHEMES[scheme].order
    return {"h": float(SPACE_ORDER), "dt": float(q), "tol": q / (q + 1.0)}.get(refined, math.nan)


def within(order: float, expect: float) -> bool:
    """Whether an observed order is within :data:`BAND` of the expected one."""
    return math.isfinite(order) and math.isfinite(expect) and abs(order - expect) <= BAND


def check(order: float, expect: float) -> str:
    """"" for an order in the band, or none to check (nan, or no expected order);
    "pre-asymptotic" outside it."""
    if not (math.isfinite(order) and math.isfinite(expect)) or within(order, expect):
        return ""
    return "pre-asymptotic"


def stepped(scene) -> tuple[str, ...]:
    """The measures of ``scene`` set by its steps (the module's docstring): no order for them."""
    names = STEPPED_MEASURES + (() if scene.adaptive else FIXED_STEP_MEASURES)
    declared = tuple(m.name for m in getattr(scene, "measures", ()) if m.stepped)
    return names + declared


def estimate(values: list[float], expect: float) -> float:
    """Richardson's estimate of m_∞ − m₂ from the last three values of a ladder refined by 2,
    with the expected order p: (m₂ − m₁)/(2^p − 1)."""
    return (values[-1] - values[-2]) / (2.0 ** expect - 1.0)
