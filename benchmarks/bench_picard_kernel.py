"""Benchmark: the compiled Picard loop of rodfem (:mod:`rodfem.solver.compiled.picard`) against
``benchmarks/picard_loop.c`` and rodfem's PETSc Picard loop, in the same run.

paper1 (250 cells, Δt = 1e-3, T = 8: 8000 steps) with lumped and consistent mass. The time loop
only: the paper's first step by ``scheme.advance()``, then the kernel in calls of 256 steps (as
``rodfem.run.simulate`` chunks it) into a History, no files. Each loop runs ``--repeats`` times;
the fastest µs per step of each is reported (these shared machines drift by tens of percent), and
the kernel's iterations and u(1, T) are checked against both other loops.

    .venv/bin/python benchmarks/bench_picard_kernel.py [--repeats 5]

``--cells 250,1000,10000,100000,1000000``: paper1 at those sizes instead, with Δt = 2e-3 to
T = 0.4 (200 steps, ``--dt``, ``--end``) and lumped mass (``--mass``), as
``benchmarks/bench_scaling.py`` runs it: the kernel (and with ``--uncompressed`` the kernel with
``compress=False``, a coefficient row per node) against the C loop, without the PETSc loop, the
fastest of ``--repeats`` runs (default 7, 3, 2, 1 by size, as bench_scaling), then the growth
exponent of µs per step over cells ≥ 1e3. The C loop's u(1, T) loses accuracy like 1/h² (see
bench_scaling's U1_RTOL_C): beyond 1e3 cells only its iterations are checked. At 1e6 cells the
set-up takes about 30 s and 5 GB.
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
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.history import History
from rodfem.solver.compiled.picard import PicardKernel
from rodfem.solver.methods.picard import PicardMethod

HERE = Path(__file__).resolve().parent
CHUNK = 256


FIT_FROM = 1000  # the growth exponent is fitted over cells >= FIT_FROM
U1_C_CELLS = 1000  # u(1, T) held to the C loop's up to this size (bench_scaling.U1_C_CELLS)


def c_loop(binary: Path, mass: str, repeats: int, cells: int = 250, dt: float = 1e-3,
           end: float = 8.0) -> dict:
    done = subprocess.run([str(binary), str(cells), repr(dt), repr(end), "0.01", "1", "0.2",
                           mass, "1e-10", "100"], check=True, capture_output=True, text=True,
                          env={"PICARD_LOOP_REPEATS": str(repeats)})
    return json.loads(done.stdout)


def rodfem_loop(mass: str, repeats: int, compiled: bool, extra=(), disc=None,
                compress: bool = True) -> dict:
    if disc is None:
        scene = rodfem.scene.load("paper1", [f"discretisation.mass={mass}",
                                             "solver.method=picard", *extra])
        disc = Discretisation(scene, MPI.COMM_SELF)
    steps, best = disc.scene.steps, np.inf
    for _ in range(repeats):
        scheme, history = PicardMethod(disc), History(disc, steps + 1)
        kernel = PicardKernel(scheme, history, compress=compress) if compiled else None
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


def repeats_for(cells: int) -> int:
    """As bench_scaling.repeats_for: more runs where a run is short."""
    return 7 if cells <= 1000 else 3 if cells <= 10_000 else 2 if cells <= 100_000 else 1


def scaling(binary: Path, args) -> None:
    """--cells: the kernel against the C loop per size, and the growth exponents."""
    kinds = ["kernel", *(["uncompressed"] if args.uncompressed else [])]
    print(f"{'cells':>8s} {'C loop µs':>11s} " + " ".join(
        f"{k + ' µs':>16s} {'ratio':>6s}" for k in kinds) + f" {'iterations':>10s}")
    times: dict[str, list] = {"c_loop": [], **{k: [] for k in kinds}}
    for cells in args.cells:
        repeats = args.repeats or repeats_for(cells)
        c = c_loop(binary, args.mass, max(repeats, 2), cells, args.dt, args.end)
        extra = [f"mesh.cells={cells}", f"time.dt={args.dt!r}", f"time.end={args.end!r}"]
        scene = rodfem.scene.load("paper1", [f"discretisation.mass={args.mass}",
                                             "solver.method=picard", *extra])
        disc = Discretisation(scene, MPI.COMM_SELF)
        found = {k: rodfem_loop(args.mass, repeats, True, disc=disc,
                                compress=(k == "kernel")) for k in kinds}
        del disc
        k = found["kernel"]
        for name, other in (("C loop", c), *found.items()):
            if abs(other["iterations_mean"] - k["iterations_mean"]) > 1e-12 or (
                    (name != "C loop" or cells <= U1_C_CELLS)
                    and not np.isclose(other["u_1_final"], k["u_1_final"], rtol=1e-9, atol=0)):
                raise SystemExit(f"bench_picard_kernel: loops disagree at {cells} cells: "
                                 f"kernel {k}, {name} {other}")
        for kind in kinds:
            if found[kind]["u_1_final"] != k["u_1_final"]:
                raise SystemExit(f"bench_picard_kernel: {kind} is not bit-identical")
        times["c_loop"].append((cells, c["us_per_step"]))
        for kind in kinds:
            times[kind].append((cells, found[kind]["us_per_step"]))
        print(f"{cells:8d} {c['us_per_step']:11.2f} " + " ".join(
            f"{found[kind]['us_per_step']:16.2f} "
            f"{found[kind]['us_per_step'] / c['us_per_step']:6.2f}" for kind in kinds)
            + f" {k['iterations_mean']:10.4f}", flush=True)
    for name, points in times.items():
        points = [p for p in points if p[0] >= FIT_FROM]
        if len(points) >= 2:
            x, y = np.log([p[0] for p in points]), np.log([p[1] for p in points])
            print(f"growth exponent over cells {', '.join(str(p[0]) for p in points)}: "
                  f"{name} {np.polyfit(x, y, 1)[0]:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=None,
                        help="runs per loop, the fastest reported (default 5; by size with "
                             "--cells)")
    parser.add_argument("--cells", type=lambda s: [int(float(c)) for c in s.split(",")],
                        default=None, help="comma-separated sizes: the scaling run")
    parser.add_argument("--dt", type=float, default=2e-3, help="with --cells")
    parser.add_argument("--end", type=float, default=0.4, help="with --cells")
    parser.add_argument("--mass", default="lumped", help="with --cells")
    parser.add_argument("--uncompressed", action="store_true",
                        help="with --cells: also the kernel with compress=False")
    args = parser.parse_args()
    cc = shutil.which("cc")
    if cc is None:
        raise SystemExit("bench_picard_kernel: needs a C compiler (cc)")
    if args.cells:
        with tempfile.TemporaryDirectory() as tmp:
            binary = Path(tmp) / "picard_loop"
            subprocess.run([cc, "-O2", "-std=c99", "-o", str(binary),
                            str(HERE / "picard_loop.c"), "-lm"], check=True)
            scaling(binary, args)
        return
    args.repeats = args.repeats or 5
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
