"""Benchmark: the cost per step of the `direct` method with a heat exchange that depends on the
contact (``heat_exchange.law`` = pressure, gap) against the constant law, in the PETSc loop
(``method.advance()``) and the compiled loop (rodfem/solver/compiled/direct.py), in one session.

paper1 (250 cells, lumped mass, Δt = 1e-3, to t = 2: the rod reaches the obstacle at t ≈ 0.19),
an obstacle at θ_O = 10, each time scheme; the pressure law with k₁ = 0.5, the gap law with
k₁ = 5 and ℓ = 0.02 (q > 0 at every step: its scalar equation is solved at every step, where
the pressure law's is only in contact). Steps 1 .. N from the same state, repeated, the fastest
kept: these shared machines drift by tens of percent between runs, so only numbers taken
together compare.

    .venv/bin/python benchmarks/bench_exchange.py [--repeats 5] [--cells 250]
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
from rodfem.solver.compiled import direct as kernel
from rodfem.solver.methods.direct import DirectMethod

LAWS = {"constant": (),
        "pressure": ("heat_exchange.law=pressure", "heat_exchange.k1=0.5"),
        "gap": ("heat_exchange.law=gap", "heat_exchange.k1=5", "heat_exchange.length=0.02")}


def timed(scene, repeats: int) -> tuple[float, float]:
    """(µs per step of the PETSc loop, of the compiled loop), the fastest of
    ``repeats`` runs of steps 1 .. N each from the state after step 1."""
    disc = Discretisation(scene, MPI.COMM_SELF)
    method, history = DirectMethod(disc), History(disc, scene.steps + 1)
    loop = kernel.DirectKernel(method, history)
    method.advance()
    start = (method.values.copy(), method.u_prev.array.copy(), method.pressure, method.n)
    steps = scene.steps - 1
    rows = np.zeros((steps, history.width))

    def reset():
        method.values[:], method.u_prev.array[:] = start[0], start[1]
        method.pressure, method.n = start[2], start[3]
        for vector in (method.state, method.theta, method.du, method.u, method.u_prev):
            vector.stateIncrease()

    petsc, compiled = [], []
    for _ in range(repeats):
        reset()
        began = time.perf_counter()
        for _ in range(steps):
            method.advance()
        petsc.append((time.perf_counter() - began) / steps * 1e6)
        reset()
        began = time.perf_counter()
        loop.advance(steps, rows)
        compiled.append((time.perf_counter() - began) / steps * 1e6)
    return min(petsc), min(compiled)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--cells", type=int, default=250)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    print(f"machine: {platform.node()} {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores; paper1, {args.cells} cells, Δt = 1e-3, t = 2, θ_O = 10, "
          f"fastest of {args.repeats}")
    print(f"{'scheme':16} {'law':9} {'PETSc µs/step':>14} {'× constant':>10} "
          f"{'compiled µs/step':>17} {'× constant':>10}")
    for scheme in ("paper", "crank-nicolson"):
        base = None
        for law, overrides in LAWS.items():
            scene = rodfem.scene.load("paper1", [
                "solver.method=direct", "time.end=2", f"time.scheme={scheme}",
                f"mesh.cells={args.cells}", "obstacle.temperature=10", *overrides])
            petsc, compiled = timed(scene, args.repeats)
            base = base or (petsc, compiled)
            print(f"{scheme:16} {law:9} {petsc:14.2f} {petsc / base[0]:10.2f} "
                  f"{compiled:17.2f} {compiled / base[1]:10.2f}")


if __name__ == "__main__":
    main()
