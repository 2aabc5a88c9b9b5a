# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
# ---

# # Experiment 4: cooling obstacle, more viscosity (ε = 0.01, k = 100, ζ = 1)
#
# Experiment 3 with ζ = 1, for which the paper shows no figure ("as 3"). The viscosity damps the
# bouncing quickly; the heat drained through the obstacle (k = 100) again leaves the rod short of
# it.
#
# Run it with `mpirun -n 2 python3 demos/demo_paper4.py` (or without `mpirun`); it writes the run
# and its figures (`figures/contact.png`, `energy.png`, `spacetime_*.png`, `rod.gif`) into
# `results/demo_paper4`. With `CI` set in the environment it stops at t = 1.
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
# As in experiment 3, $U^* = a\theta_A(1 - c/2) = 0.0858 < g$: the rod comes to rest free of the
# obstacle, $\sigma(1) = 0$, sooner than with ζ = 0.2.


def run(out: Path, end: float = 8.0) -> str:
    """Simulate experiment 4 up to ``end`` into ``out``, with figures; return what it shows."""
    _, _, facts = run_experiment("paper4", out, [f"time.end={end}"], force=True)
    return facts


if __name__ == "__main__":
    parser = argparse.ArgumentParser(formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("results/demo_paper4"))
    parser.add_argument("--end", type=float, default=1.0 if os.environ.get("CI") else 8.0)
    args = parser.parse_args()
    facts = run(args.out, args.end)
    if MPI.COMM_WORLD.rank == 0:
        print(facts)
