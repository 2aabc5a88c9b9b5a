# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # A second-order time scheme, and how to know its order
#
# Run it with `mpirun -n 2 python3 demos/demo_time_schemes.py` (or without `mpirun`). With `CI`
# set in the environment it uses shorter ladders.
#
# The paper's scheme (3.1)–(3.2) is first order in time: backward Euler for the heat equation and
# for the viscous and coupling terms. `time.scheme = "crank-nicolson"` takes the same equations at
# the midpoint of the step, $\Theta^{n-1/2} = \Theta^{n-1} + \Delta\Theta^n/2$,
# $U^{n-1/2} = U^{n-1} + \Delta U^n/2$, with a velocity $V^n$ updated by the midpoint rule
# $(U^n - U^{n-1})/\Delta t = (V^n + V^{n-1})/2$, and the contact force as the discrete gradient of
# the obstacle's energy $\varphi(u) = [u - g]_+^2/(2\varepsilon)$ between the two steps. Its energy
# obeys an exact identity, contact included (docs/time-schemes.md):
#
# $$\tilde E^n - \tilde E^{n-1} = -\Delta t\,(\|\Theta^{n-1/2}_x\|^2 + k\,\Theta^{n-1/2}(1)^2
#   + \zeta\,\|\delta^n_x\|^2) \le 0.$$

# +
import os

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.model import manufactured
from rodfem.run import simulate

COMM = MPI.COMM_WORLD
SHORT = bool(os.environ.get("CI"))


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


def slope(steps, errors) -> float:
    """The observed order: the least-squares slope of log error against log step."""
    return float(np.polyfit(np.log(steps), np.log(errors), 1)[0])


# -

# ## The manufactured solution
#
# The built-in scene `manufactured` adds body sources to (1.1)–(1.2) that keep
# $u = (\cos t + \sin t)\sin(\pi x/2)$, $\theta = e^{-t}x(1-x)^2$ an exact solution, with the
# obstacle out of reach. On a fine mesh the error at $t = 1$ is the time scheme's:

# +
dts = [0.02, 0.01, 0.005] if SHORT else [0.02, 0.01, 0.005, 0.0025]
for scheme in ("paper", "crank-nicolson"):
    errors = []
    for dt in dts:
        scene = manufactured.scene(1000, dt, 1.0, [f"time.scheme={scheme}"])
        errors.append(manufactured.errors(simulate(scene, None, COMM, progress=False), scene))
    u = [e["u"] for e in errors]
    say(f"{scheme:15s} L2 error of u at t = 1: " + ", ".join(f"{e:.2e}" for e in u)
        + f"; order {slope(dts, u):.2f}")
# -

# ## With contact
#
# On the paper's first experiment the rod hits the obstacle and leaves it again. Both schemes keep
# their energy non-increasing; Crank–Nicolson's, being second order, moves far less when the step
# is halved.

# +
end = "time.end=2" if SHORT else "time.end=8"
for scheme in ("paper", "crank-nicolson"):
    finals, non_increasing = [], True
    for dt in (0.002, 0.001):
        run = simulate(rodfem.scene.load("paper1", [f"time.scheme={scheme}", "solver.method=direct",
                                                    f"time.dt={dt}", end]), None, COMM,
                       progress=False)
        finals.append(run.history[-1, 5])
        non_increasing = non_increasing and run.summary["energy_non_increasing"]
    say(f"{scheme:15s} energy at the end {finals[1]:.8f} (change on halving Δt "
        f"{abs(finals[1] - finals[0]):.1e}); energy non-increasing: {non_increasing}")
# -
