"""The time scale of a scene's contact, and whether a fixed time step resolves it (NumPy only).

An elastic obstacle of compliance ε pushes back on the rod (density b) over a time of the order
of √(b ε), the period scale of a mass b on a spring of stiffness 1/ε. A fixed step that takes
few steps per √(b ε) misses the peak of the contact stress: the paper's first-order scheme damps
it (−17 % to −30 % at 10 steps per √(b ε), ζ = 1 … 0.1), Crank–Nicolson samples it between two
steps (+2.8 % there). The number of steps needed per √(b ε) is :data:`STEPS_NEEDED`, calibrated
by ``benchmarks/bench_contact_step.py`` on the ``stiff`` scene over ζ ∈ {0.1, 0.2, 0.5, 1} × ε ∈
{1e-2, 1e-3, 1e-4} (docs/time-schemes.md gives the table): at the step the warning offers, and
at exactly that many steps per √(b ε) (the most the offered step's rounding can give), every
peak is within 5 % (the paper's scheme: −4.6 % at worst, ζ = 0.1) or 1.5 % (Crank–Nicolson:
+1.4 %) of the converged one. The errors do not follow the node's scale √(b h ε): at equal steps
per √(b ε) they are the same on 250 and 1000 cells.

The rigid obstacle has no such scale: an impact changes the velocity at once, inside a fixed
step, whatever its length; an adaptive run (``time.adaptive``) ends a step at each impact. b = 0
is quasi-static: nothing to resolve. The power law (``obstacle.law = "power"``, m > 1) stiffens
with the penetration, which a scene does not tell before it runs: no warning there.

:func:`coarse_step` is the one judgement. ``rodfem run``, ``rodfem resume``, ``rodfem sweep``
and the API say what it finds (:class:`CoarseStepWarning`) after a complete run that touched the
obstacle (:func:`coarse_run`): a run that never touches it has no contact to resolve, and a
failed run says why it failed instead. Nothing about the run changes.
"""

from __future__ import annotations

import dataclasses
import math

from rodfem.scene.schema import MAX_STEPS

# Steps per √(b ε) at and above which a fixed step resolves an elastic obstacle's contact
# (docs/time-schemes.md: the calibration). The paper's scheme needs 100 at ζ = 0.1, 50 at ζ = 1:
# one number, the least viscous grid point's, holds for every ζ ≥ 0.1.
STEPS_NEEDED = {"paper": 100.0, "crank-nicolson": 20.0}
ERROR_THERE = {"paper": "5 %", "crank-nicolson": "1.5 %"}  # the calibrated peak error at most
ROUNDING = 1e-9  # √(b ε)/Δt at a fixed step's bound is that bound, whatever the rounding
SCHEME_NAMES = {"paper": "the paper's scheme", "crank-nicolson": "Crank–Nicolson"}


class CoarseStepWarning(UserWarning):
    """A complete fixed-step run touched its obstacle with a step coarse for the contact (fewer
    steps per contact time √(b ε) than its scheme needs), or touched the rigid obstacle, whose
    impacts fall inside a step: the contact stress and the times of contact may be off. The
    message is the line ``rodfem run`` prints, with its fix (``rodfem.model.timescales``)."""


@dataclasses.dataclass(frozen=True)
class CoarseStep:
    """What :func:`coarse_step` finds: a kind (``elastic`` or ``rigid``: one line each in a
    sweep), the step, the time scale (0 for the rigid obstacle), the steps per scale, a fixed
    step that would do (None: none would), and the one line that says so."""

    kind: str
    dt: float
    scale: float
    steps: float
    fix_dt: float | None
    line: str


def adaptive(scene) -> bool:
    """Whether the scene adapts its step (``time.adaptive``, where that key exists)."""
    return bool(scene.data()["time"].get("adaptive", False))


def contact_time_scale(scene) -> float:
    """√(b ε) of the elastic obstacle, 0 for the rigid one (an impact takes no time)."""
    if scene["obstacle.kind"] == "rigid":
        return 0.0
    return math.sqrt(scene["model.b"] * scene["obstacle.epsilon"])


def _dividing(end: float, most: float) -> float:
    """The largest step ≤ ``most`` of the 1, 2, 5 × 10ᵏ ladder that divides ``end`` into whole
    steps, or else end / ⌈end / most⌉."""
    decade = 10.0 ** math.floor(math.log10(most))
    for k in range(4):
        for m in (5.0, 2.0, 1.0):
            dt = float(f"{m * decade / 10.0 ** k:.1e}")
            if dt <= most * (1.0 + ROUNDING) and abs(end / dt - round(end / dt)) <= 1e-9 * end / dt:
                return dt
    return end / math.ceil(end / most)


def fix_dt(scene, needed: float) -> float:
    """The fixed step :func:`coarse_step` offers for ``needed`` steps per √(b ε): the largest of
    the 1, 2, 5 × 10ᵏ ladder at or below √(b ε)/needed that divides ``time.end``
    (``benchmarks/bench_contact_step.py`` measures the peak stress at this step itself)."""
    return _dividing(scene["time.end"], contact_time_scale(scene) / needed)


def coarse_step(scene, needed: float | None = None) -> CoarseStep | None:
    """Whether the scene's fixed step is coarse for its contact, and the one line that says so
    (None: it is not, or the scene adapts its step, is quasi-static, or its law stiffens).
    ``needed``: the steps per √(b ε) asked for (None: its scheme's :data:`STEPS_NEEDED`)."""
    if adaptive(scene) or scene["model.b"] == 0.0:
        return None
    dt, scheme = scene["time.dt"], scene["time.scheme"]
    fix = "time.adaptive = true"
    if scene["obstacle.kind"] == "rigid":
        return CoarseStep("rigid", dt, 0.0, 0.0, None, (
            f"the rigid obstacle's impacts take no time and fall inside a fixed step "
            f"(time.dt = {dt:g}): the times of contact and the contact stress are off by up to "
            f"a step, whatever its length; fix: {fix} (a step ends at each impact)"))
    if scene["obstacle.law"] == "power" and scene["obstacle.exponent"] > 1.0:
        return None
    scale = contact_time_scale(scene)
    steps, needed = scale / dt, needed or STEPS_NEEDED[scheme]
    if steps >= needed * (1.0 - ROUNDING):  # the fix offered below does not warn again
        return None
    end, offered = scene["time.end"], fix_dt(scene, needed)
    if end / offered <= MAX_STEPS:
        fix += f", or time.dt = {offered:g}"
    else:
        offered = None
    return CoarseStep("elastic", dt, scale, steps, offered, (
        f"time.dt = {dt:g} is coarse for this obstacle: {steps:.3g} steps per contact time "
        f"√(b ε) = {scale:.3g}, where {SCHEME_NAMES[scheme]} needs {needed:g} to hold the peak "
        f"contact stress within {ERROR_THERE[scheme]}; it and the times of contact may be "
        f"off; fix: {fix}"))


def coarse_run(scene, summary: dict) -> CoarseStep | None:
    """:func:`coarse_step` of a complete run that touched the obstacle (its summary's record of
    contact counts a step in contact); None for any other run."""
    contact = summary.get("contact")
    if summary.get("status") != "complete" or not isinstance(contact, dict) \
            or not contact.get("touching"):
        return None
    return coarse_step(scene)


def study_line(judged: list[CoarseStep], total: int, where: str) -> str | None:
    """The one line of a study over many runs (``rodfem fit``, ``rodfem sensitivity``): how many
    of its ``total`` runs had a fixed step coarse for their contact (``judged``: their
    :func:`coarse_step`), where they are flagged, and the line of the coarsest, with its fix
    (None: none was)."""
    if not judged:
        return None
    worst = min(judged, key=lambda c: (c.kind != "elastic", c.steps))
    return (f"{len(judged)} of the {total} runs had a fixed step coarse for their contact "
            f"({where}); the coarsest: {worst.line}")
