"""Benchmark: the size of a long run's directory at the scene's defaults, and that every step's
history is still there to read.

paper1 to T = 400 (400,000 steps of Δt = 0.001 on 250 cells) by ``rodfem run`` in a process of
its own, as a user runs it; then the directory's size per file, and the history read back by
``rodfem.load`` (every step n = 0 … N, once each, in order) and the fields by
``rodfem.read_fields``. The machine is printed with the figures.

    .venv/bin/python benchmarks/bench_long_run.py [--end 400] [--scene paper1] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

LIMIT = 30e6  # bytes: what a 400,000-step paper1 run may write at its defaults


def sizes(run: Path) -> dict[str, int]:
    """Bytes per file of a run directory, those of fields/ summed under its name."""
    found = {}
    for entry in sorted(run.iterdir()):
        if entry.is_dir():
            found[entry.name + "/"] = sum(p.stat().st_size for p in entry.rglob("*")
                                          if p.is_file())
        else:
            found[entry.name] = entry.stat().st_size
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--end", type=float, default=400.0)
    parser.add_argument("--scene", default="paper1")
    parser.add_argument("--keep", type=Path, help="write the run here (kept) instead of a "
                        "temporary directory")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-"))
    run = args.keep or root / "run"
    rodfem_command = Path(sys.executable).with_name("rodfem")
    try:
        started = time.perf_counter()
        subprocess.run([str(rodfem_command), "run", args.scene, "--set", f"time.end={args.end}",
                        "--out", str(run), "--quiet", *(["--force"] if run.exists() else [])],
                       check=True)
        seconds = time.perf_counter() - started
        files = sizes(run)
        total = sum(files.values())

        import rodfem

        started = time.perf_counter()
        result = rodfem.load(run)
        load_seconds = time.perf_counter() - started
        steps = result.summary["steps"]
        n = np.rint(result.history["t"] / result.scene["time.dt"]).astype(np.int64)
        every_step = bool(np.array_equal(n, np.arange(steps + 1)))
        fields = rodfem.read_fields(run / "fields.xdmf")

        print(f"machine: {platform.node()}, {platform.processor() or platform.machine()}, "
              f"{os.cpu_count()} cores, Python {platform.python_version()}")
        print(f"{args.scene} to T = {args.end:g}: {steps:,} steps, whole run {seconds:.1f} s, "
              f"loop {result.summary['loop_seconds']:.1f} s")
        for name, size in files.items():
            print(f"  {name:<16} {size / 1e6:9.3f} MB")
        print(f"  {'total':<16} {total / 1e6:9.3f} MB (at most {LIMIT / 1e6:g} MB: "
              f"{'yes' if total <= LIMIT else 'NO'})")
        print(f"history: {len(result.history):,} rows, every step 0..{steps} once in order: "
              f"{'yes' if every_step else 'NO'}; read by rodfem.load in {load_seconds:.2f} s")
        print(f"fields: {fields.t.size} saved steps, t = {fields.t[0]:g} … {fields.t[-1]:g}")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
