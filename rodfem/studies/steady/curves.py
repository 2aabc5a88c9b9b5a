"""``rodfem steady --continue KEY=a:b --follow fold|grazing|hopf --along KEY2=c:d[:n]``: the located
points of one kind traced over a second scene value, curves in the (KEY, KEY2) plane that bound
the regions of bistability (folds, grazing points where the branch turns) and of oscillation
(Hopf points).

At each of n values of KEY2 (41 by default) the branches over [a, b] are followed again
(:mod:`.continuation`: milliseconds). Folds and grazing points are located on them as in a
diagram, to the doubles' resolution, and joined across values in order along the branches; a
curve ends where its points do (two folds meeting at a cusp, a point leaving [a, b]). A Hopf
point is followed from the value before: the spectra are computed only along the branch near
where it was, outward until ψ changes sign (:mod:`.points`), so that a curve costs a few spectra
per value. Every rank computes the same curves; rank 0 writes ``curves.csv`` and the figure,
which shades the plane by the number of steady states (on a grid of 60 × 40 values: the root
search, :mod:`rodfem.model.steady`).
"""

from __future__ import annotations

import math

import numpy as np

from rodfem.model import steady
from rodfem.studies.steady import continuation as ct
from rodfem.studies.steady import points as pt

CURVES = "curves.csv"
COUNTS = "counts.csv"
COLUMNS = ("kind", "curve", "parameter", "parameter2", "u_1", "theta_1", "p", "omega", "period",
           "key", "key2")
KINDS = ("fold", "grazing", "hopf")
DEFAULT_VALUES = 41
GRID = (60, 40)  # the counts' grid over (KEY, KEY2)
REACH = 12  # a Hopf point is searched this many branch points either way of where it was


def parse_along(text: str, key: str, error) -> tuple[str, float, float, int]:
    """``KEY2=c:d`` or ``KEY2=c:d:n`` → (KEY2, c, d, n): a real scene key other than ``key``
    (``error``: the exception raised, with its one line)."""
    from rodfem.studies.steady.ranges import parse_range

    key2, found, c, d, n = parse_range(text, "--along", error, name="KEY2",
                                       example="heat_exchange.k1=500:2000", maximum=1000)
    if found.kind != "real":
        raise error(f"--along: {key2!r} is not a real scene key ({found.kind}); give a real "
                    "one, e.g. heat_exchange.k1=500:2000")
    if key2 == key:
        raise error(f"--along: {key2} is the key of --continue; give a second one")
    return key2, c, d, DEFAULT_VALUES if n is None else n


def follow(scene, key: str, lo: float, hi: float, key2: str, values: np.ndarray, kind: str,
           spectra, start_points: list[dict] | None = None) -> list[dict]:
    """The points of ``kind`` over ``key`` in [lo, hi] at each of ``values`` of ``key2``, joined
    into curves (the module's doc); Hopf points followed from ``start_points`` (points.csv's
    rows of the first value's diagram)."""
    if kind == "hopf":
        return _hopf_curves(scene, key, lo, hi, key2, values, spectra, start_points or [])
    rows: list[dict] = []
    before: dict[str, list[int]] = {}
    made = 0
    for value in values:
        here_scene = ct.at(scene, key2, value)
        curve = ct.Curve(here_scene, key, lo, hi)
        points = [p for branch in ct.branches(here_scene, key, lo, hi) for p in branch]
        # a grazing point where the branch turns back is a fold in the value too (a corner)
        wanted = {"fold": [("fold", lambda p: p.kind == "fold"),
                           ("grazing", lambda p: p.kind == "grazing" and p.turns)],
                  "grazing": [("grazing", lambda p: p.kind == "grazing")]}[kind]
        for name, chosen in wanted:
            found = sorted((p for p in points if chosen(p)), key=lambda p: p.t)
            labels = before.get(name, [])
            if len(found) != len(labels):  # points born or ended: new curves
                labels = list(range(made, made + len(found)))
                made += len(found)
            rows.extend(_row(name, label, point, value, curve, key, key2)
                        for label, point in zip(labels, found, strict=True))
            before[name] = labels
    return rows


def _row(kind, label, point, value2, curve, key, key2, omega=math.nan) -> dict:
    problem = curve.problem(point.value)
    state = problem.state(point.t, kind == "fold")
    return {"kind": kind, "curve": label, "parameter": point.value, "parameter2": float(value2),
            "u_1": state.u_1, "theta_1": state.theta_1, "p": state.p, "omega": omega,
            "period": 2.0 * math.pi / omega if math.isfinite(omega) else math.nan,
            "key": key, "key2": key2}


def _hopf_curves(scene, key, lo, hi, key2, values, spectra, start_points) -> list[dict]:
    """Each Hopf point of the first value followed over the rest (the module's doc)."""
    rows: list[dict] = []
    tracked = [(i, row["parameter"], row["u_1"]) for i, row in enumerate(start_points)
               if row["kind"] == "hopf"]
    for value in values:
        here_scene = ct.at(scene, key2, value)
        curve = ct.Curve(here_scene, key, lo, hi)
        spectral = pt.Spectral(curve, spectra)
        found_branches = ct.branches(here_scene, key, lo, hi)
        still = []
        for label, where, u_1 in tracked:
            hopf = _near(spectral, curve, found_branches, where, u_1)
            if hopf is None:
                continue
            rows.append(_row("hopf", label, hopf.point, value, curve, key, key2, hopf.omega))
            state = curve.problem(hopf.point.value).state(hopf.point.t)
            still.append((label, hopf.point.value, state.u_1))
        tracked = still
    return rows


def _near(spectral: pt.Spectral, curve: ct.Curve, branches, where: float, u_1: float):
    """The Hopf point nearest (``where``, ``u_1``) on the branches: from the branch point
    nearest it, chords outward until ψ changes sign across one."""
    best = None
    for branch in branches:
        for i, point in enumerate(branch):
            state = curve.problem(point.value).state(point.t)
            distance = math.hypot((point.value - where) / curve.v_scale,
                                  (state.u_1 - u_1) / curve.t_scale)
            if best is None or distance < best[0]:
                best = (distance, branch, i)
    if best is None:
        return None
    _, branch, i = best
    tests: dict[int, float] = {}

    def test(j: int) -> float:
        if j not in tests:
            tests[j] = spectral.test(branch[j])
        return tests[j]

    for offset in range(REACH + 1):
        for j in sorted({i - offset - 1, i + offset}):
            if 0 <= j < len(branch) - 1:
                a, b = test(j), test(j + 1)
                if math.isfinite(a) and math.isfinite(b) and (a < 0.0) != (b < 0.0):
                    found = spectral.hopf(branch[j], branch[j + 1])
                    if found is not None:
                        return found
    return None


def counts(scene, key: str, lo: float, hi: float, key2: str, c: float, d: float) -> dict:
    """The number of steady states on a grid over (key, key2): {"x", "y", "count"}."""
    x = np.linspace(lo, hi, GRID[0])
    y = np.linspace(c, d, GRID[1])
    count = np.zeros((y.size, x.size), dtype=int)
    for j, v2 in enumerate(y):
        at2 = ct.at(scene, key2, v2)
        for i, v in enumerate(x):
            count[j, i] = len(steady.of_scene(ct.at(at2, key, v)).roots())
    return {"x": x, "y": y, "count": count, "key": key, "key2": key2}
