"""What ``rodfem verify`` reports: orders.md and the lines it prints.

A scene has ladders in h and in Δt against a finer reference run, or (the impact) one ladder
refining both together, h = Δt, against its exact solution: each kind of ladder gets its own
columns and tables, headed by the step it refines, so that an order in h = Δt is never read as
one in h or in Δt alone.
"""

from __future__ import annotations

import math
from pathlib import Path

from rodfem.studies import asymptotic
from rodfem.studies.verification import convergence as cv

DIRECTIONS = ("h", "dt", "h=dt", "tol")
# How a direction is written: in the tables, and padded in the printed lines.
HEADINGS = {"h": "h", "dt": "Δt", "h=dt": "h = Δt", "tol": "tolerance"}
SHORT = {"h": "h", "dt": "Δt", "h=dt": "h=Δt", "tol": "tol"}


def _g(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}g}" if isinstance(value, float) and math.isfinite(value) else "—"


LABELS = {"u1_max": "u(1,·) max", "u1_l1": "u(1,·) L¹(0,T)", "u1_l2": "u(1,·) L²(0,T)",
          "u_T": "u(·,T) L²", "theta_T": "θ(·,T) L²"}


def _exact(data: dict) -> list[str]:
    """The scenes measured against an exact solution (older files: the manufactured one)."""
    return data.get("exact", ["manufactured"] if data.get("manufactured") else [])


def _plan_lines(data: dict) -> list[str]:
    plan, lines = data["plan"], []
    built_in = [k for k in data.get("scenes", {"paper1": None}) if k not in data.get("user", [])]
    if any(k not in _exact(data) for k in built_in):
        lines += [f"T = {plan['end']:g}. h ladder: cells {', '.join(map(str, plan['h_cells']))} "
                  f"at Δt = {plan['h_dt']:g}, against {plan['h_reference']} cells at the same Δt. "
                  f"Δt ladder: Δt = T/{', T/'.join(map(str, plan['dt_steps']))} on "
                  f"{plan['dt_cells']} cells, against Δt = T/{plan['dt_reference']} on the same "
                  "cells. References: direct method, the ladder's time scheme. Orders: "
                  "least-squares slopes of log error against log h or log Δt, over the runs that "
                  "completed.", ""]
    if data["manufactured"]:
        lines += [f"Manufactured solution (against its exact solution, T = {plan['mms_end']:g}): "
                  f"h ladder cells {', '.join(map(str, plan['mms_h_cells']))} at Δt = "
                  f"{plan['mms_h_dt']:g}; Δt ladder Δt = T/"
                  f"{', T/'.join(map(str, plan['mms_dt_steps']))} on {plan['mms_dt_cells']} "
                  "cells.", ""]
    if data.get("impact"):
        lines += [f"Impact (against its exact solution, T = {plan['impact_end']:g}, the scene's "
                  "redistributed mass): one ladder refining h and Δt together, h = Δt = "
                  f"{', '.join(f'{h:g}' for h in plan['impact_h'])}; its orders are slopes "
                  "against log h = log Δt. u(1,·) L¹(0,T) is GetFEM's measure of this benchmark; "
                  "u(1,·) max leaves out t = 0.", ""]
    for key in data.get("user", []):
        lines += [_user_plan(key, data["scenes"][key]), ""]
    return lines


def _user_plan(key: str, s: dict) -> str:
    """How a scene file's ladders were made."""
    rungs = [2 ** k for k in range(s["rungs"])]
    if s["adaptive"]:
        tolerances = ", ".join(f"{s['tolerance'] / k:g}" for k in rungs)
        second = (f"tolerance ladder: {tolerances} on "
                  f"{s['cells']} cells, against {s['tolerance'] / rungs[-1] / s['dt_reference']:g}")
        fixed = (f"the tolerance {s['h_tolerance']:g} (the tolerance ladder's finest, whose "
                 "time error that ladder measures)")
    else:
        steps = ", ".join(f"{s['dt'] / k:g}" for k in rungs)
        second = (f"Δt ladder: Δt = {steps} on "
                  f"{s['cells']} cells, against Δt = {s['dt'] / rungs[-1] / s['dt_reference']:g}")
        fixed = f"Δt = {s['dt']:g}"
    source = s["scene"] if "member" not in s else \
        f"scene {s['member']} of the sweep {s['scene']}: {s['values']}"
    return (f"{key} ({source}{''.join(f' --set {o}' for o in s['overrides'])}; T = "
            f"{s['end']:g}, {s['method']}, {s['scheme']}): h ladder: cells "
            f"{', '.join(str(s['cells'] * k) for k in rungs)} at {fixed}, against "
            f"{s['cells'] * rungs[-1] * s['h_reference']} cells; {second}. References: the "
            "scene's own method and scheme. Measures: the order p = log2(|m₁ − m₀| / |m₂ − m₁|) "
            "of the last three runs and, where p is within ±"
            f"{asymptotic.BAND:g} of the expected order q, the Richardson estimate "
            "(m₂ − m₁)/(2^q − 1) of m_∞ − m₂.")


def _told(r: dict) -> str:
    """A measure's order as the tables give it: the order, or why there is none, or the order
    and why it is not trusted."""
    if r["note"] == asymptotic.STEPPED:
        return f"— ({r['note']})"
    if not math.isfinite(r["order"]):
        return f"no order ({r['note']})"
    return _g(r["order"]) + (f" ({r['note']})" if r["note"] else "")


def _measure_lines(data: dict, scene: str) -> list[str]:
    """A scene file's measures: each ladder's finest value, order and Richardson estimate."""
    rows = [r for r in data.get("measure_orders", []) if r["scene"] == scene]
    if not rows:
        return []
    lines = ["", "Measures (finest run, order from the last three against the expected one, "
             "Richardson estimate with the expected order):", "",
             "| ladder | measure | finest | expected | order | m_∞ − finest |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        finest = r["finest"] if isinstance(r["finest"], int) else _g(r["finest"], 6)
        lines.append(f"| {HEADINGS[r['refined']]} | {r['measure']} | {finest} | "
                     f"{_g(r.get('expected', math.nan))} | {_told(r)} | "
                     f"{_g(r['richardson'])} |")
    return lines


def _rate(row: dict, m: str) -> str:
    """An error's order in the orders table, with its check."""
    check = row.get(f"check_{m}", "")
    return _g(row[f"rate_{m}"], 3) + (f" ({check})" if check else "")


def _checks(rows: list[dict]) -> list[str]:
    """What the checks in an orders table mean, where it has any."""
    told = {row.get(f"check_{m}", "") for row in rows for m in cv.MEASURES}
    lines = []
    if "pre-asymptotic" in told:
        lines.append(f"- pre-asymptotic: more than {asymptotic.BAND:g} from the expected order "
                     "(h: 2; Δt: the scheme's; a tolerance: q/(q + 1) for a scheme of order q): "
                     "refine further before trusting it.")
    if "time error" in told:
        lines.append(f"- time error: the adaptive steps' time error at the h ladder's tolerance "
                     f"is more than {asymptotic.POLLUTION:g} of its finest rung's error: the "
                     "order in h may be the time error's; tighten time.tolerance.")
    if any(r["refined"] == "h=dt" for r in rows):
        lines.append("- h = Δt: the solution has kinks; no order is expected of it, and none "
                     "is checked.")
    return ["", *lines] if lines else []


def markdown(data: dict) -> str:
    """orders.md: per scene, the observed orders of each (method, scheme) in each of its
    ladders' directions, then each ladder's errors."""
    lines = ["# Observed orders of convergence (`rodfem verify`)", "", *_plan_lines(data)]
    exact = _exact(data)
    for scene in dict.fromkeys(r["scene"] for r in data["orders"]):
        rows = [r for r in data["orders"] if r["scene"] == scene]
        present = [d for d in DIRECTIONS if any(r["refined"] == d for r in rows)]
        against = " (against the exact solution)" if scene in exact else ""
        header = "| method | scheme | " + " | ".join(
            f"{HEADINGS[d]}: {LABELS[m]}" for d in present for m in cv.MEASURES) \
            + " | runs completed |"
        directions = " and in ".join(HEADINGS[d] for d in present)
        lines += [f"## {scene}", "", f"Observed orders in {directions}{against}:", "", header,
                  "|---|---|" + "---|" * (len(present) * len(cv.MEASURES) + 1)]
        for method, scheme in dict.fromkeys((r["method"], r["scheme"]) for r in rows):
            by = {r["refined"]: r for r in rows if (r["method"], r["scheme"]) == (method, scheme)}
            cells = [_rate(by[d], m) if d in by else "" for d in present
                     for m in cv.MEASURES]
            runs = ", ".join(f"{by[d]['points']} ({HEADINGS[d]})" for d in present if d in by)
            lines.append(f"| {method} | {scheme} | " + " | ".join(cells) + f" | {runs} |")
        lines += _checks(rows)
        for refined in present:
            points = [r for r in data["points"] if r["scene"] == scene and r["refined"] == refined]
            if not points:
                continue
            lines += ["", f"Errors, {HEADINGS[refined]} ladder{against}:", "",
                      f"| method | scheme | cells | {'tolerance' if refined == 'tol' else 'Δt'} "
                      "| status | "
                      + " | ".join(LABELS[m] for m in cv.MEASURES) + " | seconds |",
                      "|---|---|---|---|---|" + "---|" * (len(cv.MEASURES) + 1)]
            for r in points:
                size = r["tolerance"] if refined == "tol" else r["dt"]
                lines.append(f"| {r['method']} | {r['scheme']} | {r['cells']} | {size:.4g} | "
                             f"{r['status']} | " + " | ".join(_g(r[m]) for m in cv.MEASURES)
                             + f" | {r['seconds']:.3f} |")
            failed = [r for r in points if r["status"] != "complete"]
            if failed:
                lines.append("")
            lines += [f"- {r['method']}, {r['scheme']}, {r['cells']} cells, Δt = {r['dt']:.4g}: "
                      f"{r['status']}: {r['message']}" for r in failed]
        lines += [*_measure_lines(data, scene), ""]
    if data["rejected"]:
        lines += ["Choices the scene rejects:", ""]
        lines += [f"- {r['scene']}: {r['method']}, {r['scheme']}: {r['message']}"
                  for r in data["rejected"]]
        lines.append("")
    spread = data["method_spread"]
    if all(r["scene"] in data.get("user", []) for r in data["orders"]):
        return "\n".join(lines)  # one method a scene file: no spread to tell
    lines += ["Largest relative difference of a method's error from the direct method's at the "
              "same point: " + ", ".join(f"{LABELS[m]} {spread[m]:.2g}" for m in cv.MEASURES)
              + ".", ""]
    return "\n".join(lines)


def summary_lines(data: dict, out: Path) -> list[str]:
    """What ``rodfem verify`` prints: the observed orders of each measure, per scene, ladder and
    choice (those against an exact solution marked so)."""
    lines = [f"verify: {len(data['points'])} runs in {data['seconds']:.0f} s -> {out}"]
    exact = _exact(data)
    width = max([12, *(len(r["scene"]) for r in data["orders"])])
    for r in data["orders"]:
        rates = ", ".join(f"{m} {_rate(r, m)}" for m in cv.MEASURES
                          if math.isfinite(r[f"rate_{m}"]))
        against = " (exact solution)" if r["scene"] in exact else ""
        lines.append(f"{r['scene']:<{width}} {SHORT[r['refined']]:<4} {r['method']:<6} "
                     f"{r['scheme']:<14} orders{against}: {rates}")
    ladders = dict.fromkeys((r["scene"], r["refined"]) for r in data.get("measure_orders", []))
    for scene, refined in ladders:
        rows = [r for r in data["measure_orders"] if (r["scene"], r["refined"]) == (scene, refined)]
        told = "; ".join(f"{r['measure']} {_g(r['order'])} (m_∞ − finest {_g(r['richardson'], 2)})"
                         if r["note"] == "" else f"{r['measure']} {_told(r)}" for r in rows)
        lines.append(f"{scene:<{width}} {SHORT[refined]:<4} measures: {told}")
    return lines
