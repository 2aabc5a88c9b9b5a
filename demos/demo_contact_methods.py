# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Three ways to solve a step, and the rigid obstacle
#
# Run it with `mpirun -n 2 python3 demos/demo_contact_methods.py` (or without `mpirun`). With `CI`
# set in the environment it uses shorter runs.
#
# Each step of Copetti's scheme (3.1)–(3.2) couples the heat equation for $\Theta^n$ to the
# momentum equation for $U^n$, and adds the contact force $p = \frac1\varepsilon[U^n(1) - g]_+$ at
# $x = 1$. rodfem solves that step in one of three ways (`solver.method`):
#
# * `picard`: the paper's iteration (3.3)–(3.4), which freezes the other unknown and the contact
#   force and iterates until the change is below `solver.tol`;
# * `direct`: the step is linear but for the one scalar $p$. The coupled operator is factored
#   once, with its response $q$ to a unit force at $x = 1$; a step is one solve, and then $p$ in
#   closed form from $U^n(1) = s - p\,w$, where $s$ is $U^n(1)$ without contact and $w = -q_U(1)$
#   the rod's compliance over a step: $p = (s - g)/(\varepsilon + w)$ if $s > g$, else 0;
# * `newton`: the coupled step as one nonlinear system, solved by PETSc's SNES, semismooth Newton
#   with the generalized derivative of $[\cdot]_+$.
#
# The last two solve (3.1)–(3.2) exactly; `picard` to its tolerance, and only where it converges.

# +
import argparse
import os
import sys

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.columns import INDEX
from rodfem.run import simulate
from rodfem.solver.methods.direct import DirectMethod

COMM = MPI.COMM_WORLD


def say(*args) -> None:
    if COMM.rank == 0:
        print(*args, flush=True)


def run(*overrides: str):
    """Run paper1 with the overrides, in memory; return the RunResult (history in .history)."""
    return simulate(rodfem.scene.load("paper1", list(overrides)), None, COMM, progress=False)


# -

# ## The same answer three ways
#
# On the paper's first experiment the three methods agree to Picard's tolerance; the direct
# method needs one solve per step where Picard needs about four pairs.


def agree(end: float) -> None:
    results = {m: run(f"time.end={end}", f"solver.method={m}") for m in ("picard", "direct",
                                                                          "newton")}
    reference = results["direct"].history
    for method, result in results.items():
        h, s = result.history, result.summary
        differs = np.abs(h[:, 1:6] - reference[:, 1:6]).max(axis=0) / np.abs(reference[:, 1:6]).max(
            axis=0)
        say(f"{method:7s} {s['us_per_step']:6.1f} µs/step, {s['iterations_mean']:.2f} "
            f"iterations/step, largest relative difference from direct {differs.max():.1e}")


# ## Beyond the paper's condition
#
# The paper proves that Picard converges when $\Delta t < \varepsilon\zeta$. What really governs
# it is the compliance $w$: while the rod presses on the obstacle, an iteration maps the contact
# force $p$ to $\frac1\varepsilon[s - w p - g]_+$, which contracts by $w/\varepsilon$. With
# $\Delta t = 0.01$ and $\varepsilon = 0.001$ ($\Delta t = 50\,\varepsilon\zeta$),
# $w > \varepsilon$: Picard cannot converge once the rod touches, while the exact methods go on,
# and the energy $\hat E^n$ still never increases.


def beyond(end: float) -> None:
    overrides = ["time.dt=0.01", "obstacle.epsilon=0.001", f"time.end={end}"]
    scene = rodfem.scene.load("paper1", [*overrides, "solver.method=direct"])
    w = DirectMethod(Discretisation(scene, COMM)).compliance
    say(f"Δt/(εζ) = {0.01 / (0.001 * 0.2):g}; compliance w = {w:.3e}, w/ε = {w / 0.001:.2f}")
    for method in ("picard", "direct", "newton"):
        result = run(*overrides, f"solver.method={method}")
        if result.status == "failed":
            say(f"{method:7s} failed: {result.error}")
        else:
            s = result.summary
            say(f"{method:7s} {s['steps']} steps, energy non-increasing: "
                f"{s['energy_non_increasing']} "
                f"(largest step change {s['energy_max_increase']:.1e})")


# ## The rigid obstacle
#
# `obstacle.kind = "rigid"` replaces the penalty by Signorini's condition $U^n(1) \le g$,
# $\sigma(1) \le 0$, $\sigma(1)(U^n(1) - g) = 0$. The direct method solves it exactly too
# ($p = (s - g)/w$ when $s > g$, so that $U^n(1) = g$), and $\sigma(1) = -p$ is the multiplier.
# As $\varepsilon \to 0$ the elastic obstacle tends to it, at the rate $\varepsilon$ once
# $\varepsilon \ll w$: in a step in contact, $p = (s - g)/(\varepsilon + w)$ against
# $(s - g)/w$, a relative difference $\varepsilon/(\varepsilon + w)$ (here $w = 7\cdot10^{-5}$).


def rigid(end: float) -> None:
    rigid = run(f"time.end={end}", "obstacle.kind=rigid", "solver.method=direct").history
    u_1, sigma_1 = rigid[:, INDEX["u_1"]], rigid[:, INDEX["sigma_1"]]
    say(f"rigid: max u(1) - g = {u_1.max() - 0.1:.1e}, max σ(1) = {sigma_1.max():.1e}, "
        f"max |σ(1)(u(1) - g)| = {np.abs(sigma_1 * (u_1 - 0.1)).max():.1e}, "
        f"min σ(1) = {sigma_1.min():.2f}")
    epsilons = 10.0 ** -np.arange(3, 9)
    errors = []
    for eps in epsilons:
        elastic = run(f"time.end={end}", f"obstacle.epsilon={eps}", "solver.method=direct")
        errors.append(np.abs(elastic.history[:, INDEX["u_1"]] - u_1).max())
        rate = f", rate {np.log10(errors[-2] / errors[-1]):.3f}" if len(errors) > 1 else ""
        say(f"ε = {eps:.0e}: max_t |u_ε(1, t) - u_rigid(1, t)| = {errors[-1]:.3e}{rate}")
    small = epsilons <= 1e-5
    rate = np.polyfit(np.log(epsilons[small]), np.log(np.array(errors)[small]), 1)[0]
    say(f"rate for ε <= 1e-5: {rate:.3f} (least-squares slope)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--end", type=float, default=1.0 if os.environ.get("CI") else 4.0,
                        help="end time T")
    args = parser.parse_args()
    agree(args.end)
    beyond(args.end)
    rigid(args.end)
    sys.exit(0)
