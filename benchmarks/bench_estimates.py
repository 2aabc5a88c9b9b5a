"""How good the error estimates of accuracy targets (``[accuracy]``, docs/accuracy-targets.md)
are, over random manufactured scenes whose measures have exact values: how often an estimate
covers the exact error, and by how much it exceeds it.

Each scene (``tests/random_manufactured.py``: the model's a, b, ζ, the end time, the first mesh
and step, the scheme and the target drawn at random) is run in-process to its target with
``rodfem.simulate``, and each of its three measures gives a case: its reported estimate beside
|m − m_exact|. Printed and written (``--json``): the cases covered, the estimate over the exact
error (median, 90th percentile, largest, how many over 30), the targets met whose exact error is
not within them, the runs made and their time, per scheme and in all.

    .venv/bin/python benchmarks/bench_estimates.py [--scenes 200] [--seed 7]
        [--json benchmarks/results/estimates.json]

200 scenes take about a minute on 2 cores. The test (``tests/test_accuracy_targets.py``, ``-m
slow``) runs 10 of them, from seed 20261206.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from bench_accuracy_targets import machine  # noqa: E402
from random_manufactured import exact, random_scene  # noqa: E402

import rodfem  # noqa: E402

PESSIMISM = 30.0  # the most an estimate should exceed the exact error by


def run(scenes: int, seed: int) -> list[dict]:
    rng = random.Random(seed)
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(scenes):
            text, end = random_scene(rng)
            path = Path(tmp) / f"random{i}.toml"
            path.write_text(text)
            started = time.perf_counter()
            result = rodfem.simulate(path)
            seconds = time.perf_counter() - started
            accuracy = result.summary["accuracy"]
            scheme = result.scene["time.scheme"]
            for name, value in exact(end).items():
                m, error = result.measures[name], result.errors[name]
                cases.append({"scene": i, "scheme": scheme, "measure": name,
                              "target": accuracy["measures"][name]["target"],
                              "met": accuracy["measures"][name]["met"], "value": m,
                              "exact": value, "true_error": abs(m - value), "estimate": error,
                              "runs": accuracy["runs"], "seconds": seconds})
            if sys.stderr.isatty():
                print(f"\r{i + 1}/{scenes} scenes", end="", file=sys.stderr, flush=True)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    return cases


def summary(cases: list[dict]) -> dict:
    ratios = sorted(c["estimate"] / c["true_error"] for c in cases if c["true_error"] > 0.0)
    scenes = {c["scene"]: c for c in cases}.values()
    return {
        "cases": len(cases),
        "covered": sum(c["true_error"] <= c["estimate"] for c in cases),
        "pessimism_median": statistics.median(ratios),
        "pessimism_90": ratios[int(0.9 * (len(ratios) - 1))],
        "pessimism_max": ratios[-1],
        "over_30": sum(r > PESSIMISM for r in ratios),
        "met_but_missed": sum(c["met"] and c["true_error"] > c["target"] * abs(c["value"])
                              for c in cases),
        "runs": sum(c["runs"] for c in scenes),
        "seconds": sum(c["seconds"] for c in scenes),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--json", type=Path, default=HERE / "results" / "estimates.json")
    args = parser.parse_args()
    cases = run(args.scenes, args.seed)
    groups = {"all": cases}
    for scheme in sorted({c["scheme"] for c in cases}):
        groups[scheme] = [c for c in cases if c["scheme"] == scheme]
    table = {name: summary(group) for name, group in groups.items()}
    print("| scenes | cases | covered | estimate / exact error: median, 90 %, largest "
          "| over 30× | met, exact error not within | runs | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for name, s in table.items():
        print(f"| {name} | {s['cases']} | {s['covered']} ({100 * s['covered'] / s['cases']:.1f} %)"
              f" | {s['pessimism_median']:.2f}, {s['pessimism_90']:.2f}, {s['pessimism_max']:.1f}"
              f" | {s['over_30']} | {s['met_but_missed']} | {s['runs']} | {s['seconds']:.1f} |")
    load = os.getloadavg()
    print(f"\nmachine: {machine()}; load average {load[0]:.2f} at the end")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    head = {"machine": machine(), "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "load_average_end": list(load),
            "command": "python benchmarks/bench_estimates.py " + " ".join(sys.argv[1:]),
            "scenes": args.scenes, "seed": args.seed, "summary": table}
    text = json.dumps(head, indent=1)[:-2]  # the cases one a line
    text += ',\n "cases": [\n' + ",\n".join(json.dumps(c) for c in cases) + "\n ]\n}\n"
    args.json.write_text(text)


if __name__ == "__main__":
    main()
