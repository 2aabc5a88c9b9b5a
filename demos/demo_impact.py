# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # An impact on a rigid wall, with its exact solution
#
# Run it with `mpirun -n 2 python3 demos/demo_impact.py` (or without `mpirun`). With `CI` set in
# the environment it uses coarser meshes.
#
# The built-in scene `impact` is the standard benchmark of dynamic contact (GetFEM's
# `demo_dynamic_contact_1D`): the wave equation $u_{tt} = u_{xx}$ on $(0, 1)$, clamped at
# $x = 0$, a rigid wall at $g = 0$, the bar released from $u_0 = -x/2$ at rest. No heat
# ($a = \theta_A = 0$) and no viscosity ($\zeta = 0$), so nothing dissipates: the energy
# $\tfrac12\int (u_t^2 + u_x^2) = 1/8$ is kept for all time. The end reaches the wall at $t = 1$,
# presses it with $\sigma(1) = -1/2$ until $t = 2$, leaves, and at $t = 3$ the bar is back where it
# started (`rodfem.model.impact` holds the exact solution).

# Every fixed-step run against the rigid wall warns that its impacts fall inside a step
# (`rodfem.CoarseStepWarning`, whose fix is adaptive steps); this page measures exactly what that
# costs, so it silences the warning.

# +
import os
import warnings

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.model import impact

COMM = MPI.COMM_WORLD
SHORT = bool(os.environ.get("CI"))
warnings.simplefilter("ignore", rodfem.CoarseStepWarning)


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


# -

# ## The paper's scheme against the wall
#
# The paper's scheme (3.1)–(3.2) with the rigid obstacle: Signorini's condition
# $U^n(1) \le g$ with its multiplier, and the paper's lumped mass. It is stable, and its contact
# stress is right, but each impact costs energy: the end's velocity is stopped in one step, and
# its kinetic energy is lost.

h = 0.01 if SHORT else 0.001
paper = rodfem.simulate("impact", {"mesh.cells": round(1 / h), "time.dt": h,
                                   "time.scheme": "paper", "discretisation.mass": "lumped"})
errors = impact.errors(paper.history)
say(f"paper's scheme, h = dt = {h:g}: L1 error of u(1, .) {errors['u1_l1']:.2e}, "
    f"energy at T {paper.history['energy'][-1]:.6f} (exact 0.125)")

# ## Crank–Nicolson, and an end without mass
#
# Crank–Nicolson keeps the energy exactly (docs/time-schemes.md), but with a mass at the end and
# the end held at the wall, its midpoint rule makes the end's velocity flip sign every step, and
# the contact stress with it. `discretisation.mass = "redistributed"` moves the end's mass to its
# neighbour. The end is then in equilibrium at every instant, and rodfem eliminates it: the rest of
# the bar pushes on the wall through the last cell, and the contact force is the discrete gradient
# of that cell and the wall in series. The scene `impact` is set up so by default.

cn = rodfem.simulate("impact", {"mesh.cells": round(1 / h), "time.dt": h})
errors = impact.errors(cn.history)
energy = np.asarray(cn.history["energy"])
say(f"Crank-Nicolson, redistributed mass: L1 error {errors['u1_l1']:.2e}, contact stress off "
    f"by at most {errors['stress']:.1e} on [1.2, 1.8], largest u(1) {np.max(cn.history['u_1'])}")
say(f"its energy: {energy[0]:.15f} at t = 0, {energy[-1]:.15f} at T "
    f"(the largest change in one step {np.max(np.abs(np.diff(energy))):.1e})")

# The energy is $(1 - h)/8$ rather than $1/8$ from the start: the interpolated initial data strain
# the last cell, and an end without mass starts where its equation puts it, with the last cell
# unstrained. Apart from that it is constant to round-off through the impact, the contact and the
# release, while $u(1) \le g$ holds exactly.

# ## Order of convergence in h = Δt
#
# Through an impact the velocity jumps, and no scheme keeps its smooth-solution order. The L1
# error in time of $u(1, \cdot)$, GetFEM's measure, falls about as $h^{0.7}$:

steps = [0.02, 0.01, 0.005] if SHORT else [0.01, 0.002, 0.001, 0.0005]
l1 = [impact.errors(rodfem.simulate(impact.scene(s)).history)["u1_l1"] for s in steps]
for s, e in zip(steps, l1, strict=True):
    say(f"h = dt = {s:<7g} L1 error {e:.3e}")
say(f"observed order: {np.polyfit(np.log(steps), np.log(l1), 1)[0]:.2f}")

# On the same benchmark, GetFEM 5.4's Newmark scheme with its own redistributed mass gives
# 9.3e-3, 1.7e-3 and 1.0e-3 at h = 1e-2, 1e-3 and 5e-4 (`benchmarks/bench_impact.py` prints both).
