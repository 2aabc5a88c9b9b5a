"""Benchmark: how long a small run takes as a whole process (start-up included), for this version
and an earlier one, and against GetFEM's start, on this machine.

* ``rodfem run`` of tiny scenes (paper1 to t = 0.01, 10 steps; impact to t = 0.01, 10 steps of
  1,000 cells) as a user runs it, a whole process into a fresh directory: the median of
  ``--repeats`` runs, this version and the earlier one taken alternately so that both see the
  same load (these shared 2-core machines drift by tens of percent: compare only numbers taken
  together). The earlier version is the git revision ``--rev``, checked out by ``git worktree
  add`` into a temporary directory and put first on PYTHONPATH. Both use the per-user cache as a
  user's second run finds it (compiled loops and, for this version, operators: one run of each
  first, not timed); ``RODFEM_CACHE=0`` shows this version without its operator cache. Both
  checkouts are byte-compiled first, as ``make setup`` does (a machine with
  PYTHONDONTWRITEBYTECODE set would otherwise compile rodfem's modules in every run). Besides
  the wall time, the processor time of each run (user + system, its children included), which
  the load of a shared machine disturbs less.
* a fresh machine's first run: the same command with caches of its own (an empty
  ``$XDG_CACHE_HOME``), once after ``rodfem prepare SCENE`` (what ``make setup`` runs for every
  built-in scene; not timed) and once without it (the loops built and the forms compiled in the
  run), a new cache for every repeat; ``prepare``'s own time is reported too.
* where the time goes: ``python -X importtime`` of one such run of each version, the cumulative
  import time of the main packages, and the rest of the process.
* GetFEM (``python3-getfem``, if installed; Debian's package ships no demos, so its
  ``demo_dynamic_contact_1D.py`` is not at hand): a stand-in process that imports getfem, makes
  the 1D mesh of 1,000 cells, the P1 space and its integration method, and assembles the mass and
  stiffness matrices, which is how the demo starts; and the same with the demo's own imports
  (``matplotlib.pyplot``, which it imports whether it draws or not). Each is run once in every
  repeat, between rodfem's runs, so that all see the same load.

    .venv/bin/python benchmarks/bench_startup.py [--repeats 9] [--fresh 3] [--rev 60c163f]
        [--json FILE] [--scenes paper1 impact] [--no-fresh] [--no-cache-variant]

The machine is printed first; ``--json`` also writes the numbers and the machine to FILE.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = {"paper1": ["--set", "time.end=0.01"], "impact": ["--set", "time.end=0.01"]}
PACKAGES = ("mpi4py.MPI", "petsc4py.PETSc", "dolfinx", "ufl", "h5py", "scipy", "scipy.linalg",
            "numpy", "cffi",
            "rodfem.cli", "rodfem.run")
GETFEM_STAND_IN = """
import numpy as np
import getfem as gf
mesh = gf.Mesh("cartesian", np.linspace(0.0, 1.0, 1001))
mf = gf.MeshFem(mesh, 1)
mf.set_fem(gf.Fem("FEM_PK(1,1)"))
mim = gf.MeshIm(mesh, gf.Integ("IM_GAUSS1D(4)"))
M = gf.asm_mass_matrix(mim, mf)
K = gf.asm_laplacian(mim, mf, mf, np.ones(mf.nbdof()))
"""
GETFEM_DEMO_IMPORTS = "import matplotlib.pyplot as plt\nimport time, os, sys\n"
GETFEM = {  # name: the process's script
    "getfem": GETFEM_STAND_IN,
    "getfem_demo_imports": GETFEM_DEMO_IMPORTS + GETFEM_STAND_IN,
}


def machine() -> dict:
    cpu = "unknown"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            cpu = line.split(":", 1)[1].strip()
            break
    return {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "load": os.getloadavg()[0],
            "date": time.strftime("%Y-%m-%d %H:%M:%S %Z")}


def environment(source: Path, **extra: str) -> dict:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(source), os.environ.get("PYTHONPATH")])), **extra)
    return env


def run_command(scene: str, out: Path) -> list[str]:
    return ["-m", "rodfem", "run", scene, *SCENES[scene], "--out", str(out), "--force",
            "--quiet"]


def seconds(arguments: list[str], env: dict, cwd: Path, cpu: list | None = None) -> float:
    """Wall time of ``python arguments`` as a new process (its processor time appended to
    ``cpu``)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    # run from a directory without rodfem/: "python -m" puts the working directory first on
    # sys.path, and a checkout's rodfem/ there would shadow PYTHONPATH
    subprocess.run([sys.executable, *arguments], check=True, env=env, cwd=cwd,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if cpu is not None:
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return wall


def byte_compiled(source: Path) -> None:
    """rodfem's modules byte-compiled, as make setup does."""
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(source / "rodfem"),
                    str(source / "forms")], check=True, stdout=subprocess.DEVNULL)


def import_breakdown(arguments: list[str], env: dict, cwd: Path) -> dict:
    """Cumulative import seconds of :data:`PACKAGES` (where first imported) and the total."""
    done = subprocess.run([sys.executable, "-X", "importtime", *arguments], env=env, cwd=cwd,
                          capture_output=True, text=True, check=True)
    found, total = {}, 0.0
    for line in done.stderr.splitlines():
        match = re.match(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)", line)
        if not match:
            continue
        cumulative, depth, name = int(match[2]) * 1e-6, len(match[3]), match[4]
        if depth == 1:
            total += cumulative
        if name in PACKAGES and name not in found:
            found[name] = cumulative
    return {"packages": found, "imports": total}


def fresh_machine(scene: str, out: Path, work: Path, repeats: int) -> dict:
    """This version's first run with empty caches, after ``rodfem prepare`` and without it
    (alternately, a new cache each time), and prepare's own time."""
    times: dict[str, list[float]] = {"fresh machine, after rodfem prepare": [],
                                     "fresh machine, first run compiling": [],
                                     "rodfem prepare (make setup)": []}
    for k in range(repeats):
        for prepared in (True, False):
            cache = work / f"cache-{scene}-{k}-{int(prepared)}"
            env = environment(ROOT, XDG_CACHE_HOME=str(cache))
            if prepared:
                times["rodfem prepare (make setup)"].append(
                    seconds(["-m", "rodfem", "prepare", scene, "--quiet"], env, work))
            key = "after rodfem prepare" if prepared else "first run compiling"
            times[f"fresh machine, {key}"].append(seconds(run_command(scene, out), env, work))
            shutil.rmtree(cache, ignore_errors=True)
    return {name: {"median": statistics.median(t), "all": t} for name, t in times.items()}


def checkout(rev: str, directory: Path) -> Path:
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(directory), rev],
                   check=True, capture_output=True)
    return directory


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--fresh", type=int, default=3,
                        help="repeats of a fresh machine's first run (each compiles: seconds)")
    parser.add_argument("--rev", default="60c163f",
                        help="the earlier version (a git revision; default: the one before "
                             "rodfem prepare)")
    parser.add_argument("--json", type=Path, help="write the numbers and the machine here")
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--no-fresh", action="store_true",
                        help="leave out a fresh machine's first runs")
    parser.add_argument("--no-cache-variant", action="store_true",
                        help="leave out this version with RODFEM_CACHE=0")
    args = parser.parse_args()
    info = machine()
    print("machine:", ", ".join(f"{k} {v}" for k, v in info.items()))
    work = Path(tempfile.mkdtemp(prefix="rodfem-bench-startup-"))
    old = checkout(args.rev, work / "old")
    revision = subprocess.run(["git", "-C", str(old), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    versions = {f"earlier ({revision})": environment(old), "this version": environment(ROOT)}
    if not args.no_cache_variant:
        versions["this version, RODFEM_CACHE=0"] = environment(ROOT, RODFEM_CACHE="0")
    for source in (old, ROOT):
        byte_compiled(source)
    results: dict = {"machine": info, "rev": revision, "repeats": args.repeats, "runs": {}}
    getfem = {}  # name: the script's path, where getfem is installed
    if _has_getfem():
        for name, script in GETFEM.items():
            getfem[name] = work / f"stand_in_{name}.py"  # not getfem.py: it would be imported
            getfem[name].write_text(script)
    getfem_times = {name: [] for name in getfem}
    getfem_cpu = {name: [] for name in getfem}
    try:
        for scene in args.scenes:
            out = work / "out"
            for env in versions.values():  # the caches as a second run finds them
                seconds(run_command(scene, out), env, work)
            times = {name: [] for name in versions}
            cpu = {name: [] for name in versions}
            for _ in range(args.repeats):
                for name, env in versions.items():
                    times[name].append(seconds(run_command(scene, out), env, work, cpu[name]))
                for name, script in getfem.items():
                    getfem_times[name].append(seconds([str(script)], dict(os.environ), work,
                                                      getfem_cpu[name]))
            results["runs"][scene] = {name: {"median": statistics.median(t), "all": t,
                                             "cpu_median": statistics.median(cpu[name]),
                                             "cpu_all": cpu[name]}
                                      for name, t in times.items()}
            if not args.no_fresh:
                results["runs"][scene].update(fresh_machine(scene, out, work, args.fresh))
            results["runs"][scene]["imports"] = {
                name: import_breakdown(run_command(scene, out), versions[name], work)
                for name in list(versions)[:2]}
        for name, t in getfem_times.items():
            results[name] = {"median": statistics.median(t), "all": t,
                             "cpu_median": statistics.median(getfem_cpu[name]),
                             "cpu_all": getfem_cpu[name]}
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)],
                       capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
    report(results)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


def _has_getfem() -> bool:
    return subprocess.run([sys.executable, "-c", "import getfem"],
                          capture_output=True).returncode == 0


def report(results: dict) -> None:
    print(f"whole process, median of {results['repeats']} (s; processor time in brackets):")
    for scene, runs in results["runs"].items():
        line = ", ".join(f"{name} {r['median']:.3f}"
                         + (f" [{r['cpu_median']:.3f}]" if "cpu_median" in r else "")
                         for name, r in runs.items() if name != "imports")
        print(f"  rodfem run {scene} {' '.join(SCENES[scene])}: {line}")
        for name, breakdown in runs["imports"].items():
            parts = ", ".join(f"{p} {s:.3f}" for p, s in breakdown["packages"].items())
            print(f"    imports of {name}: {breakdown['imports']:.3f} ({parts})")
    if "getfem" in results:
        for name, what in (("getfem", "import getfem, 1D mesh, P1, mass and stiffness"),
                           ("getfem_demo_imports", "the same with the demo's imports")):
            print(f"  GetFEM stand-in ({what}), interleaved: {results[name]['median']:.3f} "
                  f"[{results[name]['cpu_median']:.3f}]")
    else:
        print("  GetFEM: not installed (python3-getfem)")


if __name__ == "__main__":
    sys.exit(main())
