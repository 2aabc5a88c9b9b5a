"""Benchmark: what ``rodfem paper`` (the paper's Section 6: five runs, their figures, index.md)
costs, whole and in parts, on this machine.

* ``rodfem paper``: the command as a user runs it, a whole process (start-up included), into a
  fresh directory; the fastest of ``--repeats``. The target: at most 15 s.
* its parts, in this process: the five runs alone (``rodfem.run.simulate``, the compiled loops
  warmed by a first run), then their figures and Figure 5's drawn one after another in this
  process, and drawn by the pool of worker processes that ``rodfem paper`` uses (start-up of
  the workers included).
* with ``--compare DIR``: the command also from the rodfem source tree in DIR (e.g. an earlier
  version's checkout, put first on PYTHONPATH), timed alternately with this one, so that the two
  are measured together (these shared machines drift by tens of percent: compare only numbers
  taken together).

    .venv/bin/python benchmarks/bench_paper.py [--repeats 3] [--compare DIR] [--json FILE]

The machine is printed first; ``--json`` also writes the numbers and the machine to FILE.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI


def command_seconds(out: Path, source: Path | None = None) -> float:
    """Wall time of ``python -m rodfem paper --out out`` (from ``source`` if given)."""
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(source), env.get("PYTHONPATH")]))
    shutil.rmtree(out, ignore_errors=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    # run from out's parent: "python -m" puts the working directory first on sys.path, and a
    # checkout's rodfem/ there would shadow PYTHONPATH
    subprocess.run([sys.executable, "-m", "rodfem", "paper", "--out", str(out)], check=True,
                   env=env, cwd=out.parent, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def parts(root: Path) -> dict:
    """The runs alone, then drawing one after another and with the pool."""
    import rodfem.scene
    from rodfem.output.directories import prepare_directory
    from rodfem.post.plot import prepare
    from rodfem.post.pool import Drawer, cpus
    from rodfem.post.tasks import draw
    from rodfem.run import simulate
    from rodfem.studies.verification.paper import EXPERIMENTS, FIGURE5_DIR, _figures

    comm = MPI.COMM_SELF
    warm = root / "warm"
    prepare_directory(warm, True, comm)
    simulate(rodfem.scene.load("paper1"), warm, comm, progress=False)
    dirs, started = [], time.perf_counter()
    for experiment in EXPERIMENTS:
        out = root / experiment.scene
        prepare_directory(out, True, comm)
        simulate(rodfem.scene.load(experiment.scene), out, comm, progress=False)
        dirs.append(out)
    runs = time.perf_counter() - started

    def tasks(figures: str):
        from rodfem.post.options import Options

        found = [t for d in dirs for t in prepare([d], root / figures / d.name, force=True)]
        return found + prepare(dirs[:2], root / figures / FIGURE5_DIR,
                               Options(only=frozenset({"contact", "energy"})), force=True)

    serial = tasks("serial")
    draw(serial[0])  # fonts, EGL and mathtext warmed, as a worker is before its first figure
    started = time.perf_counter()
    for task in serial:
        draw(task)
    one = time.perf_counter() - started
    started = time.perf_counter()
    with Drawer(cpus() - 1) as drawer:
        futures = [f for d in dirs for f in _figures(drawer, [d])]
        futures += _figures(drawer, dirs[:2], root / "pool" / FIGURE5_DIR)
        drawer.work()
        for future in futures:
            future.result()
    pool = time.perf_counter() - started
    return {"runs_seconds": runs, "figures": len(serial), "drawing_serial_seconds": one,
            "drawing_pool_seconds": pool, "processes": cpus()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--compare", type=Path, help="a rodfem source tree to time as well")
    parser.add_argument("--json", type=Path, help="write the numbers and the machine here")
    args = parser.parse_args()
    from rodfem.studies.common import machine

    report = {"machine": machine(MPI.COMM_WORLD)}
    print(json.dumps(report["machine"]))
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-paper-"))
    try:
        times, compared = [], []
        for i in range(args.repeats):
            if args.compare is not None:
                compared.append(command_seconds(root / f"compare{i}", args.compare))
            times.append(command_seconds(root / f"paper{i}"))
        report["rodfem_paper_seconds"] = min(times)
        report["rodfem_paper_all"] = times
        print(f"rodfem paper: {min(times):.1f} s (fastest of {args.repeats}: "
              f"{', '.join(f'{t:.1f}' for t in times)}; target <= 15 s)")
        if compared:
            report["compare"] = {"source": str(args.compare), "seconds": min(compared),
                                 "all": compared}
            print(f"rodfem paper from {args.compare}: {min(compared):.1f} s (fastest of "
                  f"{args.repeats}: {', '.join(f'{t:.1f}' for t in compared)})")
        report["parts"] = parts(root / "parts")
        p = report["parts"]
        print(f"parts: the five runs {p['runs_seconds']:.1f} s; {p['figures']} figures drawn one "
              f"after another {p['drawing_serial_seconds']:.1f} s, by {p['processes']} drawing "
              f"processes {p['drawing_pool_seconds']:.1f} s (their start-up included)")
    finally:
        shutil.rmtree(root, ignore_errors=True)
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
