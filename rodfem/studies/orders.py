"""What ``rodfem verify`` reports: orders.md and the lines it prints."""

from __future__ import annotations

import math
from pathlib import Path

from rodfem.studies import convergence as cv

DIRECTIONS = ("h", "dt")


def _g(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}g}" if isinstance(value, float) and math.isfinite(value) else "—"


LABELS = {"u1_max": "u(1,·) max", "u1_l2": "u(1,·) L²(0,T)", "u_T": "u(·,T) L²",
          "theta_T": "θ(·,T) L²"}


def markdown(data: dict) -> str:
    """orders.md: per scene, the observed orders of each (method, scheme) in h and Δt, then each
    ladder's errors."""
    plan = data["plan"]
    lines = ["# Observed orders of convergence (`rodfem verify`)", "",
             f"T = {plan['end']:g}. h ladder: cells {', '.join(map(str, plan['h_cells']))} at "
             f"Δt = {plan['h_dt']:g}, against {plan['h_reference']} cells at the same Δt. Δt "
             f"ladder: Δt = T/{', T/'.join(map(str, plan['dt_steps']))} on {plan['dt_cells']} "
             f"cells, against Δt = T/{plan['dt_reference']} on the same cells. References: "
             "direct method, the ladder's time scheme. Orders: least-squares slopes of log "
             "error against log h or log Δt, over the runs that completed.", ""]
    if data["manufactured"]:
        lines += [f"Manufactured solution (against its exact solution, T = {plan['mms_end']:g}): "
                  f"h ladder cells {', '.join(map(str, plan['mms_h_cells']))} at Δt = "
                  f"{plan['mms_h_dt']:g}; Δt ladder Δt = T/"
                  f"{', T/'.join(map(str, plan['mms_dt_steps']))} on {plan['mms_dt_cells']} "
                  "cells.", ""]
    header = "| method | scheme | " + " | ".join(f"h: {LABELS[m]}" for m in cv.MEASURES) \
        + " | " + " | ".join(f"Δt: {LABELS[m]}" for m in cv.MEASURES) + " | runs completed |"
    for scene in dict.fromkeys(r["scene"] for r in data["orders"]):
        lines += [f"## {scene}", "", "Observed orders:", "", header,
                  "|---|---|" + "---|" * (2 * len(cv.MEASURES) + 1)]
        rows = [r for r in data["orders"] if r["scene"] == scene]
        for method, scheme in dict.fromkeys((r["method"], r["scheme"]) for r in rows):
            by = {r["refined"]: r for r in rows if (r["method"], r["scheme"]) == (method, scheme)}
            cells = [_g(by[d][f"rate_{m}"], 3) if d in by else "" for d in DIRECTIONS
                     for m in cv.MEASURES]
            runs = ", ".join(f"{by[d]['points']} ({'h' if d == 'h' else 'Δt'})" for d in DIRECTIONS
                             if d in by)
            lines.append(f"| {method} | {scheme} | " + " | ".join(cells) + f" | {runs} |")
        for refined in DIRECTIONS:
            points = [r for r in data["points"] if r["scene"] == scene and r["refined"] == refined]
            if not points:
                continue
            lines += ["", f"Errors, {'h' if refined == 'h' else 'Δt'} ladder:", "",
                      "| method | scheme | cells | Δt | status | "
                      + " | ".join(LABELS[m] for m in cv.MEASURES) + " | seconds |",
                      "|---|---|---|---|---|" + "---|" * (len(cv.MEASURES) + 1)]
            for r in points:
                lines.append(f"| {r['method']} | {r['scheme']} | {r['cells']} | {r['dt']:.4g} | "
                             f"{r['status']} | " + " | ".join(_g(r[m]) for m in cv.MEASURES)
                             + f" | {r['seconds']:.3f} |")
            failed = [r for r in points if r["status"] != "complete"]
            if failed:
                lines.append("")
            lines += [f"- {r['method']}, {r['scheme']}, {r['cells']} cells, Δt = {r['dt']:.4g}: "
                      f"{r['status']}: {r['message']}" for r in failed]
        lines.append("")
    if data["rejected"]:
        lines += ["Choices the scene rejects:", ""]
        lines += [f"- {r['method']}, {r['scheme']}: {r['message']}" for r in data["rejected"]]
        lines.append("")
    spread = data["method_spread"]
    lines += ["Largest relative difference of a method's error from the direct method's at the "
              "same point: " + ", ".join(f"{LABELS[m]} {spread[m]:.2g}" for m in cv.MEASURES)
              + ".", ""]
    return "\n".join(lines)


def summary_lines(data: dict, out: Path) -> list[str]:
    """What ``rodfem verify`` prints: the observed orders of u(1, ·) max, per scene and choice."""
    lines = [f"verify: {len(data['points'])} runs in {data['seconds']:.0f} s -> {out}"]
    for r in data["orders"]:
        rates = ", ".join(f"{m} {_g(r[f'rate_{m}'], 3)}" for m in cv.MEASURES
                          if math.isfinite(r[f"rate_{m}"]))
        lines.append(f"{r['scene']:<12} {'h ' if r['refined'] == 'h' else 'Δt'} "
                     f"{r['method']:<6} {r['scheme']:<14} orders: {rates}")
    return lines
