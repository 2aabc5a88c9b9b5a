"""Benchmark: the impact benchmark (an elastic bar released against a rigid wall, exact solution
in rodfem.model.impact) for each choice of mass, time scheme and method, at h = Δt (or Δt = h/2
with ``--ratio 0.5``), beside the figures GetFEM 5.4's ``demo_dynamic_contact_1D`` gives on the
same problem (its singular dynamic mass measured with benchmarks/getfem_impact.py).

Per choice and h: the L1-in-time error of u(1, ·) (GetFEM's measure), its least-squares order
over the h given, the energy at T = 3 (exact 1/8), the contact stress on [1.2, 1.8] (exact −1/2:
the largest deviation, and the largest change from one step to the next, a flicker), and the time
loop's µs per step. Choices a scene refuses are listed with the reason.

    .venv/bin/python benchmarks/bench_impact.py [--h 1e-2 1e-3 5e-4] [--methods direct newton]
        [--ratio 0.5] [--masses dispersion-free redistributed]

Prints a Markdown table, with the machine it ran on.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.model import impact
from rodfem.scene.schema import REDISTRIBUTED
from rodfem.studies.common import machine

# GetFEM 5.4, Newmark β = 1/4, γ = 1/2, measured on this benchmark: for each Δt/h, the L1
# errors by h (the redistributed mass with GetFEM's demo, by the trapezoidal rule in time; the
# singular dynamic mass with benchmarks/getfem_impact.py, as rodfem measures them, Σ Δt |e|)
# and the energy at T at the second h.
GETFEM = {
    ("GetFEM, Newmark, redistributed mass", 1.0): (
        {1e-2: 9.3e-3, 2e-3: 2.8e-3, 1e-3: 1.7e-3, 5e-4: 1.0e-3}, 0.1248),
    ("GetFEM, Newmark, singular dynamic mass", 1.0): (
        {1e-2: 3.78e-3, 2e-3: 1.58e-3, 1e-3: 1.07e-3, 5e-4: 7.15e-4}, None),
    ("GetFEM, Newmark, singular dynamic mass", 0.5): (
        {1e-2: 3.60e-3, 2e-3: 1.09e-3, 1e-3: 7.67e-4, 5e-4: 5.25e-4}, None),
}
CHOICES = (("paper", "lumped"), ("paper", "redistributed"), ("crank-nicolson", "lumped"),
           ("crank-nicolson", "consistent"), ("crank-nicolson", "redistributed-lumped"),
           ("crank-nicolson", "redistributed"), ("crank-nicolson", "dispersion-free"))


def measure(h: float, scheme: str, mass: str, method: str, overrides=(),
            ratio: float = 1.0) -> dict | str:
    """One run at h and Δt = ratio·h: its errors, energy at T and µs per step, or why the scene
    refuses it."""
    cells = round(1.0 / h)
    try:
        scene = impact.scene(h, overrides=[f"time.scheme={scheme}", f"discretisation.mass={mass}",
                                           f"solver.method={method}",
                                           f"time.dt={ratio / cells!r}", *overrides])
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
    parser.add_argument("--ratio", type=float, default=1.0, help="Δt/h")
    parser.add_argument("--masses", nargs="+", default=None,
                        help="only these masses (default: every one)")
    args = parser.parse_args()
    hs = sorted(args.h, reverse=True)
    print(f"Δt = {args.ratio:g} h\n")
    lines = ["| scheme, mass, method | " + " | ".join(f"L1 h = {h:g}" for h in hs)
             + " | order | energy at T (h = {0:g}) | stress dev, flicker (h = {0:g}) "
               "| µs/step (h = {0:g}) |".format(hs[min(1, len(hs) - 1)]),
             "|---|" + "---|" * (len(hs) + 4)]
    refused = []
    choices = [c for c in CHOICES if args.masses is None or c[1] in args.masses]
    for (scheme, mass), method in itertools.product(choices, args.methods):
        overrides = ["obstacle.kind=elastic", "obstacle.epsilon=1e-6"] \
            if scheme == "crank-nicolson" and mass not in REDISTRIBUTED else []
        rows = [measure(h, scheme, mass, method, overrides, args.ratio) for h in hs]
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
    for (label, ratio), (errors, energy) in GETFEM.items():
        if ratio == args.ratio and set(hs) <= set(errors):
            order = np.polyfit(np.log(hs), np.log([errors[h] for h in hs]), 1)[0] \
                if len(hs) > 1 else float("nan")
            lines.append(f"| {label} | " + " | ".join(f"{errors[h]:.2e}" for h in hs)
                         + f" | {order:.2f} | {energy or '–'} | – | – |")
    print("\n".join(lines))
    if refused:
        print("\nRefused:\n" + "\n".join(refused))
    m = machine(MPI.COMM_SELF)
    print(f"\n{m['cpu']}, {m['cpus']} cores; dolfinx {m['dolfinx']}, PETSc {m['petsc']}, "
          f"NumPy {m['numpy']}, rodfem {m['rodfem']}")


if __name__ == "__main__":
    main()
