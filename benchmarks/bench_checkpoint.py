"""Benchmark: what crash-consistent output costs paper1 at its defaults (250 cells, 8,000 steps,
fields every 50 steps: 161 saves, a checkpoint every 5 s of wall time, so one at the end).

Three ways, in one process, each repeated and the fastest kept (these shared machines drift by
tens of percent between runs; compare only numbers taken together):

* ``bare``: ``simulate(scene, None)``, no files at all (the rows kept in memory);
* ``files``: into a run directory at the defaults: the loop with its field saves, then the final
  checkpoint (history.csv, the fields' segment and fields.xdmf, checkpoint.npz, each synced and
  renamed);
* ``every save``: ``output.checkpoint = 0``, a checkpoint at each of the 160 saves.

The time is the loop and the final writes (``simulate`` less its set-up).

    .venv/bin/python benchmarks/bench_checkpoint.py [--repeats 5] [--scene paper1]
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import rodfem.scene
from rodfem.output.directories import prepare_directory
from rodfem.run import simulate


def timed(scene, out: Path | None) -> float:
    if out is not None:
        shutil.rmtree(out, ignore_errors=True)
        prepare_directory(out, False, MPI.COMM_WORLD)
    started = time.perf_counter()
    result = simulate(scene, out, MPI.COMM_WORLD, progress=False)
    return time.perf_counter() - started - result.summary["setup_seconds"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--scene", default="paper1")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-"))
    cases = {"bare": ([], None), "files": ([], root / "files"),
             "every save": (["output.checkpoint=0"], root / "every")}
    best = {name: float("inf") for name in cases}
    for _ in range(args.repeats):
        for name, (overrides, out) in cases.items():
            scene = rodfem.scene.load(args.scene, overrides)
            best[name] = min(best[name], timed(scene, out))
    shutil.rmtree(root, ignore_errors=True)
    report = {"machine": f"{platform.node()} ({platform.processor() or platform.machine()})",
              "scene": args.scene, "seconds": best,
              "files_over_bare": best["files"] / best["bare"],
              "every_save_over_bare": best["every save"] / best["bare"]}
    for name, seconds in best.items():
        print(f"{name:>10}: {1e3 * seconds:7.1f} ms ({seconds / best['bare']:.3f}× bare)")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
