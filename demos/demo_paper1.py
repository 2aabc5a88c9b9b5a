# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # A thermoviscoelastic rod hits an elastic obstacle (Copetti, experiment 1)
#
# Run it with `mpirun -n 2 python3 demos/demo_paper1.py` (or without `mpirun`). With `CI` set in
# the environment it stops at t = 1.
#
# ## The model
#
# A rod on $I = (0, 1)$, clamped at $x = 0$ and held there at temperature $\theta_A$, has
# temperature $\theta$ and displacement $u$:
#
# $$\theta_t - \theta_{xx} = -a u_{xt}, \qquad b u_{tt} - \sigma_x = 0, \qquad
#   \sigma = u_x + \zeta u_{xt} - a\theta .$$
#
# Its free end exchanges heat with an obstacle at distance $g$, $-\theta_x(1) = k\theta(1)$, and
# pushes into it elastically: $\sigma(1) = -\frac1\varepsilon [u(1) - g]_+$. The paper works with
# the shifted temperature $\hat\theta = \theta + \theta_A r$, $r = cx - 1$, $c = k/(k+1)$, which
# vanishes at $x = 0$ and satisfies a homogeneous Robin condition at $x = 1$.

# +
import argparse
import os
import sys

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.columns import INDEX
from rodfem.output.history import History
from rodfem.solver.methods.picard import PicardMethod

# -

# ## The scene
#
# Experiment 1 is a built-in scene: $a = 0.017$, $g = 0.1$, $\theta_A = 10$, $\varepsilon = 0.01$,
# $k = 1$, $\zeta = 0.2$, 250 cells and $\Delta t = 10^{-3}$ up to $T = 8$, with
# $\theta_0 = \theta_A(\cos 2\pi x - \sin \frac{\pi x}{2})$, $u_0 = 0$, $u_1 = 20x(x-1)^2$.
# Anything can be overridden the way `rodfem run --set` does it.


# ## The scheme (3.1)–(3.2) and its Picard iteration (3.3)–(3.4)
#
# P1 elements on a uniform mesh; $S_E$ holds the P1 functions vanishing at $x = 0$. For
# $n \ge 2$, with $\Theta^{n,0} = \Theta^{n-1}$ and $U^{n,0} = U^{n-1}$, each Picard iteration
# solves the heat equation with the last displacement iterate, then the momentum equation with
# the new temperature and the contact pressure of the last iterate:
#
# $$\tfrac{1}{\Delta t}(\Theta^{n,l} - \Theta^{n-1}, w) + (\Theta^{n,l}_x, w_x)
#   + \tfrac{a}{\Delta t}(U^{n,l-1}_x - U^{n-1}_x, w) + k\Theta^{n,l}(1)w(1) = 0,$$
#
# $$\tfrac{b}{\Delta t^2}(U^{n,l} - 2U^{n-1} + U^{n-2}, v)
#   + (U^{n,l}_x - a\Theta^{n,l} + a\theta_A r, v_x)
#   + \tfrac{\zeta}{\Delta t}(U^{n,l}_x - U^{n-1}_x, v_x)
#   + \tfrac1\varepsilon[U^{n,l-1}(1) - g]_+ v(1) = 0 .$$
#
# These are `forms.copetti.heat` and `forms.copetti.momentum` (+ `contact`). `PicardMethod` solves
# the same equations for the increments $\Delta\Theta^n = \Theta^n - \Theta^{n-1}$ and
# $\Delta U^n = U^n - U^{n-1}$ (`heat_increment`, `momentum_increment`): written for $U^n$, the
# second difference $U^n - 2U^{n-1} + U^{n-2}$ subtracts numbers of size $|U|/\Delta t^2$ and
# loses $10^{-10}$ of the acceleration to round-off every step. Both equations are linear in
# their unknown, so their matrices are read off the forms, assembled and LU-factored once; each
# iteration is two mat-vecs and two triangular solves.
#
# ## The time loop
#
# $\Theta^0$, $U^0$, $U^1$ are the nodal interpolants of the initial data; $\Theta^1$ comes from
# (3.1) with $U^1$ known. Every step is recorded: point values at $x = 1$ and $x = 0.5$ and the
# energy $\hat E^n$ of Remark 4.4.


def run(end: float = 8.0, zeta: float = 0.2) -> np.ndarray:
    """Simulate experiment 1 up to ``end``; return the history rows (t, u_1, u_half, ut_1,
    sigma_1, energy, iterations)."""
    scene = rodfem.scene.load("paper1", [f"time.end={end}", f"model.zeta={zeta}"])
    disc = Discretisation(scene, MPI.COMM_WORLD)
    scheme = PicardMethod(disc)
    history = History(disc, block=scene.steps + 1)
    history.record(scheme)
    for _ in range(scene.steps):
        scheme.advance()
        history.record(scheme)
    return history.take()


# ## What happens
#
# The rod first oscillates, touching the obstacle ($u(1) > g$, $\sigma(1) < 0$) and leaving it;
# as it warms and the oscillations die out it comes to rest pressed against it. The energy
# $\hat E^n$ never increases (Remark 4.4).


def report(rows: np.ndarray, gap: float = 0.1) -> None:
    t, u_1, sigma_1, energy = (rows[:, INDEX[c]] for c in ("t", "u_1", "sigma_1", "energy"))
    touching = u_1 > gap
    starts = np.flatnonzero(np.diff(touching.astype(int)) == 1) + 1
    print(f"{len(starts)} intervals of contact; first at t = {t[starts[0]]:.3f}"
          if starts.size else "no contact")
    print(f"at t = {t[-1]:g}: u(1) = {u_1[-1]:.5f}, sigma(1) = {sigma_1[-1]:.5f}, "
          f"in contact: {bool(touching[-1])}")
    print(f"energy {energy[0]:.3f} -> {energy[-1]:.5f}; "
          f"max increase over n >= 2: {np.diff(energy)[1:].max():.2e}")
    iterations = rows[:, INDEX["iterations"]]
    print(f"Picard iterations per step: {iterations[2:].mean():.2f} (max {int(iterations.max())})")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--end", type=float, default=1.0 if os.environ.get("CI") else 8.0,
                        help="end time T")
    parser.add_argument("--zeta", type=float, default=0.2, help="viscosity ζ")
    args = parser.parse_args()
    rows = run(args.end, args.zeta)
    if MPI.COMM_WORLD.rank == 0:
        report(rows)
    sys.exit(0)
