"""Benchmark: the peak contact stress against a stiff obstacle, fixed steps against adaptive ones.

The built-in scene ``stiff`` (paper1's rod, data and mesh to T = 0.5) over a grid of viscosities ζ
and obstacle stiffnesses 1/ε. Per point, the largest |σ(1, t)| over the run's steps:

* the reference: fixed steps of Crank–Nicolson, Δt halved from 1e-5 until the peak changes by
  less than 0.01 %, and of the paper's scheme from 2e-6 the same way (its value beside it: the
  two schemes converge to the same peak);
* the paper's fixed step Δt = 1e-3, both schemes: their errors;
* the fixed Crank–Nicolson step needed for 1 %: on the ladder of 500 · 2^(j/4) steps, the fewest
  from which every finer rung is within 1 % (its error jumps with Δt, the peak falling between
  steps, so one lucky rung is not enough);
* ``time.adaptive = true`` at the default tolerance, both schemes: the error, steps and rejected
  steps.

    .venv/bin/python benchmarks/bench_adaptive_peak.py [--zeta 0.1 1] [--stiffness 1e3 1e4]

Prints a Markdown table, with the machine it ran on.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from mpi4py import MPI

import rodfem
from rodfem.studies.common import machine

SCENE, END = "stiff", 0.5
CHANGE = 1e-4  # the reference: refined until the peak changes by less than 0.01 %
REQUIRED = 0.01  # the peak within 1 %
LADDER = tuple(round(500 * 2 ** (j / 4)) for j in range(17))  # 500 … 8000 steps


def peak(zeta: float, stiffness: float, **keys) -> tuple[float, int, dict]:
    """The largest |σ(1, t)| of ``stiff`` at (ζ, 1/ε) with ``keys`` set (dots as "__"), its
    steps and the run's summary."""
    overrides = {"model.zeta": zeta, "obstacle.epsilon": 1.0 / stiffness,
                 "output.fields": ["u"], **{k.replace("__", "."): v for k, v in keys.items()}}
    with warnings.catch_warnings():  # the coarse fixed steps are the study's own choice
        warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
        result = rodfem.simulate(SCENE, overrides, comm=MPI.COMM_SELF)
    if result.status != "complete":
        raise RuntimeError(f"{SCENE} {overrides}: {result.status}")
    return float(np.max(np.abs(result.history["sigma_1"]))), len(result.history) - 1, \
        result.summary


def converged(zeta: float, stiffness: float, scheme: str, dt: float) -> tuple[float, float]:
    """The peak with fixed steps of ``scheme`` from ``dt``, halved until it changes by less than
    CHANGE; (the peak, the finest Δt)."""
    last = peak(zeta, stiffness, time__scheme=scheme, time__dt=dt)[0]
    while True:
        dt /= 2.0
        value = peak(zeta, stiffness, time__scheme=scheme, time__dt=dt)[0]
        if abs(value - last) < CHANGE * abs(value):
            return value, dt
        last = value


def fixed_for(zeta: float, stiffness: float, reference: float) -> int | None:
    """The fewest Crank–Nicolson steps on LADDER from which every finer rung is within 1 %."""
    fewest = None
    for steps in reversed(LADDER):
        value = peak(zeta, stiffness, time__scheme="crank-nicolson", time__dt=END / steps)[0]
        if abs(value / reference - 1.0) > REQUIRED:
            break
        fewest = steps
    return fewest


def point(zeta: float, stiffness: float) -> dict:
    started = time.perf_counter()
    reference, finest = converged(zeta, stiffness, "crank-nicolson", 1e-5)
    paper_reference, paper_finest = converged(zeta, stiffness, "paper", 2e-6)
    row = {"zeta": zeta, "stiffness": stiffness, "reference": reference, "finest": finest,
           "paper_reference": paper_reference / reference - 1.0, "paper_finest": paper_finest}
    for scheme in ("paper", "crank-nicolson"):
        row[f"fixed {scheme}"] = peak(zeta, stiffness, time__scheme=scheme)[0] / reference - 1.0
        value, steps, summary = peak(zeta, stiffness, time__scheme=scheme, time__adaptive=True)
        row[f"adaptive {scheme}"] = (value / reference - 1.0, steps,
                                     summary["adaptive"]["rejected"])
    row["cn for 1 %"] = fixed_for(zeta, stiffness, reference)
    row["seconds"] = time.perf_counter() - started
    return row


def _steps(fewest: int | None) -> str:
    """The fewest steps for 1 %, as far as LADDER tells."""
    if fewest is None:
        return f"> {LADDER[-1]}"
    return f"≤ {fewest}" if fewest == LADDER[0] else str(fewest)


def table(rows: list[dict]) -> list[str]:
    lines = ["| ζ | 1/ε | reference peak (CN; paper's scheme) | fixed Δt = 1e-3: paper, CN "
             "| fixed CN steps for 1 % | adaptive paper: error, steps (rejected) "
             "| adaptive CN: error, steps (rejected) |", "|---" * 7 + "|"]
    for r in rows:
        adaptive = [f"{100 * e:+.2f} %, {n} ({k})"
                    for e, n, k in (r["adaptive paper"], r["adaptive crank-nicolson"])]
        cn = r["cn for 1 %"]
        lines.append(
            f"| {r['zeta']:g} | {r['stiffness']:g} | {r['reference']:.5f} "
            f"({100 * r['paper_reference']:+.3f} %) | {100 * r['fixed paper']:+.1f} %, "
            f"{100 * r['fixed crank-nicolson']:+.2f} % | {_steps(cn)} | "
            f"{adaptive[0]} | {adaptive[1]} |")
    return lines


def verdicts(rows: list[dict]) -> list[str]:
    worst = {s: max(abs(r[f"adaptive {s}"][0]) for r in rows)
             for s in ("paper", "crank-nicolson")}
    coarse = [r for r in rows if r["cn for 1 %"] != LADDER[0]]  # where Δt = 1e-3 misses 1 %
    fewer = [r for r in coarse if r["cn for 1 %"] is None
             or r["adaptive crank-nicolson"][1] < r["cn for 1 %"]]
    return [f"adaptive at the default tolerance, worst error of the peak: paper "
            f"{100 * worst['paper']:.2f} %, Crank–Nicolson {100 * worst['crank-nicolson']:.2f} % "
            f"(required: 1 %)",
            f"where fixed Crank–Nicolson needs more than {LADDER[0]} steps for 1 %, the adaptive "
            f"run takes fewer at {len(fewer)} of {len(coarse)} points"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--zeta", type=float, nargs="+", default=[0.1, 0.2, 0.5, 1.0])
    parser.add_argument("--stiffness", type=float, nargs="+", default=[1e3, 3e3, 1e4],
                        help="1/ε of the obstacle")
    args = parser.parse_args()
    rows = []
    for stiffness in args.stiffness:
        for zeta in args.zeta:
            rows.append(point(zeta, stiffness))
            print(f"ζ = {zeta:g}, 1/ε = {stiffness:g}: {rows[-1]['seconds']:.0f} s", flush=True)
    print("\n".join(["", *table(rows), "", *verdicts(rows), ""]))
    m = machine(MPI.COMM_SELF)
    print(f"machine: {m['cpu']} ({m['cpus']} cpus), rodfem {m['rodfem']}, dolfinx {m['dolfinx']}, "
          f"PETSc {m['petsc']}")


if __name__ == "__main__":
    main()
