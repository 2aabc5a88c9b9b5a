"""Benchmark: the paper's experiments with adaptive steps at the default tolerance, against fine
fixed-step references, beside the paper's fixed step Δt = 1e-3.

Per scene (``paper1`` … ``paper5``, T = 8, 250 cells) and time scheme, all by the direct method:

* the reference: fixed steps Δt = 1e-5 (800,000 steps) of the same scheme;
* the paper's fixed step Δt = 1e-3 and ``time.adaptive = true`` at the default tolerance: the
  largest difference from the reference over the run's times (the reference interpolated
  linearly to them: its own error there is O(Δt²) = 1e-10) of u(1, t), σ(1, t) and the energy,
  each relative to the largest value of that column in the reference; and the steps taken.

    .venv/bin/python benchmarks/bench_adaptive_paper.py [--scenes paper1 paper3]
        [--schemes paper crank-nicolson]

Prints a Markdown table, with the machine it ran on (about 3 minutes on one core).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.studies.common import machine

REFERENCE_DT = 1e-5
COLUMNS = ("u_1", "sigma_1", "energy")


def history(scene: str, scheme: str, *sets: str) -> np.ndarray:
    with warnings.catch_warnings():  # the paper's scenes do not warn; the study's choices only
        warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
        result = rodfem.simulate(scene, [f"time.scheme={scheme}", "solver.method=direct", *sets],
                                 comm=MPI.COMM_SELF)
    if result.status != "complete":
        raise SystemExit(f"{scene} {scheme} {sets}: {result.status}")
    return result.history


def errors(run: np.ndarray, reference: np.ndarray) -> dict[str, float]:
    """The largest relative difference of each column from the reference at the run's times."""
    return {c: float(np.max(np.abs(run[c] - np.interp(run["t"], reference["t"], reference[c])))
                     / np.max(np.abs(reference[c]))) for c in COLUMNS}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=[f"paper{i}" for i in range(1, 6)])
    parser.add_argument("--schemes", nargs="+", default=["paper", "crank-nicolson"])
    args = parser.parse_args()
    print("| scene | scheme | fixed Δt = 1e-3: u(1), σ(1), energy (steps) | adaptive: u(1), "
          "σ(1), energy (steps) |")
    print("|---|---|---|---|")
    for scheme in args.schemes:
        for scene in args.scenes:
            reference = history(scene, scheme, f"time.dt={REFERENCE_DT}")
            cells = []
            for sets in ((), ("time.adaptive=true",)):
                run = history(scene, scheme, *sets)
                e = errors(run, reference)
                cells.append(", ".join(f"{e[c]:.1e}" for c in COLUMNS) + f" ({len(run) - 1:,})")
            print(f"| {scene} | {scheme} | {cells[0]} | {cells[1]} |", flush=True)
    info = machine(MPI.COMM_SELF)
    print(f"\nmachine: {info.get('cpu', '')}, dolfinx {info.get('dolfinx', '')}")


if __name__ == "__main__":
    main()
