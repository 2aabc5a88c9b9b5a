"""Benchmark: what an adaptive step costs against a step of the fixed-step compiled loop, and
where its time goes (rodfem/solver/adaptive/stepper.py).

Runs, without files: paper1 (250 cells) with ``picard`` and ``direct``, stiff (paper1's rod
against 1/ε = 1e4, ``direct``) with each time scheme, impact (1000 cells) with ``direct``, and
with ``picard`` against an elastic obstacle (ε = 0.01: Picard cannot take the rigid one; with
a = 0 its steps are the PETSc loop's), each fixed-step and adaptive at the default tolerance.
For each: the time loop's µs per step (``Simulation.loop``'s over the steps), of the adaptive
run the second in its process, and the ratio of the adaptive step's µs to the fixed one's; the
first adaptive run, as a run of its own, also pays the imports and the forms' compilation that
its first new step size needs: its loop's seconds are given too. Then, from a third adaptive run with each part of the stepper timed (its timers add
about a microsecond per call), µs per accepted step in:

* step: the method's step itself (the compiled loop, one step per call, or the PETSc one);
* hand-over: the state handed to the method of the step's size and back (``_take``, ``_method``);
* methods: the methods and compiled loops made for new step sizes in Python (counted: on the
  controller's ladder, or located: sizes the root-finder of an event tried); the sizes formed
  inside the compiled calls (counted as "formed in C", the event's tries not counted) are part of
  "other";
* estimate: the error estimate (Milne's device, the two halves at a restart, the norm);
* record: the history's row in Python (``record_step``) and what it saves;
* locate: the Illinois iteration's own work (its steps and methods are counted above); per
  event, its evaluations and its whole time are given apart;
* other: the rest of the loop: the compiled calls of the regular steps (their steps, estimates,
  rows, events and the sizes they form), the controller, the contact test, the progress bar.

Each round measures every case once in a fresh process (so the first new step size pays its
imports in each, as in a run of its own); ``--rounds`` rounds are taken and the fastest kept
(these shared machines drift by tens of percent). ``--against REV`` also measures the code of git
revision REV (extracted to a temporary directory and imported from there), alternating with this
tree's round by round, so that old and new are compared on the same machine at the same time.

    .venv/bin/python benchmarks/bench_adaptive.py [--rounds 3] [--against REV] [--json FILE]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = {  # name: (scene, overrides)
    "paper1 picard": ("paper1", []),
    "paper1 direct": ("paper1", ["solver.method=direct"]),
    "stiff paper": ("stiff", ["time.scheme=paper"]),
    "stiff crank-nicolson": ("stiff", ["time.scheme=crank-nicolson"]),
    "impact direct": ("impact", []),
    "impact picard": ("impact", ["solver.method=picard", "obstacle.kind=elastic",
                                 "obstacle.epsilon=0.01"]),
}
# The process's CPU time: what other work on the shared cores takes does not count (its effect on
# the caches and the memory bus does).
CLOCK = time.process_time
PARTS = ("step", "hand-over", "methods", "estimate", "record", "locate", "other")


class Timers:
    """Exclusive times of wrapped functions: a call's time less that of the wrapped calls it
    makes, by part."""

    def __init__(self):
        self.seconds = dict.fromkeys(PARTS, 0.0)
        self.calls: dict[str, int] = {}
        self.stack: list[float] = []  # the time spent in the children of each open call

    def wrap(self, function, part: str, name: str | None = None):
        timers = self

        def timed(*args, **kwargs):
            timers.stack.append(0.0)
            started = CLOCK()
            try:
                return function(*args, **kwargs)
            finally:
                elapsed = CLOCK() - started
                children = timers.stack.pop()
                timers.seconds[part] += elapsed - children
                if timers.stack:
                    timers.stack[-1] += elapsed
                key = name or part
                timers.calls[key] = timers.calls.get(key, 0) + 1

        return timed


def timed_simulate(scene):
    """A run of ``scene`` without files, and the CPU seconds of its time loop."""
    from rodfem.run import Simulation, simulate

    loop, seconds = Simulation.loop, []

    def timed(self, *args, **kwargs):
        started = CLOCK()
        try:
            return loop(self, *args, **kwargs)
        finally:
            seconds.append(CLOCK() - started)

    Simulation.loop = timed
    try:
        return simulate(scene, None, progress=False), seconds[0]
    finally:
        Simulation.loop = loop


def instrumented(scene):
    """One adaptive run with the stepper's parts timed: the timers, the stepper's counts, the
    methods made (size, seconds, on the ladder) and the events' (evaluations, seconds)."""
    from rodfem.solver.adaptive import stepper as module
    from rodfem.solver.adaptive.control import rung
    from rodfem.solver.compiled.loop import CompiledLoop
    from rodfem.solver.methods.base import Method

    timers, made, events = Timers(), [], []
    cls = module.AdaptiveStepper
    saved = {name: getattr(cls, name) for name in ("__init__", "_take", "_method", "_predicted",
                                                   "_halves", "_accept", "_locate")
             if hasattr(cls, name)}
    steps = {CompiledLoop: CompiledLoop.advance, Method: Method.advance}
    init = saved["__init__"]
    try:  # the sizes formed inside the compiled calls (none before they were)
        from rodfem.solver.adaptive.compiled import CompiledSteps
    except ImportError:
        CompiledSteps = None
    regular_advance = CompiledSteps.advance if CompiledSteps is not None else None
    formed = [0]

    def counted_advance(self, *args, **kwargs):
        try:
            return regular_advance(self, *args, **kwargs)
        finally:
            formed[0] = getattr(self, "formed", 0)

    def __init__(self, home, scene, make, loop, record, *args, **kwargs):
        def timed_make(h, *once):
            started = CLOCK()
            try:
                return make(h, *once)
            finally:
                made.append((h, CLOCK() - started, rung(self.dt0, h) == h))

        init(self, home, scene, timers.wrap(timed_make, "methods"), loop,
             timers.wrap(record, "record"), *args, **kwargs)

    def _locate(self, *args, **kwargs):
        before, started = timers.calls.get("take", 0), CLOCK()
        try:
            return timed_locate(self, *args, **kwargs)
        finally:
            events.append((timers.calls.get("take", 0) - before,
                           CLOCK() - started))

    parts = {"_take": ("hand-over", "take"), "_method": ("hand-over", "method"),
             "_predicted": ("estimate", None), "_halves": ("estimate", "halves"),
             "_accept": ("estimate", "accept")}
    try:
        cls.__init__ = __init__
        for name, (part, key) in parts.items():
            if name in saved:
                setattr(cls, name, timers.wrap(saved[name], part, key))
        timed_locate = timers.wrap(saved["_locate"], "locate")
        cls._locate = _locate
        for owner, advance in steps.items():
            owner.advance = timers.wrap(advance, "step", f"step {owner.__name__}")
        if CompiledSteps is not None:
            CompiledSteps.advance = counted_advance
        result, loop = timed_simulate(scene)
    finally:
        for name, function in saved.items():
            setattr(cls, name, function)
        for owner, advance in steps.items():
            owner.advance = advance
        if CompiledSteps is not None:
            CompiledSteps.advance = regular_advance
    timers.seconds["other"] = loop - sum(timers.seconds.values())
    return timers, result.summary["adaptive"], made, events, loop, formed[0]


def measure() -> dict:
    """Every case, fixed-step and adaptive, once: the report of the code imported."""
    import rodfem.scene

    report = {}
    for case, (name, overrides) in CASES.items():
        out = {}
        for mode, extra in (("adaptive", ["time.adaptive=true"]), ("fixed", [])):
            scene = rodfem.scene.load(name, overrides + extra)
            runs = [timed_simulate(scene) for _ in range(2 if mode == "adaptive" else 1)]
            result = runs[0][0]
            steps = result.summary["adaptive"]["steps"] if mode == "adaptive" else scene.steps
            out[mode] = {"us_per_step": 1e6 * runs[-1][1] / steps, "steps": steps,
                         "first_seconds": runs[0][1]}
        timers, counts, made, events, loop, formed = instrumented(
            rodfem.scene.load(name, overrides + ["time.adaptive=true"]))
        accepted = counts["steps"]
        ladder = [h for h, _, on in made if on]
        out["adaptive"].update(
            counts, split={k: 1e6 * v / accepted for k, v in timers.seconds.items()},
            instrumented_us_per_step=1e6 * loop / accepted, calls=timers.calls,
            made={"count": len(made), "ladder": len(ladder), "ladder_sizes": len(set(ladder)),
                  "located": len(made) - len(ladder),
                  "ms_each": 1e3 * sum(s for _, s, _ in made) / max(len(made), 1),
                  "formed_in_c": formed},
            events_located=[{"evaluations": e, "ms": 1e3 * s} for e, s in events])
        report[case] = out
    return report


def machine() -> str:
    return (f"{platform.node()}, {platform.processor() or platform.machine()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}")


def extract(revision: str, tree: str) -> None:
    """The packages of git ``revision`` into the directory ``tree``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "rodfem", "forms"],
                             check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(tree)


def measured(tree: str) -> dict:
    """:func:`measure` in a fresh process importing rodfem from ``tree``."""
    env = dict(os.environ, PYTHONPATH=tree, RODFEM_BENCH_MEASURE="1")
    done = subprocess.run([sys.executable, __file__], env=env, check=True, capture_output=True,
                          text=True, cwd=tree)
    return json.loads(done.stdout)


def fastest(rounds: list[dict]) -> dict:
    """Per case: the fastest fixed-step loop, and the round of the fastest adaptive loop (its
    split from the timed run of that round)."""
    best = {}
    for case in CASES:
        fixed = min(r[case]["fixed"]["us_per_step"] for r in rounds)
        chosen = min(rounds, key=lambda r: r[case]["adaptive"]["us_per_step"])[case]
        best[case] = {**chosen, "fixed": {**chosen["fixed"], "us_per_step": fixed}}
    return best


def table(reports: dict[str, dict]) -> None:
    head = ("case", "code", "fixed µs", "adaptive µs", "adaptive/fixed", "first run s", "steps", "rejected",
            "events", *(f"{p} µs" for p in PARTS), "made (ladder/located)", "ms/made",
            "formed in C",
            "evals/event", "ms/event")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for case in CASES:
        for code, report in reports.items():
            r = report[case]
            a = r["adaptive"]
            made, events = a["made"], a["events_located"]
            evals = sum(e["evaluations"] for e in events) / max(len(events), 1)
            ms = sum(e["ms"] for e in events) / max(len(events), 1)
            cells = (case, code, f"{r['fixed']['us_per_step']:.1f}",
                     f"{a['us_per_step']:.1f}",
                     f"{a['us_per_step'] / r['fixed']['us_per_step']:.1f}",
                     f"{a['first_seconds']:.2f}", a["steps"],
                     a["rejected"], a["events"],
                     *(f"{a['split'][p]:.1f}" for p in PARTS),
                     f"{made['count']} ({made['ladder']}/{made['located']})",
                     f"{made['ms_each']:.1f}", made.get("formed_in_c", 0), f"{evals:.1f}",
                     f"{ms:.0f}")
            print("| " + " | ".join(str(c) for c in cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--against", metavar="REV", help="also measure git revision REV")
    parser.add_argument("--json", type=Path, help="write the numbers to this file")
    args = parser.parse_args()
    if os.environ.get("RODFEM_BENCH_MEASURE"):
        print(json.dumps(measure()))
        return
    with tempfile.TemporaryDirectory() as old:
        trees = {"this tree": str(ROOT)}
        if args.against:
            extract(args.against, old)
            trees = {args.against: old, **trees}
        rounds = {code: [] for code in trees}
        for _ in range(args.rounds):
            for code, tree in trees.items():
                rounds[code].append(measured(tree))
    reports = {code: fastest(taken) for code, taken in rounds.items()}
    print(f"machine: {machine()}; load average {os.getloadavg()[0]:.1f}\n")
    table(reports)
    if args.json:
        args.json.write_text(json.dumps({"machine": machine(), "reports": reports}, indent=1))


if __name__ == "__main__":
    main()
