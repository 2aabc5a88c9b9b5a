"""Benchmark: what saving fields costs a run, serially and under MPI.

paper1 at its defaults (250 cells, 8,000 steps) into a run directory, the loop's wall time
(``summary.json``'s ``loop_seconds``: the steps, the history, the field saves and the checkpoints),
three ways, each repeated and the fastest kept (these shared machines drift by tens of percent:
compare only numbers taken together):

* ``no fields``: ``output.every`` = the number of steps, so only t = 0 and T are saved;
* ``every 50``: the default, 161 saves;
* ``every 10``: 801 saves.

And a save's own cost as saves accumulate: ``FieldFile.write`` timed for the first and the last
hundred of 2,000 saves into one file (it must not grow with the count).

    .venv/bin/python benchmarks/bench_fields.py [--repeats 5]
    mpirun -n 2 .venv/bin/python benchmarks/bench_fields.py
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import rodfem.scene
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.directories import prepare_directory
from rodfem.output.fields import FieldFile
from rodfem.run import simulate
from rodfem.studies.common import machine

COMM = MPI.COMM_WORLD


def loop_seconds(every: int, root: Path) -> float:
    out = root / f"every{every}"
    if COMM.rank == 0:
        shutil.rmtree(out, ignore_errors=True)
    prepare_directory(out, False, COMM)
    result = simulate(rodfem.scene.load("paper1", [f"output.every={every}"]), out, COMM,
                      progress=False)
    return COMM.allreduce(result.summary["loop_seconds"], op=MPI.MAX)


def save_cost(root: Path, saves: int = 2000) -> tuple[float, float]:
    """µs per save of the first and of the last hundred of ``saves`` into one field file."""
    disc = Discretisation(rodfem.scene.load("paper1", []), COMM)
    out = root / "saves"
    if COMM.rank == 0:
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir()
    COMM.barrier()
    fields = FieldFile(out / "fields.xdmf", disc)
    state = np.zeros(3 * disc.nodes.size)  # [Θ; D; U]
    times = []
    for k in range(saves):
        started = time.perf_counter()
        fields.write(k, 0.001 * k, state)
        times.append(time.perf_counter() - started)
        if k % 500 == 499:
            fields.checkpoint()
    first, last = sum(times[:100]) / 100, sum(times[-100:]) / 100
    return 1e6 * COMM.allreduce(first, op=MPI.MAX), 1e6 * COMM.allreduce(last, op=MPI.MAX)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    root = COMM.bcast(Path(tempfile.mkdtemp(prefix="rodfem-bench-")) if COMM.rank == 0
                      else None)
    steps = rodfem.scene.load("paper1", []).steps
    cases = {"no fields": steps, "every 50": 50, "every 10": 10}
    best = dict.fromkeys(cases, float("inf"))
    for _ in range(args.repeats):
        for name, every in cases.items():
            best[name] = min(best[name], loop_seconds(every, root))
    first, last = save_cost(root)
    if COMM.rank == 0:
        shutil.rmtree(root, ignore_errors=True)
        for name, seconds in best.items():
            print(f"{name:>10}: {1e3 * seconds:7.1f} ms ({seconds / best['no fields']:.3f}× no "
                  "fields)")
        print(f"a save: {first:.1f} µs among the first 100, {last:.1f} µs among the last 100 "
              "of 2000")
        m = machine(COMM)
        print(json.dumps({"seconds": best, "save_us": {"first": first, "last": last},
                          "ranks": COMM.size, "machine": f"{m['cpu']}, {m['cpus']} cores"},
                         indent=2))


if __name__ == "__main__":
    main()
