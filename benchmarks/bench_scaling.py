"""Benchmark: cost per step, memory and set-up of every rodfem method against cells, with a
compiled Picard loop (``benchmarks/picard_loop.c``) measured in the same run (issue 5 §4).

On scene paper1 (Δt and T below, the same steps at every size and for the C loop; the rod first
touches the obstacle at t ≈ 0.19, so about half the steps are in contact), for cells = 250, 1e3,
1e4, 1e5, 1e6:

1. µs per step of each method (``solver.method`` = picard, newton, direct; and direct with
   ``time.scheme = crank-nicolson`` where the scene has it) and of the C loop, and their ratio;
   checks that the C loop and rodfem's picard computed the same thing (mean Picard iterations
   and u(1, T)), and that the exact methods agree with picard to its tolerance;
2. the growth exponent of cost per step in cells over 1e3 … 1e6 (least-squares slope of
   log µs/step against log cells);
3. peak memory (ru_maxrss of a process that runs one size) and bytes per cell from the slope
   between sizes (the interpreter and the dolfinx import are the intercept, not per cell);
4. set-up: ``import dolfinx, rodfem.run`` in a fresh process, the JIT with a cold cache (a fresh
   ``XDG_CACHE_HOME``, where dolfinx 0.5.2 puts its cache ``fenics/``) and a warm one, and each
   run's own ``setup_seconds`` (mesh, assembly, factorisation);
5. ``mpirun -n 2`` against ``-n 1`` at 1e6 cells (direct): rank 0 reports set-up and loop;
6. the issue's targets, pass or fail.

Every size and method runs in its own process (``--worker``), so that its peak memory is its own;
sizes are run from small to large, C loop and rodfem side by side, so that the drift of these
shared machines hits both alike. Only ratios taken in one run compare.

    .venv/bin/python benchmarks/bench_scaling.py [--dt 2e-3] [--end 0.4]
        [--cells 250,1000,10000,100000,1000000] [--out benchmarks/results]

writes ``scaling.json`` and ``scaling.png`` (log–log) to ``--out`` and prints the table; about
8 minutes on a 2-core machine. ``--quick`` (cells up to 1e4, no mpirun) is for trying it out.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from scaling_report import CN, METHODS, analyse, figure, table

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MPI_CELLS = 1_000_000
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1",
           "PRTE_MCA_rmaps_default_mapping_policy": ":oversubscribe"}


def peak_rss_bytes() -> int:
    """The peak resident set of this process (Linux reports ru_maxrss in KiB)."""
    return 1024 * resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def repeats_for(cells: int) -> int:
    """Runs per (size, method), the fastest reported: more where a run is short."""
    return 7 if cells <= 1000 else 3 if cells <= 10_000 else 2 if cells <= 100_000 else 1


# ---------------------------------------------------------------------------------------------
# Workers: each runs in a fresh process and prints one JSON line.


def overrides(cells: int, method: str, dt: float, end: float) -> list[str]:
    sets = [f"mesh.cells={cells}", f"time.dt={dt!r}", f"time.end={end!r}",
            "output.every=100000000"]
    if method == CN:
        return sets + ["solver.method=direct", "time.scheme=crank-nicolson"]
    return sets + [f"solver.method={method}"]


def worker(cells: int, method: str, dt: float, end: float, repeats: int) -> dict:
    """Run paper1 ``repeats`` times in memory; the fastest loop, every run's set-up, peak RSS."""
    started = time.perf_counter()
    import rodfem.run
    import rodfem.scene
    imported = time.perf_counter() - started
    scene = rodfem.scene.load("paper1", overrides(cells, method, dt, end))
    runs = []
    for _ in range(repeats):
        result = rodfem.run.simulate(scene, None, progress=False)
        if result.status != "complete":
            return {"status": result.status, "error": result.summary.get("error"),
                    "peak_rss_bytes": peak_rss_bytes()}
        runs.append((result.summary, float(result.u[-1])))
    best, u_1 = min(runs, key=lambda r: r[0]["us_per_step"])
    return {"status": "complete", "cells": cells, "method": method, "steps": best["steps"],
            "us_per_step": best["us_per_step"],
            "us_per_step_runs": [r[0]["us_per_step"] for r in runs],
            "iterations_mean": best["iterations_mean"], "iterations_max": best["iterations_max"],
            "u_1_final": u_1,
            # The first run's set-up loads the compiled forms from the (warm) JIT cache too.
            "setup_seconds_first": runs[0][0]["setup_seconds"],
            "setup_seconds": min(r[0]["setup_seconds"] for r in runs),
            "import_seconds": imported, "peak_rss_bytes": peak_rss_bytes()}


def worker_baseline() -> dict:
    """The intercept of memory: the interpreter with dolfinx and rodfem imported, nothing run."""
    import dolfinx  # noqa: F401

    import rodfem.run  # noqa: F401
    return {"peak_rss_bytes": peak_rss_bytes()}


def worker_setup() -> dict:
    """The first set-up of a process: a 250-cell paper1 run of 2 steps (whatever the JIT cache
    holds, given by the environment); its ``setup_seconds`` includes compiling or loading the
    forms, then a second set-up in the same process, which finds them in memory."""
    started = time.perf_counter()
    import dolfinx  # noqa: F401

    import rodfem.run
    import rodfem.scene
    imported = time.perf_counter() - started
    scene = rodfem.scene.load("paper1", ["time.end=0.002", "output.every=100000000"])
    first = rodfem.run.simulate(scene, None, progress=False).summary["setup_seconds"]
    second = rodfem.run.simulate(scene, None, progress=False).summary["setup_seconds"]
    return {"import_seconds": imported, "setup_seconds_first": first,
            "setup_seconds_again": second, "process_seconds": time.perf_counter() - started}


def worker_mpi(cells: int, dt: float, end: float) -> dict | None:
    """One direct run under mpirun; rank 0 reports (the loop runs on every rank, redundantly)."""
    from mpi4py import MPI

    import rodfem.run
    import rodfem.scene
    comm = MPI.COMM_WORLD
    scene = rodfem.scene.load("paper1", overrides(cells, "direct", dt, end))
    comm.barrier()
    started = time.perf_counter()
    result = rodfem.run.simulate(scene, None, comm=comm, progress=False)
    comm.barrier()
    wall = time.perf_counter() - started
    rss = comm.gather(peak_rss_bytes(), root=0)
    if comm.rank != 0:
        return None
    s = result.summary
    return {"ranks": comm.size, "cells": cells, "status": result.status, "steps": s["steps"],
            "setup_seconds": s["setup_seconds"], "loop_seconds": s["loop_seconds"],
            "us_per_step": s["us_per_step"], "wall_seconds": wall,
            "u_1_final": float(result.u[-1]), "peak_rss_bytes_per_rank": rss}


# ---------------------------------------------------------------------------------------------
# The driver.


def run_json(command: list[str], env: dict | None = None) -> dict:
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, **(env or {})})
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return json.loads(lines[-1])


def me(*args: str) -> list[str]:
    return [sys.executable, str(Path(__file__).resolve()), *args]


def c_loop(binary: Path, cells: int, dt: float, end: float, repeats: int) -> dict:
    """The C loop at the paper1 data (ε = 0.01, k = 1, ζ = 0.2, lumped mass, tol 1e-10)."""
    started = time.perf_counter()
    done = subprocess.run([str(binary), str(cells), repr(dt), repr(end), "0.01", "1", "0.2",
                           "lumped", "1e-10", "100"], check=True, capture_output=True, text=True,
                          env={**os.environ, "PICARD_LOOP_REPEATS": str(max(repeats, 2))})
    return {**json.loads(done.stdout), "repeats": max(repeats, 2),
            "process_seconds": time.perf_counter() - started}




def has_time_scheme() -> bool:
    import rodfem.scene
    try:
        rodfem.scene.load("paper1", ["time.scheme=crank-nicolson", "solver.method=direct"])
    except Exception:
        return False
    return True


def git_state() -> dict:
    def git(*args):
        done = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return done.stdout.strip() if done.returncode == 0 else None
    status = git("status", "--porcelain", "--", "rodfem", "forms")
    return {"head": git("rev-parse", "HEAD"),
            "rodfem_or_forms_modified": None if status is None else bool(status)}


def measure(args) -> dict:
    sys.path.insert(0, str(HERE))
    from bench_picard import machine

    cc = shutil.which("cc")
    if cc is None:
        raise SystemExit("bench_scaling: needs a C compiler (cc)")
    methods = list(METHODS) + ([CN] if has_time_scheme() else [])
    started = time.perf_counter()
    report = {"machine": machine(), "git": git_state(), "scene": "paper1",
              "dt": args.dt, "end": args.end, "steps": int(round(args.end / args.dt)),
              "c_loop_data": {"epsilon": 0.01, "k": 1, "zeta": 0.2, "mass": "lumped",
                              "tol": 1e-10, "max_it": 100},
              "methods": methods, "cells": args.cells, "sizes": {}}

    # Set-up: import, JIT with a cold and a warm cache.
    imports = [run_json([sys.executable, "-c",
                         "import time, json; t = time.perf_counter(); import dolfinx, rodfem.run; "
                         "print(json.dumps({'s': time.perf_counter() - t}))"])["s"]
               for _ in range(3)]
    with tempfile.TemporaryDirectory() as cache:
        cold = run_json(me("--worker-setup"), {"XDG_CACHE_HOME": cache})
        warm = [run_json(me("--worker-setup"), {"XDG_CACHE_HOME": cache}) for _ in range(2)]
        jit_files = sum(1 for _ in Path(cache).rglob("*.so"))
    report["setup"] = {
        "import_seconds": min(imports), "import_seconds_runs": imports,
        "jit_cold": cold, "jit_warm": min(warm, key=lambda w: w["setup_seconds_first"]),
        "jit_cold_compile_seconds": cold["setup_seconds_first"] - cold["setup_seconds_again"],
        "jit_warm_load_seconds": min(w["setup_seconds_first"] - w["setup_seconds_again"]
                                     for w in warm),
        "jit_modules": jit_files,
        "note": "setup_seconds_first: the first 250-cell set-up of a fresh process (forms "
                "compiled with a cold cache, loaded from disk with a warm one); "
                "setup_seconds_again: a second set-up in the same process.",
    }
    print(f"import {min(imports):.2f} s, JIT cold {cold['setup_seconds_first']:.2f} s, "
          f"warm {report['setup']['jit_warm']['setup_seconds_first']:.2f} s", flush=True)
    report["memory_baseline_bytes"] = run_json(me("--worker-baseline"))["peak_rss_bytes"]

    with tempfile.TemporaryDirectory() as tmp:
        binary = Path(tmp) / "picard_loop"
        subprocess.run([cc, "-O2", "-std=c99", "-o", str(binary), str(HERE / "picard_loop.c"),
                        "-lm"], check=True)
        for cells in args.cells:
            repeats = repeats_for(cells)
            size = {"repeats": repeats, "c_loop": c_loop(binary, cells, args.dt, args.end,
                                                         repeats), "rodfem": {}}
            for method in methods:
                size["rodfem"][method] = run_json(me("--worker", str(cells), method,
                                                     repr(args.dt), repr(args.end),
                                                     str(repeats)))
            report["sizes"][str(cells)] = size
            line = "  ".join(f"{m} {r['us_per_step']:.4g}" if r["status"] == "complete"
                             else f"{m} {r['status']}" for m, r in size["rodfem"].items())
            print(f"{cells:>8d} cells: C loop {size['c_loop']['us_per_step']:.4g}  {line} "
                  f"µs/step ({time.perf_counter() - started:.0f} s)", flush=True)

    if not args.quick:
        mpi = {}
        for ranks in (1, 2):
            command = ["mpirun", "-n", str(ranks), *me("--worker-mpi", str(MPI_CELLS),
                                                      repr(args.dt), repr(args.end))]
            mpi[str(ranks)] = run_json(command, MPI_ENV)
            print(f"mpirun -n {ranks} at {MPI_CELLS:g} cells: set-up "
                  f"{mpi[str(ranks)]['setup_seconds']:.1f} s, "
                  f"{mpi[str(ranks)]['us_per_step']:.0f} µs/step", flush=True)
        mpi["speedup_loop"] = mpi["1"]["loop_seconds"] / mpi["2"]["loop_seconds"]
        mpi["speedup_setup"] = mpi["1"]["setup_seconds"] / mpi["2"]["setup_seconds"]
        mpi["speedup_wall"] = mpi["1"]["wall_seconds"] / mpi["2"]["wall_seconds"]
        mpi["same_u_1"] = mpi["1"]["u_1_final"] == mpi["2"]["u_1_final"]
        report["mpi"] = mpi
    report["bench_seconds"] = time.perf_counter() - started
    return report


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1].startswith("--worker"):
        kind, rest = sys.argv[1], sys.argv[2:]
        if kind == "--worker":
            cells, method, dt, end, repeats = rest
            out = worker(int(cells), method, float(dt), float(end), int(repeats))
        elif kind == "--worker-baseline":
            out = worker_baseline()
        elif kind == "--worker-setup":
            out = worker_setup()
        elif kind == "--worker-mpi":
            cells, dt, end = rest
            out = worker_mpi(int(cells), float(dt), float(end))
        else:
            raise SystemExit(f"bench_scaling: unknown {kind}")
        if out is not None:
            print(json.dumps(out), flush=True)
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--dt", type=float, default=2e-3)
    parser.add_argument("--end", type=float, default=0.4)
    parser.add_argument("--cells", default="250,1000,10000,100000,1000000",
                        help="comma-separated sizes")
    parser.add_argument("--quick", action="store_true",
                        help="cells 250, 1e3, 1e4 only, no mpirun")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument("--analyse-only", action="store_true",
                        help="re-analyse the scaling.json already in --out, measuring nothing")
    args = parser.parse_args()
    args.cells = [250, 1000, 10_000] if args.quick else [int(float(c))
                                                         for c in args.cells.split(",")]
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "scaling.json"
    if args.analyse_only:  # redo the analysis, figure and table of the measurements in --out
        report = json.loads(path.read_text())
    else:
        report = measure(args)
        path.write_text(json.dumps(report, indent=2) + "\n")  # the measurements, kept first
    analyse(report)
    path.write_text(json.dumps(report, indent=2) + "\n")
    figure(report, args.out / "scaling.png")
    print(table(report))
    print(f"-> {path}, {args.out / 'scaling.png'}")


if __name__ == "__main__":
    main()
