"""Benchmark: the compiled Picard loop of rodfem (:mod:`rodfem.picard_kernel`) against
``benchmarks/picard_loop.c`` and rodfem's PETSc Picard loop, in the same run.

paper1 (250 cells, Δt = 1e-3, T = 8: 8000 steps) with lumped and consistent mass. The time loop
only: the paper's first step by ``scheme.advance()``, then the kernel in calls of 256 steps (as
``rodfem.run.simulate`` chunks it) into a History, no files. Each loop runs ``--repeats`` times;
the fastest µs per step of each is reported (these shared machines drift by tens of percent), and
the kernel's iterations and u(1, T) are checked against both other loops.

    .venv/bin/python benchmarks/bench_picard_kernel.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.discretisation import Discretisation
from rodfem.history import History
from rodfem.picard import PicardScheme
from rodfem.picard_kernel import PicardKernel

HERE = Path(__file__).resolve().parent
CHUNK = 256


def c_loop(binary: Path, mass: str, repeats: int) -> dict:
    done = subprocess.run([str(binary), "250", "0.001", "8", "0.01", "1", "0.2", mass, "1e-10",
                           "100"], check=True, capture_output=True, text=True,
                          env={"PICARD_LOOP_REPEATS": str(repeats)})
    return json.loads(done.stdout)


def rodfem_loop(mass: str, repeats: int, compiled: bool) -> dict:
    scene = rodfem.scene.load("paper1", [f"discretisation.mass={mass}", "solver.method=picard"])
    disc = Discretisation(scene, MPI.COMM_SELF)
    steps, best = scene.steps, np.inf
    for _ in range(repeats):
        scheme, history = PicardScheme(disc), History(disc, steps + 1)
        kernel = PicardKernel(scheme, history) if compiled else None
        history.record(scheme)
        started = time.perf_counter()
        scheme.advance()  # the paper's first step
        history.record(scheme)
        n = 1
        while n < steps:
            if kernel is None:
                scheme.advance()
                history.record(scheme)
                n += 1
            else:
                chunk = min(CHUNK, steps - n)
                kernel.advance(chunk, history.reserve(chunk))
                history.commit(chunk)
                n += chunk
        best = min(best, time.perf_counter() - started)
    rows = history.take()
    return {"us_per_step": 1e6 * best / steps, "iterations_mean": float(rows[2:, 6].mean()),
            "u_1_final": float(rows[-1, 1])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    cc = shutil.which("cc")
    if cc is None:
        raise SystemExit("bench_picard_kernel: needs a C compiler (cc)")
    print(f"{'paper1':10s} {'kernel µs':>10s} {'C loop µs':>10s} {'ratio':>6s} "
          f"{'PETSc µs':>9s} {'iterations':>10s}")
    with tempfile.TemporaryDirectory() as tmp:
        binary = Path(tmp) / "picard_loop"
        subprocess.run([cc, "-O2", "-std=c99", "-o", str(binary), str(HERE / "picard_loop.c"),
                        "-lm"], check=True)
        for mass in ("lumped", "consistent"):
            c = c_loop(binary, mass, args.repeats)
            k = rodfem_loop(mass, args.repeats, True)
            petsc = rodfem_loop(mass, max(1, args.repeats // 2), False)
            for other in (c, petsc):
                if abs(other["iterations_mean"] - k["iterations_mean"]) > 1e-12 or not np.isclose(
                        other["u_1_final"], k["u_1_final"], rtol=1e-9, atol=0):
                    raise SystemExit(f"bench_picard_kernel: loops disagree ({mass}): {k} {other}")
            print(f"{mass:10s} {k['us_per_step']:10.2f} {c['us_per_step']:10.2f} "
                  f"{k['us_per_step'] / c['us_per_step']:6.2f} {petsc['us_per_step']:9.1f} "
                  f"{k['iterations_mean']:10.4f}")


if __name__ == "__main__":
    main()
