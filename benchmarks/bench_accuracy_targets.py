"""Evidence for accuracy targets (``[accuracy]``, docs/accuracy.md): on ``stiff`` (paper1's rod
against a stiff obstacle, 250 cells, T = 0.5) over ζ = model.zeta ∈ {0.1, 0.2, 0.5, 1} and
ε = obstacle.epsilon ∈ {1e-2, 1e-3, 1e-4}, the peak contact stress declared as a measure,

    [measures]
    peak = { column = "sigma_1", reduce = "max_abs" }

run with ``time.adaptive = true``, ``time.scheme = "crank-nicolson"`` and ``[accuracy] target``
0.01 and 0.001, as a user runs it: ``rodfem run FILE --out DIR --force --quiet``. For each grid
point and target:

1. **the reference**, converged in h and in time (in-process ``rodfem.simulate``, adaptive
   Crank–Nicolson): cells 4000, 8000, 16000 (doubled further while the last doubling moves the
   peak by 1e-4 relative or more) at tolerance 1e-8, and tolerances 1e-6, 1e-7, 1e-8 (divided
   by 10 further under the same rule) on 8000 cells; the reference is the finest run's peak,
   its uncertainty the Richardson estimate of that run's error in each direction (the last
   difference over R − 1, R the observed rate capped at 4 in h and at 10 in the tolerance, and
   the difference itself where the differences do not fall by 2 at least);
2. **the accuracy run**: whole-process wall time (fastest of ``--rounds``), the cells and
   tolerance it chose, its runs, the reported run's steps, its peak and estimated error; the
   true error |peak − reference|; covered (true error ≤ estimate), pessimism (estimate / true
   error), met (true relative error ≤ target); and each direction's true error beside its
   estimate: in h, the chosen mesh's peak converged in time (tolerance 1e-8) against the
   reference; in time, the reported peak against that;
3. **the hindsight cost**: the cheapest fixed-step Crank–Nicolson run (cells from 250 … 8000,
   Δt = T/n, n = 500 · 2^(j/2) rounded) whose true relative error is within the target and stays
   so for every finer Δt on that mesh. The search is in-process: each mesh's error in h is its
   adaptive run at tolerance 1e-8 against the reference; the coarsest three meshes whose error
   in h is within the target are scanned coarse Δt to fine until three rungs in a row are within
   a quarter of the slack left by the mesh (|peak − the mesh's converged peak| ≤ (target·ref −
   e_h)/4), finer rungs assumed to hold from there (a fixed Crank–Nicolson step's error jumps
   with Δt, so a rung that holds by luck is not counted). The first rung of each mesh from
   which every rung scanned holds is a candidate; the candidates
   are then timed as whole processes (``rodfem run stiff --set ...``): each once, the fastest and
   those within 25 % of it fastest of 3.

With ``--paper`` the accuracy runs are repeated with ``time.scheme = "paper"`` (adaptive) on a
subset of the grid, against the same references and hindsight runs.

Writes benchmarks/results/accuracy_targets.json and prints the tables (markdown):

    .venv/bin/python benchmarks/bench_accuracy_targets.py [--quick] [--reuse-references]
        [--rounds 2] [--paper] [--snapshot]

The full run with ``--paper --snapshot`` took 7.4 minutes on 2 shared cores (load 2.4-3.3);
``--quick`` (two grid points, one round) 1-2 minutes, and writes
$TMPDIR/accuracy_targets_quick.json instead. ``--reuse-references`` takes the references of the
results file already written (they take about a fifth of the full run). ``--snapshot`` runs
HEAD's committed rodfem/ (the results record the commit), not a working tree others edit.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RODFEM = str(Path(sys.executable).with_name("rodfem"))
RESULTS = ROOT / "benchmarks" / "results" / "accuracy_targets.json"
QUICK_RESULTS = Path(tempfile.gettempdir()) / "accuracy_targets_quick.json"  # not kept
ZETAS = (0.1, 0.2, 0.5, 1.0)
EPSILONS = (1e-2, 1e-3, 1e-4)
TARGETS = (1e-2, 1e-3)
QUICK_POINTS = ((0.1, 1e-4), (1.0, 1e-2))
PAPER_POINTS = ((0.1, 1e-4), (0.2, 1e-3), (0.5, 1e-2), (1.0, 1e-4))
END = 0.5  # stiff's time.end
MEASURES = {"peak": {"column": "sigma_1", "reduce": "max_abs"}}
# the reference
REF_CELLS, REF_TOLERANCES, REF_MESH = (4000, 8000, 16000), (1e-6, 1e-7, 1e-8), 8000
REF_MOVE = 1e-4  # the last refinement in each direction moves the peak by less (relative)
REF_CELLS_MAX, REF_TOLERANCE_MIN = 64000, 1e-10
# the hindsight search
HIND_CELLS = (250, 500, 1000, 2000, 4000, 8000)
HIND_MESHES = 3  # the coarsest meshes within the target in h that are scanned
HIND_HELD = 3  # rungs in a row within a quarter of the slack that end a mesh's scan
HIND_WORK = 1.3e8  # cells × steps beyond which a rung is not run
HIND_ROUNDS = 3


def point_name(zeta: float, epsilon: float) -> str:
    return f"zeta={zeta:g},epsilon={epsilon:g}"


# -- in-process runs -------------------------------------------------------------------------


def peak_of(zeta: float, epsilon: float, cells: int, **time_keys) -> dict:
    """One in-process run of stiff at (ζ, ε) with ``cells`` and the time keys given
    (tolerance= for adaptive Crank–Nicolson, dt= for fixed Crank–Nicolson): its peak, steps,
    seconds."""
    import rodfem

    overrides = {"model.zeta": zeta, "obstacle.epsilon": epsilon, "mesh.cells": cells,
                 "time.scheme": "crank-nicolson", "output.fields": ["u"]}
    if "tolerance" in time_keys:
        overrides.update({"time.adaptive": True, "time.tolerance": time_keys["tolerance"]})
    else:
        overrides.update({"time.adaptive": False, "time.dt": time_keys["dt"]})
    started = time.perf_counter()
    with warnings.catch_warnings():  # CoarseStepWarning on the coarsest fixed steps
        warnings.simplefilter("ignore")
        result = rodfem.simulate({"scene": "stiff", "measures": MEASURES}, overrides)
    seconds = time.perf_counter() - started
    if result.status != "complete":
        raise RuntimeError(f"{point_name(zeta, epsilon)}, {cells} cells, {time_keys}: "
                           f"{result.status}")
    return {"peak": float(result.measures["peak"]), "steps": int(result.summary["steps"]),
            "seconds": seconds}


def richardson(values: list[float], cap: float) -> dict:
    """The error of the last of ``values`` (refined by a constant ratio each): the last
    difference d over R − 1, R = the observed rate (the difference before over d) capped at
    ``cap``; d itself where R < 2 or only two values."""
    d = abs(values[-1] - values[-2])
    rate = abs(values[-2] - values[-3]) / d if len(values) >= 3 and d > 0 else None
    error = d / (min(rate, cap) - 1.0) if rate is not None and rate >= 2.0 else d
    return {"difference": d, "rate": rate, "error": error}


def reference(zeta: float, epsilon: float, say) -> dict:
    """The peak converged in h and in the tolerance, with its uncertainty."""
    runs: dict[str, dict] = {}

    def at(cells: int, tolerance: float) -> float:
        key = f"{cells},{tolerance:g}"
        if key not in runs:
            runs[key] = dict(peak_of(zeta, epsilon, cells, tolerance=tolerance), cells=cells,
                             tolerance=tolerance)
        return runs[key]["peak"]

    cells, tolerances = list(REF_CELLS), list(REF_TOLERANCES)
    while True:
        space = [at(c, tolerances[-1]) for c in cells]
        time_ = [at(REF_MESH, t) for t in tolerances]
        moved_h = abs(space[-1] - space[-2]) / abs(space[-1])
        moved_t = abs(time_[-1] - time_[-2]) / abs(time_[-1])
        if moved_h >= REF_MOVE and 2 * cells[-1] <= REF_CELLS_MAX:
            cells.append(2 * cells[-1])
        elif moved_t >= REF_MOVE and tolerances[-1] / 10 >= REF_TOLERANCE_MIN:
            tolerances.append(tolerances[-1] / 10)
        else:
            break
    h, t = richardson(space, 4.0), richardson(time_, 10.0)
    value = space[-1]
    out = {"value": value, "cells": cells[-1], "tolerance": tolerances[-1],
           "uncertainty": h["error"] + t["error"],
           "relative_uncertainty": (h["error"] + t["error"]) / abs(value),
           "space": dict(h, cells=cells, values=space, moved=moved_h),
           "time": dict(t, cells=REF_MESH, tolerances=tolerances, values=time_, moved=moved_t),
           "converged": moved_h < REF_MOVE and moved_t < REF_MOVE,
           "seconds": sum(r["seconds"] for r in runs.values()), "runs": list(runs.values())}
    say(f"  reference {point_name(zeta, epsilon)}: {value:.8g} ± {out['uncertainty']:.2g} "
        f"(moved {moved_h:.1e} in h, {moved_t:.1e} in the tolerance; {out['seconds']:.0f} s)")
    return out


# -- the accuracy run ------------------------------------------------------------------------


def scene_text(zeta: float, epsilon: float, target: float, scheme: str) -> str:
    return (f'scene = "stiff"\n\n[model]\nzeta = {zeta!r}\n\n[obstacle]\nepsilon = {epsilon!r}\n\n'
            f'[time]\nadaptive = true\nscheme = "{scheme}"\n\n'
            '[measures]\npeak = { column = "sigma_1", reduce = "max_abs" }\n\n'
            f"[accuracy]\ntarget = {target!r}\n")


def accuracy_run(zeta: float, epsilon: float, target: float, scheme: str, rounds: int,
                 tmp: Path, ref: dict, meshes: dict) -> dict:
    """``rodfem run FILE --out DIR --force --quiet`` on the scene with its target: the
    fastest of ``rounds`` whole processes, what it chose and reported, against ``ref``."""
    scene = tmp / f"accuracy_{scheme}_{zeta:g}_{epsilon:g}_{target:g}.toml"
    scene.write_text(scene_text(zeta, epsilon, target, scheme))
    out = tmp / "accuracy_run"
    command = [RODFEM, "run", str(scene), "--out", str(out), "--force", "--quiet"]
    times = []
    for _ in range(rounds):
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
        times.append(time.perf_counter() - started)
        if done.returncode != 0:
            return {"status": f"exit {done.returncode}", "message": done.stderr.strip(),
                    "seconds": min(times)}
    summary = json.loads((out / "summary.json").read_text())
    with open(out / "accuracy.csv", newline="") as f:
        ladder = [{k: float(v) if k not in ("run", "cells", "steps", "rejected_steps")
                   else int(v) for k, v in row.items()} for row in csv.DictReader(f)]
    acc = summary["accuracy"]
    m = acc["measures"]["peak"]
    peak, estimate = float(summary["measures"]["peak"]), float(m["error"])
    true = abs(peak - ref["value"])
    # each direction's true error: the reported mesh's peak converged in time against the
    # reference (in h), the reported peak against that (in time)
    mesh = meshes.get(acc["cells"]) or meshes.setdefault(acc["cells"], mesh_error(
        zeta, epsilon, acc["cells"], ref))
    true_h, true_t = abs(mesh["peak"] - ref["value"]), abs(peak - mesh["peak"])
    est_h = m["space"]["error"] if m["space"] else math.inf
    est_t = m["time"]["error"] if m["time"] else math.inf
    return {"status": summary.get("status", "complete"), "seconds": min(times),
            "all_seconds": times, "ladder_seconds": acc["seconds"],
            "cells": acc["cells"], "tolerance": acc.get("tolerance"), "runs": acc["runs"],
            "steps": summary["steps"], "reported_met": acc["met"], "limit": acc["limit"],
            "peak": peak, "estimate": estimate, "space": m["space"], "time": m["time"],
            "true_error": true, "relative_true_error": true / abs(ref["value"]),
            "true_space_error": true_h, "true_time_error": true_t,
            "space_covered": bool(true_h <= est_h), "time_covered": bool(true_t <= est_t),
            "relative_estimate": estimate / abs(peak),
            "covered": bool(true <= estimate),
            # whether the reference is precise enough to tell covered from not
            "coverage_sure": bool(abs(true - estimate) > ref["uncertainty"]),
            "pessimism": estimate / true if true > 0 else math.inf,
            "met": bool(true <= target * abs(ref["value"])),
            "stderr": done.stderr.strip()[-2000:], "accuracy_csv": ladder}


# -- the hindsight cost ----------------------------------------------------------------------


def steps_ladder() -> list[int]:
    """n = 500 · 2^(j/2) rounded, j = 0, 1, …"""
    return [round(500 * 2.0 ** (j / 2)) for j in range(40)]


def mesh_error(zeta: float, epsilon: float, cells: int, ref: dict) -> dict:
    """A mesh's peak converged in time (adaptive, tolerance 1e-8; the reference's own run where
    it made one) and its relative error in h."""
    made = {r["cells"]: r for r in ref["runs"] if r["tolerance"] == 1e-8}
    run = made.get(cells) or peak_of(zeta, epsilon, cells, tolerance=1e-8)
    return {"peak": run["peak"], "error": abs(run["peak"] - ref["value"]) / abs(ref["value"])}


def mesh_errors(zeta: float, epsilon: float, ref: dict) -> dict[int, dict]:
    """Each hindsight mesh's :func:`mesh_error`."""
    return {cells: mesh_error(zeta, epsilon, cells, ref) for cells in HIND_CELLS}


def scan_mesh(zeta: float, epsilon: float, cells: int, converged: float, ref: float,
              target: float, cache: dict) -> dict:
    """Fixed Crank–Nicolson steps on ``cells``, coarse to fine, until HIND_HELD rungs in a row
    are within a quarter of the slack the mesh leaves: the rungs and the first from which
    every one holds the target (None: none, or the scan was cut at HIND_WORK)."""
    slack = target * abs(ref) - abs(converged - ref)
    rungs, in_row, finished = [], 0, False
    for n in steps_ladder():
        if cells * n > HIND_WORK:
            break
        key = (cells, n)
        if key not in cache:
            cache[key] = peak_of(zeta, epsilon, cells, dt=END / n)
        run = cache[key]
        error = abs(run["peak"] - ref) / abs(ref)
        rungs.append({"cells": cells, "n": n, "dt": END / n, "peak": run["peak"],
                      "error": error, "seconds": run["seconds"], "held": error <= target})
        in_row = in_row + 1 if abs(run["peak"] - converged) <= slack / 4 else 0
        if in_row >= HIND_HELD:
            finished = True
            break
    first = None
    if finished:
        for j in range(len(rungs)):
            if all(r["held"] for r in rungs[j:]):
                first = rungs[j]
                break
    return {"cells": cells, "slack": slack, "finished": finished, "rungs": rungs,
            "reached": first}


def whole_process(zeta: float, epsilon: float, cells: int, n: int, tmp: Path,
                  rounds: int) -> float:
    command = [RODFEM, "run", "stiff", "--out", str(tmp / "hindsight_run"), "--force", "--quiet"]
    for setting in (f"model.zeta={zeta!r}", f"obstacle.epsilon={epsilon!r}",
                    f"mesh.cells={cells}", "time.scheme=crank-nicolson", "time.adaptive=false",
                    f"time.dt={END / n!r}"):
        command += ["--set", setting]
    best = math.inf
    for _ in range(rounds):
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
        seconds = time.perf_counter() - started
        if done.returncode != 0:
            raise RuntimeError(f"hindsight run failed: {' '.join(command)}\n{done.stderr}")
        best = min(best, seconds)
    return best


def hindsight(zeta: float, epsilon: float, target: float, ref: dict, meshes: dict,
              cache: dict, timed: dict, tmp: Path) -> dict:
    value = ref["value"]
    within = [c for c in HIND_CELLS if meshes[c]["error"] < target][:HIND_MESHES]
    scans = [scan_mesh(zeta, epsilon, c, meshes[c]["peak"], value, target, cache)
             for c in within]
    candidates = [s["reached"] for s in scans if s["reached"]]
    for c in candidates:  # each once, then the fastest (and those within 25 %) again
        key = (c["cells"], c["n"])
        if key not in timed:
            timed[key] = [whole_process(zeta, epsilon, c["cells"], c["n"], tmp, 1), 1]
    fastest = min((timed[c["cells"], c["n"]][0] for c in candidates), default=None)
    for c in candidates:
        entry = timed[c["cells"], c["n"]]
        if entry[0] <= 1.25 * fastest and entry[1] < HIND_ROUNDS:
            entry[0] = min(entry[0], whole_process(zeta, epsilon, c["cells"], c["n"], tmp,
                                                   HIND_ROUNDS - entry[1]))
            entry[1] = HIND_ROUNDS
        c["whole_process_seconds"], c["whole_process_rounds"] = entry
    best = min(candidates, key=lambda c: c["whole_process_seconds"]) if candidates else None
    return {"meshes_scanned": within, "scans": scans, "candidates": candidates, "best": best}


# -- the whole ---------------------------------------------------------------------------------


def machine() -> str:
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def code_version() -> dict:
    """The commit measured and rodfem/'s tree (with whether it differs from the commit's)."""
    def git(*args):
        return subprocess.run(["git", *args], capture_output=True, text=True,
                              cwd=ROOT).stdout.strip()

    import rodfem

    where = str(Path(rodfem.__file__).resolve().parent)
    if SNAPSHOT:
        return {"commit": SNAPSHOT, "rodfem": where, "snapshot": True}
    return {"commit": git("rev-parse", "HEAD"), "rodfem_tree": git("rev-parse", "HEAD:rodfem"),
            "rodfem_modified": bool(git("status", "--porcelain", "--", "rodfem")),
            "rodfem": where}


SNAPSHOT = None  # the commit --snapshot runs


def snapshot(directory: Path) -> str:
    """rodfem/ and forms/ of HEAD into ``directory``, put first on the path of this process and
    of the runs it starts (other engineers edit the working tree meanwhile): HEAD's commit."""
    global SNAPSHOT
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT, check=True).stdout.strip()
    archive = subprocess.run(["git", "archive", commit, "rodfem", "forms"], capture_output=True,
                             cwd=ROOT, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(directory)], input=archive, check=True)
    sys.path.insert(0, str(directory))
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(directory), os.environ.get("PYTHONPATH")) if p)
    SNAPSHOT = commit
    return commit


def say(text: str) -> None:
    print(text, flush=True)


def measure(args) -> dict:
    points = QUICK_POINTS if args.quick else tuple((z, e) for z in ZETAS for e in EPSILONS)
    paper_points = [p for p in PAPER_POINTS if p in points] if args.paper else []
    rounds = 1 if args.quick else args.rounds
    cached = {}
    if args.reuse_references:
        for path in (RESULTS, QUICK_RESULTS):
            if path.exists():
                cached.update(json.loads(path.read_text()).get("references", {}))
    started = time.perf_counter()
    data = {"machine": machine(), "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "load_average_start": os.getloadavg(), "quick": args.quick, "rounds": rounds,
            "command": " ".join([Path(sys.executable).name, *sys.argv]),
            "rodfem": code_version(), "targets": TARGETS, "references": {}, "points": {},
            "paper": {}}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for zeta, epsilon in points:
            name = point_name(zeta, epsilon)
            say(f"{name}:")
            ref = cached.get(name) or reference(zeta, epsilon, say)
            data["references"][name] = ref
            meshes = mesh_errors(zeta, epsilon, ref)
            cache, timed = {}, {}
            entry = {"zeta": zeta, "epsilon": epsilon, "mesh_errors": meshes, "targets": {}}
            for target in TARGETS:
                acc = accuracy_run(zeta, epsilon, target, "crank-nicolson", rounds, tmp, ref,
                                   meshes)
                hind = hindsight(zeta, epsilon, target, ref, meshes, cache, timed, tmp)
                best = hind["best"]
                ratio = (acc["seconds"] / best["whole_process_seconds"]
                         if best and "peak" in acc else None)
                entry["targets"][f"{target:g}"] = {"accuracy": acc, "hindsight": hind,
                                                   "ratio": ratio}
                say(f"  target {target:g}: " + line(acc, best, ratio))
            data["points"][name] = entry
            if (zeta, epsilon) in paper_points:
                data["paper"][name] = {}
                for target in TARGETS:
                    acc = accuracy_run(zeta, epsilon, target, "paper", rounds, tmp, ref, meshes)
                    best = entry["targets"][f"{target:g}"]["hindsight"]["best"]
                    ratio = (acc["seconds"] / best["whole_process_seconds"]
                             if best and "peak" in acc else None)
                    data["paper"][name][f"{target:g}"] = {"accuracy": acc, "ratio": ratio}
                    say(f"  paper, target {target:g}: " + line(acc, best, ratio))
            RESULTS.parent.mkdir(exist_ok=True)
            (QUICK_RESULTS if args.quick else RESULTS).write_text(
                json.dumps(data, indent=1, allow_nan=True) + "\n")  # partial, point by point
    data["load_average_end"] = os.getloadavg()
    data["rodfem_end"] = code_version()  # other engineers commit on main meanwhile
    data["total_seconds"] = time.perf_counter() - started
    data["summary"] = {"crank-nicolson": summary(data["points"], TARGETS)}
    if data["paper"]:
        data["summary"]["paper"] = summary(
            {k: {"targets": v} for k, v in data["paper"].items()}, TARGETS)
    return data


def line(acc: dict, best: dict | None, ratio: float | None) -> str:
    if "peak" not in acc:
        return f"{acc['status']}: {acc.get('message', '')[-300:]}"
    hind = (f"hindsight {best['cells']} cells, n = {best['n']}, "
            f"{best['whole_process_seconds']:.2f} s" if best else "no hindsight run")
    return (f"{acc['cells']} cells, tolerance {acc['tolerance']:g}, {acc['runs']} runs, "
            f"peak {acc['peak']:.6g} ± {acc['estimate']:.2g}, true error "
            f"{acc['true_error']:.2g}, covered {acc['covered']}, met {acc['met']}, "
            f"{acc['seconds']:.2f} s; {hind}; ratio "
            + (f"{ratio:.2f}" if ratio else "—"))


def summary(points: dict, targets) -> dict:
    out = {}
    for target in targets:
        rows = [p["targets"][f"{target:g}"] for p in points.values()]
        accs = [r["accuracy"] for r in rows if "peak" in r["accuracy"]]
        ratios = [r["ratio"] for r in rows if r["ratio"] is not None]
        out[f"{target:g}"] = {
            "runs": len(accs),
            "coverage": sum(a["covered"] for a in accs) / len(accs) if accs else None,
            "not_covered": [f"{a['peak']:.6g}" for a in accs if not a["covered"]],
            "max_pessimism": max((a["pessimism"] for a in accs), default=None),
            "median_pessimism": statistics.median([a["pessimism"] for a in accs])
            if accs else None,
            "space_coverage": sum(a["space_covered"] for a in accs) / len(accs)
            if accs else None,
            "time_coverage": sum(a["time_covered"] for a in accs) / len(accs)
            if accs else None,
            "met": sum(a["met"] for a in accs) / len(accs) if accs else None,
            "reported_met": sum(a["reported_met"] for a in accs) / len(accs) if accs else None,
            "median_ratio": statistics.median(ratios) if ratios else None,
            "max_ratio": max(ratios) if ratios else None,
            "within_5x": sum(r <= 5 for r in ratios) / len(ratios) if ratios else None}
    all_ratios = [r["ratio"] for p in points.values() for r in p["targets"].values()
                  if r["ratio"] is not None]
    all_accs = [r["accuracy"] for p in points.values() for r in p["targets"].values()
                if "peak" in r["accuracy"]]
    out["all"] = {"coverage": sum(a["covered"] for a in all_accs) / len(all_accs)
                  if all_accs else None,
                  "max_pessimism": max((a["pessimism"] for a in all_accs), default=None),
                  "met": sum(a["met"] for a in all_accs) / len(all_accs) if all_accs else None,
                  "median_ratio": statistics.median(all_ratios) if all_ratios else None,
                  "max_ratio": max(all_ratios) if all_ratios else None}
    return out


def tables(data: dict) -> None:
    la = data["load_average_start"]
    print(f"\nmachine: {data['machine']}; load average {la[0]:.2f} {la[1]:.2f} {la[2]:.2f} at the "
          f"start, {data['load_average_end'][0]:.2f} at the end; {data['date']}; "
          f"total {data['total_seconds']:.0f} s\n")
    for scheme, source in (("crank-nicolson", data["points"]), ("paper", data["paper"])):
        if not source:
            continue
        for target in TARGETS:
            print(f"\n### {scheme}, adaptive, target {target:g}\n")
            print("| ζ | ε | reference | cells | tolerance | runs | steps | reported peak ± "
                  "estimate | true error | covered | pessimism | met | wall s | hindsight "
                  "(cells, Δt, wall s) | ratio |")
            print("|" + "---|" * 15)
            for name, entry in source.items():
                point = data["points"][name]
                row = entry if scheme == "paper" else entry["targets"]
                r = row[f"{target:g}"]
                acc, ref = r["accuracy"], data["references"][name]["value"]
                best = point["targets"][f"{target:g}"]["hindsight"]["best"]
                hind = (f"{best['cells']}, {best['dt']:.3g}, {best['whole_process_seconds']:.2f}"
                        if best else "—")
                head = f"| {point['zeta']:g} | {point['epsilon']:g} | {ref:.7g} |"
                if "peak" not in acc:
                    print(f"{head} {acc['status']} |" + " |" * 12)
                    continue
                print(f"{head} {acc['cells']} | {acc['tolerance']:g} | {acc['runs']} | "
                      f"{acc['steps']} | {acc['peak']:.6g} ± {acc['estimate']:.2g} | "
                      f"{acc['true_error']:.2g} ({acc['relative_true_error']:.1e}) | "
                      f"{'yes' if acc['covered'] else '**no**'} | {acc['pessimism']:.3g} | "
                      f"{'yes' if acc['met'] else '**no**'} | {acc['seconds']:.2f} | {hind} | "
                      + (f"{r['ratio']:.2f}" if r["ratio"] else "—") + " |")
        print(f"\nsummary ({scheme}):")
        for key, s in data["summary"][scheme].items():
            print(f"  {key}: " + ", ".join(
                f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in s.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="two grid points, one round")
    parser.add_argument("--reuse-references", action="store_true",
                        help="take the references of the results file already written")
    parser.add_argument("--rounds", type=int, default=2,
                        help="whole-process runs of each accuracy run (the fastest kept)")
    parser.add_argument("--paper", action="store_true",
                        help="also the paper scheme (adaptive) on a subset of the grid")
    parser.add_argument("--snapshot", action="store_true",
                        help="run HEAD's rodfem/ (git archive into a temporary directory), not "
                             "the working tree's")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as code:
        if args.snapshot:
            say(f"running rodfem of commit {snapshot(Path(code))}")
        data = measure(args)
    (QUICK_RESULTS if args.quick else RESULTS).write_text(
        json.dumps(data, indent=1, allow_nan=True) + "\n")
    tables(data)


if __name__ == "__main__":
    main()
