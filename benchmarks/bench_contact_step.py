"""Benchmark: the steps per contact time √(b ε) a fixed step needs (b the density, ε the obstacle's
compliance) so that the step the coarse-step warning offers holds the peak contact stress within
what the warning says (rodfem.model.timescales.STEPS_NEEDED, docs/time-schemes.md).

The scene is the built-in ``stiff`` (the paper's first experiment against a stiffer obstacle, 250
cells, the direct method, to T = 0.5), on the grid ζ ∈ {0.1, 0.2, 0.5, 1} × ε ∈ {1e-2, 1e-3,
1e-4}. At each point the reference peak max_t |σ(1, t)| is Crank–Nicolson with adaptive steps at
``time.tolerance`` = 1e-7 on the same 250 cells (a statement about the time step alone), checked
against 1e-8. For each scheme and each candidate N steps per √(b ε), the step offered is
``timescales.fix_dt`` (√(b ε)/N rounded down the 1, 2, 5 × 10ᵏ ladder to divide T), and the peak
of a fixed-step run at that step is compared with the reference. The rounding gives S = √(b ε)/Δt
≥ N, and S = N exactly where √(b ε)/N falls on the ladder (another ε): each candidate is also run
at Δt = √(b ε)/N itself (T raised to the next whole step), the worst the offered step can be. A
scheme needs the smallest candidate from which on (it and every larger candidate) both are within
its bound at every grid point.

    .venv/bin/python benchmarks/bench_contact_step.py [--quick]

Prints Markdown tables, with the machine it ran on, and writes results/contact_step.json.
"""

from __future__ import annotations

import argparse
import json
import math
import warnings
from pathlib import Path

from mpi4py import MPI

import rodfem
import rodfem.scene
from rodfem.model.timescales import coarse_step, fix_dt
from rodfem.studies.common import machine

SCENE = "stiff"
END = 0.5  # its time.end
ZETAS = (0.1, 0.2, 0.5, 1.0)
EPSILONS = (1e-2, 1e-3, 1e-4)
TOLERANCES = (1e-7, 1e-8)  # the reference, and its check
CANDIDATES = (20, 25, 30, 40, 50, 60, 70, 80, 100, 120, 150, 200)
BOUNDS = {"paper": 0.05, "crank-nicolson": 0.015}  # what the warning says of its fix


def settings(epsilon: float, zeta: float) -> dict:
    return {"obstacle.epsilon": epsilon, "model.zeta": zeta}


def load(overrides: dict):
    """``stiff`` with ``overrides``, as a scene."""
    return rodfem.scene.load(SCENE, [f"{key}={value}" for key, value in overrides.items()])


def peak(overrides: dict) -> tuple[float, int]:
    """max_t |σ(1, t)| of ``stiff`` with ``overrides``, and its step count."""
    result = rodfem.simulate(SCENE, {**overrides, "output.fields": ["u"],
                                     "output.every": 10 ** 6}, comm=MPI.COMM_SELF)
    assert result.status == "complete", result.summary.get("error")
    return float(abs(result.history["sigma_1"]).max()), int(result.summary["steps"])


def reference(epsilon: float, zeta: float) -> dict:
    values = [peak({**settings(epsilon, zeta), "time.scheme": "crank-nicolson",
                    "time.adaptive": True, "time.tolerance": tol}) for tol in TOLERANCES]
    return {"epsilon": epsilon, "zeta": zeta, "reference": values[0][0],
            "reference_steps": values[0][1], "check": values[1][0],
            "check_difference": values[0][0] / values[1][0] - 1.0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the worst grid point alone")
    args = parser.parse_args()
    warnings.simplefilter("ignore", rodfem.CoarseStepWarning)  # the runs are coarse on purpose
    grid = [(eps, zeta) for zeta in ZETAS for eps in EPSILONS]
    if args.quick:
        grid = [(1e-4, 0.1)]
    references = {(eps, zeta): reference(eps, zeta) for eps, zeta in grid}
    for r in references.values():
        print(f"reference eps={r['epsilon']:g} zeta={r['zeta']:g}: {r['reference']:.7g} "
              f"({r['check_difference']:+.1e} against tolerance {TOLERANCES[1]:g})", flush=True)
    peaks: dict[tuple, tuple[float, int]] = {}
    rows = []
    for scheme, bound in BOUNDS.items():
        for needed in CANDIDATES:
            for eps, zeta in grid:
                scene = load({**settings(eps, zeta), "time.scheme": scheme})
                dt = fix_dt(scene, needed)
                if (scheme, eps, zeta, dt) not in peaks:
                    peaks[scheme, eps, zeta, dt] = peak({**settings(eps, zeta),
                                                         "time.scheme": scheme, "time.dt": dt})
                value, steps = peaks[scheme, eps, zeta, dt]
                ref = references[eps, zeta]["reference"]
                fixed = load({**settings(eps, zeta), "time.scheme": scheme, "time.dt": dt})
                exact = math.sqrt(eps) / needed  # b = 1
                at_n, _ = peak({**settings(eps, zeta), "time.scheme": scheme, "time.dt": exact,
                                "time.end": exact * math.ceil(END / exact - 1e-9)})
                rows.append({"scheme": scheme, "needed": needed, "epsilon": eps, "zeta": zeta,
                             "dt": dt, "steps_per_scale": math.sqrt(eps) / dt, "steps": steps,
                             "peak": value, "reference": ref, "error": value / ref - 1.0,
                             "error_at_n": at_n / ref - 1.0,
                             "warns_again": coarse_step(fixed, needed) is not None})
    chosen = {}
    for scheme, bound in BOUNDS.items():
        worst = {n: max(max(abs(r["error"]), abs(r["error_at_n"])) for r in rows
                        if r["scheme"] == scheme and r["needed"] == n) for n in CANDIDATES}
        meets = [n for n in CANDIDATES if all(worst[m] <= bound for m in CANDIDATES if m >= n)]
        chosen[scheme] = meets[0] if meets else None
        per_zeta = {}
        for zeta in sorted({z for _, z in grid}):
            ok = [n for n in CANDIDATES if all(
                max(abs(r["error"]), abs(r["error_at_n"])) <= bound for r in rows
                if r["scheme"] == scheme
                and r["zeta"] == zeta and r["needed"] >= n)]
            per_zeta[zeta] = ok[0] if ok else None
        print(f"\n{scheme}: worst |error| at the offered step per N: "
              + ", ".join(f"{n}: {100 * w:.2f} %" for n, w in worst.items())
              + f"; needs N = {chosen[scheme]} (per ζ: {per_zeta}); the offered step warns "
              f"again: {any(r['warns_again'] for r in rows if r['scheme'] == scheme)}")
    where = machine(MPI.COMM_SELF)
    print(f"\nMachine: {where['cpu']}, {where['cpus']} CPUs; rodfem {where['rodfem']}\n")
    print("| ε | ζ | reference peak |σ(1)| | its check | "
          + " | ".join(f"{s}: N = {chosen[s]}, Δt, S, error" for s in BOUNDS) + " |")
    print("|---|---|---|---|" + "---|" * len(BOUNDS))
    for (eps, zeta), ref in references.items():
        cells = []
        for scheme in BOUNDS:
            r = next((r for r in rows if r["scheme"] == scheme and r["needed"] == chosen[scheme]
                      and r["epsilon"] == eps and r["zeta"] == zeta), None)
            cells.append("—" if r is None else f"{r['dt']:g}, {r['steps_per_scale']:.3g}, "
                         f"{100 * r['error']:+.2f} % (S = N: {100 * r['error_at_n']:+.2f} %)")
        print(f"| {eps:g} | {zeta:g} | {ref['reference']:.6g} | {ref['check_difference']:+.0e} | "
              + " | ".join(cells) + " |")
    print("\n| N | " + " | ".join(f"{s}: worst error at the offered step / at S = N"
                                  for s in BOUNDS) + " |")
    print("|---|" + "---|" * len(BOUNDS))
    for n in CANDIDATES:
        cells = []
        for scheme in BOUNDS:
            mine = [r for r in rows if r["scheme"] == scheme and r["needed"] == n]
            cells.append(" / ".join(
                f"{100 * w[key]:+.2f} % (ε = {w['epsilon']:g}, ζ = {w['zeta']:g})"
                for key in ("error", "error_at_n")
                for w in [max(mine, key=lambda r: abs(r[key]))]))
        print(f"| {n} | " + " | ".join(cells) + " |")
    if not args.quick:
        out = Path(__file__).parent / "results" / "contact_step.json"
        out.write_text(json.dumps({"machine": where, "scene": SCENE, "bounds": BOUNDS,
                                   "tolerances": TOLERANCES, "chosen": chosen,
                                   "references": list(references.values()), "rows": rows},
                                  indent=1) + "\n")


if __name__ == "__main__":
    main()
