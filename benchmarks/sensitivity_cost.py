"""Benchmark: what a sensitivity study costs against a plain sweep of the same scenes.

``rodfem sensitivity`` of 320 paper1 scenes (Sobol indices of three parameters, N = 64: N (D + 2)
runs) and ``rodfem sweep`` of the same 320 scenes (a ``[zip]`` of its samples.csv), each as a
whole process on one rank (start-up included: what a user waits for), the fastest of
``--repeats``, taken together in one invocation (these shared machines drift by tens of percent
between runs). Reported: scenes per second of each, over the whole process and in the sweep
engine (its summary.json: from the first scene taken to the table written); the analysis' time
(SALib's Sobol indices and their bootstrap, of the campaign's table, in this process after SALib
is imported) and its fraction of the campaign; the imports a campaign adds to a sweep's process
(SALib, and the chart's matplotlib and VTK). The target: the analysis negligible.

    .venv/bin/python benchmarks/sensitivity_cost.py [--repeats 3]

The figures and the machine go to benchmarks/results/sensitivity_cost.json.
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
RESULTS = Path(__file__).with_name("results") / "sensitivity_cost.json"
SCENE = '''scene = "paper1"
[set]
"mesh.cells" = 30
"time.end" = 1
"solver.method" = "direct"
'''
STUDY = SCENE + '''[parameters]
"model.zeta" = [0.2, 1.0]
"model.k" = [0.1, 10]
"obstacle.epsilon" = [1e-3, 1e-1]
'''


def timed(command: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def engine(summary: Path) -> float:
    """Scenes per second in the sweep engine."""
    return json.loads(summary.read_text())["scenes_per_second"]


def analysis_seconds(out: Path, repeats: int) -> tuple[float, int]:
    """The fastest analysis of the campaign's table in ``out`` (SALib imported before), and
    the rows it gave."""
    import numpy as np
    from SALib.analyze import sobol  # noqa: F401 (imported before the clock starts)

    from rodfem.studies.sensitivity import indices
    from rodfem.studies.sweep import parameters
    from rodfem.studies.sweep.run import load_sweep

    data = json.loads((out / "sensitivity.json").read_text())
    keys = tuple(parameters.Parameter(**p) for p in data["parameters"])
    plan = indices.plan(keys, data["method"], data["samples"], data["seed"])
    runs = load_sweep(out / "runs")
    outputs = {m: np.asarray(runs[m], dtype=float) for m in data["outputs"]}
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        rows, _ = indices.analyse(plan, outputs)
        best = min(best, time.perf_counter() - started)
    return best, len(rows)


IMPORTS = """import time, dolfinx
t = time.perf_counter(); import SALib.analyze.sobol, SALib.sample.sobol; a = time.perf_counter()
import rodfem.post.sensitivity; print(a - t, time.perf_counter() - a)"""


def import_seconds() -> tuple[float, float]:
    """What a campaign's process pays to import SALib, and the chart (rodfem.post: matplotlib
    and VTK), after dolfinx."""
    done = subprocess.run([sys.executable, "-c", IMPORTS], check=True, capture_output=True,
                          text=True)
    salib, chart = map(float, done.stdout.split())
    return salib, chart


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="rodfem-bench-sensitivity-"))
    study = root / "study.toml"
    study.write_text('samples = 64\noutputs = ["u_1_final", "max_penetration", '
                     '"contact_fraction"]\n' + STUDY)
    campaign = [timed([RODFEM, "sensitivity", str(study), "--out", str(root / f"s{i}"),
                       "--quiet"]) for i in range(args.repeats)]
    fastest = min(range(args.repeats), key=campaign.__getitem__)
    out = root / f"s{fastest}"
    samples = [line.split(",") for line in (out / "samples.csv").read_text().splitlines()]
    columns = {key: [float(row[j]) for row in samples[1:]]
               for j, key in enumerate(samples[0]) if key != "index"}
    sweep = root / "sweep.toml"
    sweep.write_text(SCENE + "[zip]\n" + "".join(f'"{key}" = {values!r}\n'
                                                 for key, values in columns.items()))
    plain = [timed([RODFEM, "sweep", str(sweep), "--out", str(root / f"w{i}"), "--quiet"])
             for i in range(args.repeats)]
    scenes = len(samples) - 1
    analysis, rows = analysis_seconds(out, args.repeats)
    salib, chart = min(import_seconds() for _ in range(args.repeats))
    report = {
        "machine": {"host": platform.node(), "processor": platform.processor(),
                    "cpus": os.cpu_count(), "python": platform.python_version(),
                    "date": time.strftime("%Y-%m-%d %H:%M")},
        "scenes": scenes, "ranks": 1,
        "sensitivity_seconds": min(campaign),
        "sensitivity_scenes_per_second": scenes / min(campaign),
        "sweep_seconds": min(plain), "sweep_scenes_per_second": scenes / min(plain),
        "sensitivity_engine_scenes_per_second": engine(out / "runs" / "summary.json"),
        "sweep_engine_scenes_per_second": max(engine(root / f"w{i}" / "summary.json")
                                              for i in range(args.repeats)),
        "analysis_seconds": analysis, "analysis_rows": rows,
        "analysis_fraction": analysis / min(campaign),
        "salib_import_seconds": salib, "chart_import_seconds": chart,
    }
    print(f"rodfem sensitivity of {scenes} scenes: {report['sensitivity_seconds']:.2f} s "
          f"({report['sensitivity_scenes_per_second']:.1f} scenes/s; in the engine "
          f"{report['sensitivity_engine_scenes_per_second']:.1f}/s)")
    print(f"rodfem sweep of the same scenes:  {report['sweep_seconds']:.2f} s "
          f"({report['sweep_scenes_per_second']:.1f} scenes/s; in the engine "
          f"{report['sweep_engine_scenes_per_second']:.1f}/s)")
    print(f"analysis ({rows} rows, bootstrap of 100): {analysis * 1e3:.1f} ms = "
          f"{100 * report['analysis_fraction']:.2f} % of the campaign")
    print(f"imports: SALib {salib:.2f} s, the chart (matplotlib and VTK) {chart:.2f} s")
    RESULTS.write_text(json.dumps(report, indent=2) + "\n")
    print(f"-> {RESULTS}")


if __name__ == "__main__":
    main()
