# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Experiment 3: a cooling obstacle lets the rod go (ε = 0.01, k = 100, ζ = 0.2)
#
# The heat-exchange coefficient at the contact point rises from k = 1 to k = 100:
# $-\theta_x(1) = k\theta(1)$ drains the heat through the obstacle and the rod cools. The rod
# first bounces against the obstacle as in experiment 1, but its thermal expansion no longer
# reaches it.
#
# Run it with `mpirun -n 2 python3 demos/demo_paper3.py` (or without `mpirun`); it writes the run
# and its figures (`figures/contact.png`, `energy.png`, `spacetime_*.png`, `rod.gif`) into
# `results/demo_paper3`. With `CI` set in the environment it stops at t = 1.
# `demos/demo_paper1.py` explains the model and the scheme step by step.

# +
import argparse
import os
from pathlib import Path

from mpi4py import MPI

from rodfem.studies.verification.paper import run_experiment

# -

# ## Where it ends
#
# With $c = k/(k+1) = 100/101$ the free thermal expansion is
# $U^* = a\theta_A(1 - c/2) = 0.0858 < g = 0.1$: at rest the rod is free,
# $u^*(x) = a\theta_A(x - cx^2/2)$ and $\sigma(1) = 0$. The paper: "during some time, we saw
# intervals of penetration and separation but the system evolved towards a state with no contact
# with the obstacle with the stress at the contact point equal to zero" (its Figure 3).


def run(out: Path, end: float = 8.0) -> str:
    """Simulate experiment 3 up to ``end`` into ``out``, with figures; return what it shows."""
    _, _, facts = run_experiment("paper3", out, [f"time.end={end}"], force=True)
    return facts


if __name__ == "__main__":
    parser = argparse.ArgumentParser(formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("results/demo_paper3"))
    parser.add_argument("--end", type=float, default=1.0 if os.environ.get("CI") else 8.0)
    args = parser.parse_args()
    facts = run(args.out, args.end)
    if MPI.COMM_WORLD.rank == 0:
        print(facts)
