"""Benchmark: what ``rodfem periodic`` costs on the hot rod (docs/barber.md), CPU seconds.

``shot``: one evaluation of the time-T map, N compiled steps of h = T/N from a given state
(rodfem/solver/shooting.py), the fastest of ``--rounds``; a Newton iteration takes one per
unknown and one for T (3 × cells + 1). ``start``: the time run settled near the orbit.
``find``: Newton's method from there and the Floquet multipliers (two more Jacobians).
CPU time of the process, serial.

    .venv/bin/python benchmarks/bench_periodic.py [--cells 20,40,80] [--rounds 5]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

from mpi4py import MPI

import rodfem.scene
from rodfem.studies.steady import orbit as po
from rodfem.studies.steady import periodic as pe
from rodfem.studies.steady.barber import at_rest

HOT = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
       "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
       "obstacle.epsilon=0.1", "model.zeta=0.01", "time.dt=0.001", "solver.method=direct"]
CLOCK = time.process_time


def machine() -> str:
    return (f"{platform.node()}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}; "
            f"load average {os.getloadavg()[0]:.1f}")


def measure(cells: int, rounds: int) -> dict:
    comm = MPI.COMM_WORLD
    overrides = [*HOT, f"mesh.cells={cells}"]
    scene = rodfem.scene.load("barber", overrides)
    state, eigenvalues = pe.steady_state(scene)
    flow = pe.flow_of(rodfem.scene.load("barber", [*overrides, *at_rest(state, pe.KICK)]), comm)
    started = CLOCK()
    start = po.settle(flow, flow.initial(), state.u_1, 2 * math.pi / abs(eigenvalues[0].imag))
    settled = CLOCK() - started
    started = CLOCK()
    orbit = po.find(flow, scene, state.u_1, start.state, start.period, comm)
    found = CLOCK() - started
    shots = []
    for _ in range(rounds):
        started = CLOCK()
        flow.shoot(orbit.state, orbit.period, orbit.steps)
        shots.append(CLOCK() - started)
    return {"cells": cells, "unknowns": flow.free.size, "steps": orbit.steps,
            "shot_ms": 1e3 * min(shots), "start_s": settled, "find_s": found,
            "iterations": orbit.iterations, "period": orbit.period}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cells", default="20,40,80")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    print(machine())
    print(f"{'cells':>6} {'unknowns':>9} {'N':>6} {'shot ms':>8} {'start s':>8} {'find s':>7} "
          f"{'Newton':>7} {'period':>10}")
    for cells in (int(c) for c in args.cells.split(",")):
        r = measure(cells, args.rounds)
        print(f"{r['cells']:6d} {r['unknowns']:9d} {r['steps']:6d} {r['shot_ms']:8.2f} "
              f"{r['start_s']:8.2f} {r['find_s']:7.2f} {r['iterations']:7d} {r['period']:10.6f}")


if __name__ == "__main__":
    main()
