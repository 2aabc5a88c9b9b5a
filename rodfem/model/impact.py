"""The impact benchmark: an elastic bar released against a rigid wall, with its exact solution.

The built-in scene ``impact`` (``rodfem/scene/builtin/impact.toml``) is GetFEM's
``demo_dynamic_contact_1D`` on rodfem's geometry: the wave equation u_tt = u_xx on (0, 1) (b = 1,
a = ζ = θ_A = 0, no heat), clamped at x = 0, a rigid wall at g = 0, released from u₀ = −x/2 at
rest. The release sends a front that leaves the bar unstrained and moving at 1/2; the end reaches
the wall at t = 1, when the whole bar is at u = 0, and presses it with σ(1) = −1/2 until the
fronts reflected from the wall and from the clamp have crossed the bar twice, at t = 2; it then
leaves, and at t = 3 the bar is back in its initial state. With τ = t mod 3 and s = τ − ⌊τ⌋:

    τ ∈ [0, 1):  u = −min(x, 1 − s)/2                 u(1, t) = −(1 − s)/2,  σ(1) = 0
    τ ∈ [1, 2):  u =  min(x, 1 − x, s, 1 − s)/2       u(1, t) = 0,           σ(1) = −1/2
    τ ∈ [2, 3):  u = −min(x, s)/2                      u(1, t) = −s/2,        σ(1) = 0

and the energy ½∫(u_t² + u_x²) = 1/8 for all time. The discrete solution starts from the nodal
interpolant of u₀; with a redistributed mass the end x = 1 has none, its equation is static and
it starts where that puts it (at the interpolant's U(1 − h), the last cell unstrained), which
holds (1 − h)/8 of the energy: the wall cannot store the rest.

:func:`errors` measures a run of it as GetFEM's demo does (u(1, ·) in L¹ over the steps) and
adds what the exact solution also fixes: the energy at T and the contact stress.
"""

from __future__ import annotations

import numpy as np

from rodfem.scene.loading import Scene, load

ENERGY = 0.125  # ½∫(u_t² + u_x²), for all time
STRESS = -0.5  # σ(1) while the bar presses the wall, t ∈ (1, 2) mod 3
# Where the contact stress is judged: inside the contact interval, away from its ends, where a
# discretisation's fronts are smeared over a few cells.
CONTACT_WINDOW = (1.2, 1.8)


def _phase(t):
    """(phase 0, 1, 2 of the period, time s ∈ [0, 1) into it)."""
    tau = np.mod(np.asarray(t, dtype=float), 3.0)
    phase = np.minimum(np.floor(tau), 2.0)
    return phase, tau - phase


def displacement(x, t):
    """u(x, t), for points x (an array) at one time t."""
    phase, s = _phase(t)
    x = np.asarray(x, dtype=float)
    if phase == 0:
        return -np.minimum(x, 1.0 - s) / 2.0
    if phase == 1:
        return np.minimum(np.minimum(x, 1.0 - x), min(s, 1.0 - s)) / 2.0
    return -np.minimum(x, s) / 2.0


def end_displacement(t):
    """u(1, t) at the times t (an array)."""
    phase, s = _phase(t)
    return np.where(phase == 0, -(1.0 - s) / 2.0, np.where(phase == 1, 0.0, -s / 2.0))


def end_stress(t):
    """σ(1, t) at the times t: −1/2 in contact, else 0 (the jumps at t = 1, 2 belong to the
    free phases)."""
    phase, _ = _phase(t)
    return np.where(phase == 1, STRESS, 0.0) + np.where(np.mod(t, 3.0) == 1.0, -STRESS, 0.0)


def scene(h: float, end: float = 3.0, overrides=()) -> Scene:
    """The impact scene with h = Δt (1/h cells), up to ``end``."""
    cells = round(1.0 / h)
    return load("impact", [f"mesh.cells={cells}", f"time.dt={1.0 / cells!r}",
                           f"time.end={end!r}", *overrides])


def errors(history) -> dict[str, float]:
    """A run's errors against the exact solution, from its history (``rodfem.Result.history``
    or the columns t, u_1, sigma_1, energy):

    * ``u1_l1``: Σₙ (tⁿ − tⁿ⁻¹) |Uⁿ(1) − u(1, tⁿ)| over the steps n ≥ 1 (GetFEM's measure);
    * ``u1_max``: max over the steps of |Uⁿ(1) − u(1, tⁿ)|;
    * ``energy_T``: |E(T) − 1/8|;
    * ``stress``: max |σ(1, tⁿ) + 1/2| over the steps in the contact window [1.2, 1.8] mod 3;
    * ``flicker``: max |σ(1, tⁿ) − σ(1, tⁿ⁻¹)| over the same steps: an oscillation from step to
      step, which the exact solution does not have.
    """
    t = np.asarray(history["t"], dtype=float)
    u = np.asarray(history["u_1"], dtype=float)
    sigma = np.asarray(history["sigma_1"], dtype=float)
    difference = np.abs(u - end_displacement(t))[1:]
    tau = np.mod(t, 3.0)
    window = (tau >= CONTACT_WINDOW[0]) & (tau <= CONTACT_WINDOW[1])
    inside = np.flatnonzero(window)
    return {
        "u1_l1": float(np.sum(np.diff(t) * difference)),  # Δt of each step: adaptive ones too
        "u1_max": float(difference.max()),
        "energy_T": float(abs(history["energy"][-1] - ENERGY)),
        "stress": float(np.max(np.abs(sigma[inside] - STRESS))) if inside.size else np.nan,
        "flicker": float(np.max(np.abs(np.diff(sigma[inside])))) if inside.size > 1 else np.nan,
    }
