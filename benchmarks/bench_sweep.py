"""Benchmark: what a sweep costs against single runs, and scenes per second on 1 and 2 ranks.

Two measurements, each as whole processes (start-up included: what a user waits for), taken
together in one invocation (these shared machines drift by tens of percent between runs):

* ``one run``: ``rodfem run paper1 --set solver.method=direct`` (T = 8, 250 cells, 8,000
  steps, its fields and files), the fastest of ``--repeats``; against ``rodfem sweep`` of 32
  paper1 scenes (the same, over a 8 × 4 grid of k and ζ). The target: the sweep at most 3× the
  one run.
* ``throughput``: ``mpirun -n N rodfem sweep`` of ``--scenes`` paper1 scenes for N = 1, 2:
  scenes per second in the sweep (its summary.json: from the first scene taken to the table
  written, start-up excluded) and over the whole process. The target: 30 scenes/s on 2 ranks.

    .venv/bin/python benchmarks/bench_sweep.py [--repeats 3] [--scenes 400]

The figures and the machine go to benchmarks/results/sweep.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
       "OMPI_MCA_rmaps_base_oversubscribe": "1"}
RESULTS = Path(__file__).with_name("results") / "sweep.json"


def sweep_file(path: Path, k: int, zeta: int) -> Path:
    path.write_text(f'''scene = "paper1"
[set]
"time.end" = 8
"solver.method" = "direct"
[grid]
"model.k" = {{logspace = [0.1, 100, {k}]}}
"model.zeta" = {{linspace = [0.2, 1.0, {zeta}]}}
''')
    return path


def timed(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, env=ENV, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenes", type=int, default=400, help="scenes of the throughput sweep")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-sweep-"))
    single = min(timed([RODFEM, "run", "paper1", "--set", "solver.method=direct", "--out",
                        str(root / f"run{i}"), "--quiet"]) for i in range(args.repeats))
    small = sweep_file(root / "small.toml", 8, 4)
    sweep32 = min(timed([RODFEM, "sweep", str(small), "--out", str(root / f"s{i}"), "--quiet"])
                  for i in range(args.repeats))
    print(f"one rodfem run paper1 (direct): {single:.2f} s; rodfem sweep of 32 scenes: "
          f"{sweep32:.2f} s = {sweep32 / single:.2f}x one run (target <= 3x)")
    big = sweep_file(root / "big.toml", args.scenes // 10, 10)
    throughput = {}
    for ranks in (1, 2):
        out = root / f"big{ranks}"
        wall = timed(["mpirun", "-n", str(ranks), RODFEM, "sweep", str(big), "--out", str(out),
                      "--quiet"])
        summary = json.loads((out / "summary.json").read_text())
        throughput[ranks] = {"scenes": summary["scenes"], "sweep_seconds": summary["seconds"],
                             "scenes_per_second": summary["scenes_per_second"],
                             "process_seconds": wall,
                             "scenes_per_second_with_start_up": summary["scenes"] / wall}
        print(f"mpirun -n {ranks}: {summary['scenes']} scenes in {summary['seconds']:.2f} s = "
              f"{summary['scenes_per_second']:.1f} scenes/s ({wall:.2f} s, "
              f"{summary['scenes'] / wall:.1f} scenes/s with start-up)")
    speedup = throughput[2]["scenes_per_second"] / throughput[1]["scenes_per_second"]
    print(f"speed-up on 2 ranks: {speedup:.2f} (target: >= 30 scenes/s on 2 ranks)")
    report = {"machine": {"host": platform.node(), "processor": platform.processor(),
                          "cpus": os.cpu_count(), "python": platform.python_version(),
                          "date": time.strftime("%Y-%m-%d %H:%M")},
              "one_run_seconds": single, "sweep_32_seconds": sweep32,
              "sweep_32_over_one_run": sweep32 / single, "throughput": throughput,
              "speedup_2_ranks": speedup}
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    print(f"-> {RESULTS}")


if __name__ == "__main__":
    main()
