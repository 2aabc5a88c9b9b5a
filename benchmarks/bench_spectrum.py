"""Benchmark: the stability of the barber scene's three steady states (``rodfem steady barber``),
per state, dense QZ (rodfem.solver.spectrum) against the sparse path (rodfem.solver.rightmost: the
banded pencil and SLEPc's shift-and-invert; rodfem.solver.right_half_plane: the count of the right
half-plane), at 100, 200, 500 and 1,000 cells, and the sparse path alone at 10,000 and 100,000
cells.

Each state's verdict is timed once (the operators assembled beforehand, not timed), with the
process's peak resident memory after it (``ru_maxrss``: it only grows, so a dense size's figure
includes the smaller ones'); dense sizes above ``--dense-max`` cells are skipped (1,000 cells:
about 100 s a state). These shared machines drift by tens of percent: compare only numbers taken
together.

    .venv/bin/python benchmarks/bench_spectrum.py [--dense-max 1000] [--sparse 10000 100000]
        [--json benchmarks/results/spectrum.json]

The machine is printed first; ``--json`` also writes the numbers and the machine to FILE.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import time

import rodfem.scene
from rodfem.model import steady
from rodfem.solver.spectrum import Spectra


def machine() -> dict:
    return {"node": platform.node(), "processor": platform.processor() or platform.machine(),
            "cores": os.cpu_count(), "python": platform.python_version()}


def measure(cells: int, dense: bool) -> list[dict]:
    """One row per state: verdict, growth rate, its error, seconds, peak memory (GB)."""
    scene = rodfem.scene.load("barber", [f"mesh.cells={cells}"])
    spectra = Spectra(dense_cells=None if dense else 0)
    (spectra.operators if dense else spectra.sparse_operators)(scene)
    problem = steady.of_scene(scene)
    rows = []
    for index, state in enumerate(problem.states()):
        lin = problem.linearise(state)
        start = time.perf_counter()
        found = spectra.verdict(scene, lin)
        seconds = time.perf_counter() - start
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
        rows.append({"cells": cells, "path": "dense" if dense else "sparse", "state": index,
                     "verdict": found.verdict, "growth_rate": found.growth_rate,
                     "error": found.error, "seconds": seconds, "peak_GB": peak})
        print(f"{cells:>7} {rows[-1]['path']:>6} state {index}: {found.verdict:>10} "
              f"{found.growth_rate:12.6g} ± {found.error:.2g}  {seconds:8.2f} s  "
              f"{peak:.2f} GB", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dense-max", type=int, default=1000)
    parser.add_argument("--sparse", type=int, nargs="*", default=[10_000, 100_000])
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    print("machine:", machine())
    rows = []
    for cells in (100, 200, 500, 1000):
        rows += measure(cells, dense=False)
        if cells <= args.dense_max:
            rows += measure(cells, dense=True)
    for cells in args.sparse:
        rows += measure(cells, dense=False)
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"machine": machine(), "rows": rows}, file, indent=1)


if __name__ == "__main__":
    main()
