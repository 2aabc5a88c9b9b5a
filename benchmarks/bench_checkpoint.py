"""Benchmark: what crash-consistent output costs paper1 at its defaults (250 cells, 8,000 steps,
fields every 50 steps: 161 saves, a checkpoint every 5 s of wall time, so one at the end).

Three ways, in one process, each repeated and the fastest kept (these shared machines drift by
tens of percent between runs; compare only numbers taken together):

* ``bare``: ``simulate(scene, None)``, no files at all (the rows kept in memory);
* ``files``: into a run directory at the defaults: the loop with its field saves, then the final
  checkpoint (history.h5, the fields' segment and fields.xdmf, checkpoint.npz, each synced and
  renamed);
* ``no fsync``: as ``files`` with ``os.fsync`` a no-op: the same files, not flushed to the disk;
  ``files`` − ``no fsync`` is the price of durability;
* ``every save``: ``output.checkpoint = 0``, a checkpoint at each of the 160 saves.

The time is the loop and the final writes (``simulate`` less its set-up); ``checkpoint`` is the
time of the checkpoints alone (``summary.json``'s ``checkpoint_seconds``).

    .venv/bin/python benchmarks/bench_checkpoint.py [--repeats 5] [--scene paper1]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import rodfem.scene
from rodfem.output.directories import prepare_directory
from rodfem.run import simulate


def timed(scene, out: Path | None, fsync: bool = True) -> tuple[float, float]:
    if out is not None:
        shutil.rmtree(out, ignore_errors=True)
        prepare_directory(out, False, MPI.COMM_WORLD)
    real = os.fsync
    if not fsync:
        os.fsync = lambda fd: None
    try:
        started = time.perf_counter()
        result = simulate(scene, out, MPI.COMM_WORLD, progress=False)
        seconds = time.perf_counter() - started - result.summary["setup_seconds"]
    finally:
        os.fsync = real
    return seconds, result.summary.get("checkpoint_seconds", 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--scene", default="paper1")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-"))
    cases = {"bare": ([], None, True), "files": ([], root / "files", True),
             "no fsync": ([], root / "nofsync", False),
             "every save": (["output.checkpoint=0"], root / "every", True)}
    best = {name: (float("inf"), 0.0) for name in cases}
    for _ in range(args.repeats):
        for name, (overrides, out, fsync) in cases.items():
            scene = rodfem.scene.load(args.scene, overrides)
            best[name] = min(best[name], timed(scene, out, fsync))
    shutil.rmtree(root, ignore_errors=True)
    seconds = {name: b[0] for name, b in best.items()}
    report = {"machine": f"{platform.node()} ({platform.processor() or platform.machine()}, "
                         f"{os.cpu_count()} cores)",
              "scene": args.scene, "seconds": seconds,
              "checkpoint_seconds": {name: b[1] for name, b in best.items()},
              "durability_over_files": (seconds["files"] - seconds["no fsync"]) / seconds["files"]}
    for name, (total, checkpoint) in best.items():
        print(f"{name:>10}: {1e3 * total:7.1f} ms ({total / seconds['bare']:.3f}× bare), "
              f"checkpoints {1e3 * checkpoint:6.1f} ms")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
