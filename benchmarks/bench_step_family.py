"""Benchmark: what a new step size costs an adaptive run, µs per size.

``family``: ``StepFamily.loop(h)`` (rodfem/solver/compiled/family.py), the compiled loop of a step
h formed from the operators' Laurent parts and bound to the run's method, everything included
(the loop object, the C problem, the factorisation). ``make``: what an adaptive run made for
each new size before, ``make_method(disc, h)`` inside ``disc.at_step(h)`` (assembly, PETSc LU)
and ``compiled_loop`` on it. Both on the sizes of the controller's ladder around Δt₀, for paper1
(250 cells, picard and direct), stiff (Crank–Nicolson, direct) and impact (1000 cells, direct).
The once-per-run cost of the family (the parts read off three assemblies, checked at a fourth,
the tables) is given too. CPU time of the process; the fastest of ``--rounds`` rounds.

    .venv/bin/python benchmarks/bench_step_family.py [--rounds 3] [--sizes 40]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.history import History
from rodfem.solver.compiled import compiled_loop
from rodfem.solver.compiled.families import step_family
from rodfem.solver.methods import make_method

CASES = {
    "paper1 picard": ("paper1", []),
    "paper1 direct": ("paper1", ["solver.method=direct"]),
    "stiff CN direct": ("stiff", ["solver.method=direct", "time.scheme=crank-nicolson"]),
    "impact direct": ("impact", []),
}
CLOCK = time.process_time


def machine() -> str:
    return (f"{platform.node()}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}; "
            f"load average {os.getloadavg()[0]:.1f}")


def measure(name: str, overrides: list[str], sizes: int) -> dict:
    scene = rodfem.scene.load(name, overrides)
    disc = Discretisation(scene, MPI.COMM_WORLD)
    home = make_method(disc)
    history = History(disc, 8)
    kernel = compiled_loop(home, history)
    started = CLOCK()
    family = step_family(home, history, kernel)
    once = CLOCK() - started
    steps = home.dt * 2.0 ** (np.arange(1, sizes + 1) / 4.0 - sizes / 8.0)
    family.loop(steps[0])  # warm
    started = CLOCK()
    for h in steps:
        family.loop(h)
    formed = (CLOCK() - started) / sizes
    made = np.inf
    for h in steps[:max(4, sizes // 8)]:
        started = CLOCK()
        with disc.at_step(h):
            method = make_method(disc, h)
        compiled_loop(method, history, compress=False)
        made = min(made, CLOCK() - started)
    return {"family µs": 1e6 * formed, "make µs": 1e6 * made, "once ms": 1e3 * once}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--sizes", type=int, default=40)
    args = parser.parse_args()
    best: dict[str, dict] = {}
    for _ in range(args.rounds):
        for case, (name, overrides) in CASES.items():
            got = measure(name, overrides, args.sizes)
            kept = best.setdefault(case, got)
            for key, value in got.items():
                kept[key] = min(kept[key], value)
    print(f"machine: {machine()}\n")
    print("| case | family µs per size | make µs per size (before) | ratio | family once ms |")
    print("|---|---|---|---|---|")
    for case, r in best.items():
        print(f"| {case} | {r['family µs']:.1f} | {r['make µs']:.0f} | "
              f"{r['make µs'] / r['family µs']:.0f}x | {r['once ms']:.1f} |")


if __name__ == "__main__":
    main()
