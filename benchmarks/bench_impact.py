"""Benchmark: the impact benchmark (an elastic bar released against a rigid wall, exact solution
in rodfem.model.impact) for each choice of mass, time scheme and method, at h = Δt, beside the
figures GetFEM 5.4's ``demo_dynamic_contact_1D`` gives on the same problem.

Per choice and h: the L1-in-time error of u(1, ·) (GetFEM's measure), its least-squares order
over the h given, the energy at T = 3 (exact 1/8), the contact stress on [1.2, 1.8] (exact −1/2:
the largest deviation, and the largest change from one step to the next, a flicker), and the time
loop's µs per step. Choices a scene refuses are listed with the reason.

    .venv/bin/python benchmarks/bench_impact.py [--h 1e-2 1e-3 5e-4] [--methods direct newton]

Prints a Markdown table, with the machine it ran on.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.model import impact
from rodfem.studies.common import machine

# GetFEM 5.4, Newmark β = 1/4, γ = 1/2 (the L1 errors at h = 1e-2, 1e-3, 5e-4; energy at T at
# h = 1e-3), measured with GetFEM on this benchmark.
GETFEM = {
    "GetFEM, Newmark, redistributed mass": ((9.3e-3, 1.7e-3, 1.0e-3), 0.1248),
    "GetFEM, Newmark, singular dynamic mass": ((3.7e-3, 1.1e-3, 7.2e-4), None),
}
CHOICES = (("paper", "lumped"), ("paper", "redistributed"), ("crank-nicolson", "lumped"),
           ("crank-nicolson", "consistent"), ("crank-nicolson", "redistributed-lumped"),
           ("crank-nicolson", "redistributed"))


def measure(h: float, scheme: str, mass: str, method: str, overrides=()) -> dict | str:
    try:
        scene = impact.scene(h, overrides=[f"time.scheme={scheme}", f"discretisation.mass={mass}",
                                           f"solver.method={method}", *overrides])
    except rodfem.SceneError as err:
        return str(err)
    result = rodfem.simulate(scene, comm=MPI.COMM_SELF)
    if result.status != "complete":
        return f"{result.status}: {result.summary.get('message', '')}"
    return {**impact.errors(result.history), "energy": float(result.history["energy"][-1]),
            "us_per_step": result.summary["us_per_step"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[1e-2, 1e-3, 5e-4])
    parser.add_argument("--methods", nargs="+", default=["direct"])
    args = parser.parse_args()
    hs = sorted(args.h, reverse=True)
    lines = ["| scheme, mass, method | " + " | ".join(f"L1 h = {h:g}" for h in hs)
             + " | order | energy at T (h = {0:g}) | stress dev, flicker (h = {0:g}) "
               "| µs/step (h = {0:g}) |".format(hs[min(1, len(hs) - 1)]),
             "|---|" + "---|" * (len(hs) + 4)]
    refused = []
    for (scheme, mass), method in itertools.product(CHOICES, args.methods):
        overrides = ["obstacle.kind=elastic", "obstacle.epsilon=1e-6"] \
            if scheme == "crank-nicolson" and not mass.startswith("redistributed") else []
        rows = [measure(h, scheme, mass, method, overrides) for h in hs]
        label = f"{scheme}, {mass}, {method}" + (", ε = 1e-6" if overrides else "")
        if any(isinstance(r, str) for r in rows):
            refused.append(f"- {label}: {next(r for r in rows if isinstance(r, str))}")
            continue
        order = np.polyfit(np.log(hs), np.log([r["u1_l1"] for r in rows]), 1)[0] \
            if len(hs) > 1 else float("nan")
        mid = rows[min(1, len(rows) - 1)]
        lines.append(f"| {label} | " + " | ".join(f"{r['u1_l1']:.2e}" for r in rows)
                     + f" | {order:.2f} | {mid['energy']:.6f} | {mid['stress']:.1e}, "
                       f"{mid['flicker']:.1e} | {mid['us_per_step']:.1f} |")
    for label, (errors, energy) in GETFEM.items():
        if hs == [1e-2, 1e-3, 5e-4]:
            order = np.polyfit(np.log(hs), np.log(errors), 1)[0]
            lines.append(f"| {label} | " + " | ".join(f"{e:.1e}" for e in errors)
                         + f" | {order:.2f} | {energy or '–'} | – | – |")
    print("\n".join(lines))
    if refused:
        print("\nRefused:\n" + "\n".join(refused))
    m = machine(MPI.COMM_SELF)
    print(f"\n{m['cpu']}, {m['cpus']} cores; dolfinx {m['dolfinx']}, PETSc {m['petsc']}, "
          f"NumPy {m['numpy']}, rodfem {m['rodfem']}")


if __name__ == "__main__":
    main()
