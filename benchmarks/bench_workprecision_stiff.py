"""Work against precision on ``stiff`` (paper1's rod against 1/ε = 1e4, ζ = 0.1, T = 0.5, 250
cells, the direct method): the error of the peak contact stress max |σ(1)| against the whole
process's wall time of ``rodfem run`` (start-up, set-up, time loop and the files written, as a
user runs it), for each time scheme, fixed steps against adaptive ones.

* fixed steps: Δt = T/n, n = 500 · 2^(j/2) (Crank–Nicolson's down to 7.8e-6, the paper scheme's down to
  4.9e-7);
* adaptive steps: time.tolerance = 1e-2 … 1e-8 (the paper scheme's from 1e-3), the first step
  1e-3 (the scene's);
* the reference: fixed Crank–Nicolson steps of 2.5e-6, checked against 5e-6 (they must agree to
  1e-5 relative, a tenth of the finest accuracy asked; measured 1.3e-6).

For each accuracy (1 %, 0.1 %, 0.01 %) and each ladder, the time at which it is *reached*: that
of the cheapest run from which every finer run of the ladder holds it too (a fixed
Crank–Nicolson step's error jumps with Δt, the peak falling between steps: a run that meets it
by luck is not counted). Each run is timed ``--rounds`` times, fixed and adaptive interleaved, and
the fastest kept (these shared machines drift by tens of percent).

Writes benchmarks/results/workprecision_stiff.json, the figure docs/figures/
workprecision_stiff.png, and prints the tables (markdown):

    .venv/bin/python benchmarks/bench_workprecision_stiff.py [--rounds 2] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RODFEM = str(Path(sys.executable).with_name("rodfem"))
RESULTS = ROOT / "benchmarks" / "results" / "workprecision_stiff.json"
FIGURE = ROOT / "docs" / "figures" / "workprecision_stiff.png"
SCHEMES = ("paper", "crank-nicolson")
TARGETS = (1e-2, 1e-3, 1e-4)
REFERENCE, CHECK = 2.5e-6, 5e-6  # fixed Crank–Nicolson steps
AGREE = 1e-5
END = 0.5  # stiff's time.end


def steps(finest: float) -> list[float]:
    """Δt = T/n, n = 500 · 2^(j/2) rounded (a whole number of steps to T), down to ``finest``."""
    sizes = [END / round(500 * 2.0 ** (j / 2)) for j in range(60)]
    return [dt for dt in sizes if dt >= finest * 0.99]


def ladders(quick: bool) -> dict[tuple[str, str], list[float]]:
    """(scheme, fixed|adaptive) → the Δt or tolerances, coarse to fine."""
    tolerances = [10.0 ** (-k / 2) for k in range(4, 17)]  # 1e-2 … 1e-8
    out = {("paper", "fixed"): steps(4.9e-7), ("crank-nicolson", "fixed"): steps(7.8e-6),
           ("paper", "adaptive"): [t for t in tolerances if t <= 1e-3],
           ("crank-nicolson", "adaptive"): tolerances}
    if quick:
        out = {k: v[::3][:4] for k, v in out.items()}
    return out


def overrides(scheme: str, mode: str, size: float) -> list[str]:
    if mode == "fixed":
        return [f"time.scheme={scheme}", f"time.dt={size!r}"]
    return [f"time.scheme={scheme}", "time.adaptive=true", f"time.tolerance={size!r}"]


def run(settings: list[str], out: Path) -> dict:
    """``rodfem run stiff`` as a user runs it: the whole process's seconds, the peak |σ(1)|
    from history.h5, the steps (and rejected ones)."""
    from rodfem.output.readers import read_history

    command = [RODFEM, "run", "stiff", "--out", str(out), "--force", "--quiet",
               *(a for s in settings for a in ("--set", s))]
    # os.environ as Python read it at start: the reference's run started MPI in this process,
    # and Open MPI's start put PMIX_RANK into the C environment a child would inherit, which
    # makes a rodfem process take itself for a launched one (MPI and PETSc started: 0.3 s)
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ))
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        return {"status": f"exit {done.returncode}", "seconds": seconds,
                "message": done.stderr.strip()}
    summary = json.loads((out / "summary.json").read_text())
    sigma = read_history(out / "history.h5")["sigma_1"]
    counts = summary.get("adaptive") or {"steps": summary["steps"], "rejected": 0}
    return {"status": "complete", "seconds": seconds, "peak": float(np.abs(sigma).max()),
            "steps": counts["steps"], "rejected": counts["rejected"]}


def reference() -> float:
    """The converged peak (fixed Crank–Nicolson steps of REFERENCE, checked against CHECK)."""
    import rodfem

    def peak(dt):
        result = rodfem.simulate("stiff", {"time.scheme": "crank-nicolson", "time.dt": dt,
                                           "output.fields": ["u"]})
        return float(np.abs(result.history["sigma_1"]).max())

    fine, coarse = peak(REFERENCE), peak(CHECK)
    if abs(fine - coarse) > AGREE * fine:
        raise SystemExit(f"the reference is not converged: {fine!r} at {REFERENCE}, "
                         f"{coarse!r} at {CHECK}")
    return fine


def reached(points: list[dict], target: float) -> dict | None:
    """The cheapest run of a ladder (coarse to fine) from which every finer run holds
    ``target``."""
    held = [p["status"] == "complete" and p["error"] <= target for p in points]
    for j in range(len(points)):
        if all(held[j:]):
            return min(points[j:], key=lambda p: p["seconds"])
    return None


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


def measure(rounds: int, quick: bool) -> dict:
    plan = ladders(quick)
    peak = reference()
    best: dict[tuple, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):
            # fixed and adaptive interleaved, rung by rung, so that a drift of the machine's
            # speed falls on both
            for j in range(max(map(len, plan.values()))):
                for (scheme, mode), sizes in plan.items():
                    if j >= len(sizes):
                        continue
                    key = (scheme, mode, sizes[j])
                    got = run(overrides(scheme, mode, sizes[j]), Path(tmp) / "run")
                    if key not in best or got["seconds"] < best[key]["seconds"]:
                        best[key] = got
    ladder = {}
    for (scheme, mode), sizes in plan.items():
        points = []
        for size in sizes:
            p = dict(best[(scheme, mode, size)], size=size)
            p["error"] = abs(p["peak"] / peak - 1.0) if p["status"] == "complete" else math.inf
            points.append(p)
        ladder[f"{scheme} {mode}"] = points
    return {"machine": machine(), "load": os.getloadavg()[0], "rounds": rounds,
            "reference": peak, "ladders": ladder,
            "reached": {name: {f"{t:g}": reached(points, t) for t in TARGETS}
                        for name, points in ladder.items()}}


def table(data: dict) -> None:
    print(f"machine: {data['machine']}; load average {data['load']:.1f}; "
          f"reference peak |σ(1)| = {data['reference']:.6f}\n")
    print("| ladder | Δt or tolerance | steps (rejected) | peak error | whole process s |")
    print("|---|---|---|---|---|")
    for name, points in data["ladders"].items():
        for p in points:
            if p["status"] != "complete":
                print(f"| {name} | {p['size']:.3g} | {p['status']} | | {p['seconds']:.2f} |")
                continue
            rejected = f" ({p['rejected']})" if "adaptive" in name else ""
            print(f"| {name} | {p['size']:.3g} | {p['steps']:,}{rejected} | "
                  f"{p['error']:.2e} | {p['seconds']:.2f} |")
    print("\n| ladder | " + " | ".join(f"{100 * t:g} %" for t in TARGETS) + " |")
    print("|---|" + "---|" * len(TARGETS))
    for name, at in data["reached"].items():
        cells = [f"{p['seconds']:.2f} s ({p['size']:.3g}, {p['steps']:,} steps)" if p else "—"
                 for p in at.values()]
        print(f"| {name} | " + " | ".join(cells) + " |")


def figure(data: dict, path: Path) -> None:
    from matplotlib.figure import Figure

    from rodfem.output import figures
    from rodfem.post import style
    from rodfem.post.verify import log_axes, value_range

    points = [p for ps in data["ladders"].values() for p in ps if p["status"] == "complete"]
    x_range = value_range([p["seconds"] for p in points], 1.3)
    y_range = value_range([p["error"] for p in points] + [min(TARGETS) / 2], 2.0)
    with style.mpl_fonts():
        fig = Figure(figsize=(11.0, 7.5), dpi=style.MPL_DPI, layout="constrained")
        ax = fig.subplots()
        for i, (name, ps) in enumerate(data["ladders"].items()):
            ok = [p for p in ps if p["status"] == "complete" and p["error"] > 0]
            scheme, mode = name.split()
            ax.plot([p["seconds"] for p in ok], [p["error"] for p in ok],
                    color=style.colour(SCHEMES.index(scheme)), linewidth=style.MPL_LINE_WIDTH,
                    linestyle="-" if mode == "adaptive" else "--",
                    marker="o" if mode == "adaptive" else "s", markersize=6,
                    markerfacecolor="none" if mode == "fixed" else None,
                    label=f"{scheme}, {mode} steps")
        for t in TARGETS:
            ax.plot(x_range, [t, t], color="black", linewidth=1.0, linestyle=":")
        log_axes(ax, x_range, y_range)
        ax.set_title("stiff (1/ε = 1e4, T = 0.5, 250 cells): error of the peak |σ(1)| "
                     "against wall time")
        ax.set_xlabel(r"whole process of rodfem run [$\mathrm{s}$]")
        ax.set_ylabel("relative error of max |σ(1)|")
        ax.legend(loc="upper right", fontsize=style.MPL_LEGEND_SIZE)
        figures.save(fig, path, dpi=style.MPL_DPI)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--quick", action="store_true",
                        help="four rungs of each ladder, a check of the script")
    parser.add_argument("--json", type=Path, default=RESULTS)
    parser.add_argument("--figure", type=Path, default=FIGURE)
    args = parser.parse_args()
    data = measure(args.rounds, args.quick)
    args.json.write_text(json.dumps(data, indent=1))
    figure(data, args.figure)
    table(data)


if __name__ == "__main__":
    main()
