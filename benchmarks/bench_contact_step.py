"""Benchmark: how far off the peak contact stress of a fixed-step run is, against the number of
steps per contact time scale √(b ε) (b the density, ε the obstacle's compliance), the figure
behind the warning on coarse fixed-step runs (rodfem.model.timescales, docs/time-schemes.md).

The scene is the paper's experiment 1 (``paper1``, 250 cells, the direct method) with a stiffer
obstacle, run to t = 1.5 (its first contact). Per scheme, compliance ε, viscosity ζ, density b,
cells and Δt: the peak max_t |σ(1, t)| against the same scene's Crank–Nicolson run at
Δt = 2e-5 (second order: well below 0.01 % off there), its relative error, and the steps per
time scale S = √(b ε)/Δt, beside the steps per node scale √(b h ε)/Δt. Where the error follows S
alone (the same S, the same error, whatever ε, b or h), √(b ε) is the scale that governs it.

    .venv/bin/python benchmarks/bench_contact_step.py [--quick]

Prints a Markdown table, with the machine it ran on, and writes results/contact_step.json.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from mpi4py import MPI

import rodfem
from rodfem.studies.common import machine

REFERENCE_DT = 2e-5
END = 1.5


def peak(scheme: str, epsilon: float, zeta: float, b: float, cells: int, dt: float) -> float:
    result = rodfem.simulate("paper1", {
        "time.scheme": scheme, "time.dt": dt, "time.end": END, "obstacle.epsilon": epsilon,
        "model.zeta": zeta, "model.b": b, "mesh.cells": cells, "solver.method": "direct",
        "output.fields": ["u"], "output.every": 10 ** 6}, comm=MPI.COMM_SELF)
    assert result.status == "complete", result.summary.get("error")
    return float(abs(result.history["sigma_1"]).max())


def cases(quick: bool) -> list[tuple]:
    """(ε, ζ, b, cells, [Δt]) of each column of the study."""
    dts = [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4] if not quick else [2e-3, 1e-3]
    grid = [(eps, zeta, 1.0, 250, dts) for eps in (1e-2, 1e-3, 1e-4) for zeta in (1.0, 0.1)]
    # the density and the mesh: b = 4 (τ doubles), h four times smaller (the node's scale
    # halves, τ does not)
    grid += [(1e-3, 0.1, 4.0, 250, dts), (1e-4, 0.1, 1.0, 1000, dts)]
    return grid[:2] if quick else grid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="two cases, two steps")
    args = parser.parse_args()
    rows = []
    for eps, zeta, b, cells, dts in cases(args.quick):
        reference = peak("crank-nicolson", eps, zeta, b, cells, REFERENCE_DT)
        for scheme in ("paper", "crank-nicolson"):
            for dt in dts:
                value = peak(scheme, eps, zeta, b, cells, dt)
                rows.append({"scheme": scheme, "epsilon": eps, "zeta": zeta, "b": b,
                             "cells": cells, "dt": dt, "peak": value, "reference": reference,
                             "error": value / reference - 1.0,
                             "steps_per_scale": math.sqrt(b * eps) / dt,
                             "steps_per_node_scale": math.sqrt(b * eps / cells) / dt})
                print(f"{scheme:15s} eps={eps:g} zeta={zeta:g} b={b:g} cells={cells} dt={dt:g}: "
                      f"S={rows[-1]['steps_per_scale']:.3g} error {100 * rows[-1]['error']:+.2f} %",
                      flush=True)
    where = machine(MPI.COMM_SELF)
    print(f"\nMachine: {where['cpu']}, {where['cpus']} CPUs; rodfem {where['rodfem']}\n")
    print("| scheme | ε | ζ | b | cells | Δt | S = √(bε)/Δt | √(bhε)/Δt | peak |σ(1)| | reference "
          "| error |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["scheme"], r["steps_per_scale"])):
        print(f"| {r['scheme']} | {r['epsilon']:g} | {r['zeta']:g} | {r['b']:g} | {r['cells']} "
              f"| {r['dt']:g} | {r['steps_per_scale']:.3g} | {r['steps_per_node_scale']:.3g} "
              f"| {r['peak']:.5g} | {r['reference']:.5g} | {100 * r['error']:+.2f} % |")
    if not args.quick:
        out = Path(__file__).parent / "results" / "contact_step.json"
        out.write_text(json.dumps({"machine": where, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
