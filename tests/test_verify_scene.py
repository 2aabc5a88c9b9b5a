"""``rodfem verify --scenes FILE.toml``: the convergence of a user's own scene, its error norms
against finer runs and the orders and Richardson estimates of its measures.

The scene is paper5's soft obstacle (ε = 1: the contact is smooth) on 16 cells to T = 0.4, the
direct method, Δt = 0.005: its quick ladders are cells 16, 32, 64 (against 512) and Δt = 0.005,
0.0025, 0.00125 (against Δt/64): about 50 ms a run. The tolerances of the orders, ±0.1, follow
from the ladders: the reference's own error, 8⁻² (h, order 2) and 16⁻¹ (Δt, order 1) of the
finest rung's, moves the errors' slopes by 0.035 at most; the rest is the next term of the error's
expansion, measured at these sizes at 0.06 for the paper's scheme in Δt (1.06-1.08) and 0.01 in h
and for Crank–Nicolson (2.00-2.02).
"""

import csv
import importlib.util
import json
import math

import numpy as np
import pytest

from conftest import COMM, assert_refused
from rodfem.cli import main
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification import ladders, refine, verify

EPS = np.finfo(float).eps
SCENE = """description = "paper5's soft obstacle, short"

[model]
a = 0.017
b = 1.0
zeta = 0.2
k = 1.0
theta_A = 10.0

[obstacle]
epsilon = 1.0
gap = 0.1

[initial]
theta0 = "theta_A*(cos(2*pi*x) - sin(pi*x/2))"
u0 = "0"
u1 = "20*x*(x - 1)**2"

[mesh]
cells = 16

[time]
dt = 0.005
end = 0.4

[solver]
method = "direct"
"""
# the measures of a smooth solution: of the scheme's order in Δt, of P1's in h
SMOOTH = ("u_1_final", "sigma_1_final", "max_penetration", "energy_final")
ORDER = {"paper": 1.0, "crank-nicolson": 2.0}  # rodfem.solver.time_schemes


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "soft.toml" if COMM.rank == 0 else None
    path = COMM.bcast(path, root=0)
    if COMM.rank == 0:
        path.write_text(SCENE, encoding="utf-8")
    COMM.barrier()
    return path


@pytest.fixture(scope="module")
def verified(scene_file, tmp_path_factory):
    """``rodfem verify --quick`` of the scene file with each time scheme: its output directory,
    orders.json and the tables."""
    root = tmp_path_factory.mktemp("verify") if COMM.rank == 0 else None
    root = COMM.bcast(root, root=0)
    runs = {}
    for scheme in ORDER:
        out = root / scheme
        assert main(["verify", "--quick", "--scenes", str(scene_file), "--set",
                     f"time.scheme={scheme}", "--out", str(out)]) == 0
        runs[scheme] = (out, json.loads((out / "orders.json").read_text()),
                        _csv(out / "orders.csv"), _csv(out / "measure_orders.csv"),
                        _csv(out / "measures.csv"))
    return runs


def _csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _order(rows, refined, measure):
    return next(r for r in rows if (r["refined"], r["measure"]) == (refined, measure))


def test_richardson_of_exact_expansions():
    """m_k = L + C h_k^p with h halved: the order p and the estimate L − m₂ to round-off."""
    for p, c in ((1.0, 0.3), (2.0, -1.7), (1.5, 4.0)):
        values = [2.0 + c * (0.1 / 2 ** k) ** p for k in range(4)]
        order, estimate, note = cv.richardson(values)
        assert note == "" and order == pytest.approx(p, abs=1e-9)
        assert estimate == pytest.approx(2.0 - values[-1], rel=1e-8)


@pytest.mark.parametrize("values, note", [
    ([1, 2, 2], "integer"),
    ([0.4, 0.4, 0.4], "the same in every run"),
    ([1.0, 1.0 + 4 * EPS, 1.0 + 6 * EPS], "differences at round-off"),
    ([0.816, 0.815, 0.815 + EPS], "the last difference at round-off"),
    ([0.816, 0.816 + EPS, 0.815], "the first difference at round-off"),
    ([1.0, 1.1, 1.05], "not monotone"),
    ([1.0, 1.1, 1.3], "not converging"),
    ([1.0, math.nan, 1.2], "a run without a value"),
    ([1.0, 1.1], "fewer than three runs"),
])
def test_richardson_no_order(values, note):
    order, estimate, told = cv.richardson(values)
    assert told == note and math.isnan(order) and math.isnan(estimate)


def test_error_orders(verified):
    """P1's order 2 in h for u and θ at T in L² (and u(1, ·) in time); each scheme's order in Δt
    for every error norm. Crank–Nicolson's θ(·, T) in h is left out: the midpoint rule does not
    damp the heat equation's fast modes (its amplification tends to −1 as Δt/h² grows), so at a
    fixed Δt its time error in θ changes with h (measured: order 1.8 here, 1.1 at Δt = 0.02)."""
    for scheme, (_, _, orders, _, _) in verified.items():
        rows = {r["refined"]: r for r in orders}
        assert set(rows) == {"h", "dt"}
        assert rows["h"]["method"] == "direct" and rows["h"]["scheme"] == scheme
        assert rows["h"]["points"] == rows["dt"]["points"] == "3/3"
        for m in cv.MEASURES:
            assert float(rows["dt"][f"rate_{m}"]) == pytest.approx(ORDER[scheme], abs=0.1), m
            if m != "theta_T" or scheme == "paper":
                assert float(rows["h"][f"rate_{m}"]) == pytest.approx(2.0, abs=0.1), m


def test_measure_orders(verified):
    """Smooth measures converge at P1's order in h and the scheme's in Δt; the counts, the time
    reached and (fixed steps) the contact's fraction of the steps and last change are set by
    the steps: no order, no estimate, and the table says so."""
    for scheme, (_, _, _, measured, _) in verified.items():
        for m in SMOOTH:
            h, dt = _order(measured, "h", m), _order(measured, "dt", m)
            assert float(h["order"]) == pytest.approx(2.0, abs=0.1), (scheme, m)
            assert float(dt["order"]) == pytest.approx(ORDER[scheme], abs=0.1), (scheme, m)
            assert h["note"] == dt["note"] == ""
        for refined in ("h", "dt"):
            for m in ("contact_intervals", "iterations_max", "t_final", "contact_fraction",
                      "last_contact_change"):
                row = _order(measured, refined, m)
                assert row["note"] == "set by the steps, no order", m
                assert row["order"] == row["richardson"] == "nan"
        assert "loop_seconds" not in {r["measure"] for r in measured}  # a timing


def test_richardson_estimates_the_finest_error(verified, scene_file):
    """The paper's scheme in Δt: the estimate of m_∞ − m_finest agrees with the reference run's
    value (Δt/16 of the finest) less the finest's, which is (1 − 16^−p) of it; to 10 %, the next
    term of the expansion. The estimate takes the expected order, 1."""
    _, _, _, measured, values = verified["paper"]
    user = ladders.UserScene("soft", str(scene_file), ("time.scheme=paper",))
    *_, reference = ladders.ladder(user, "dt", ladders.QUICK)
    run, _ = cv.timed_run(user.at(**reference))
    at_reference = refine.run_measures(run, user.at(**reference))
    for m in SMOOTH:
        row = _order(measured, "dt", m)
        finest = [float(r["value"]) for r in values if (r["refined"], r["measure"]) == ("dt", m)]
        p, estimate = float(row["expected"]), float(row["richardson"])
        assert p == ORDER["paper"]
        assert float(row["finest"]) == finest[-1]
        assert at_reference[m] - finest[-1] == pytest.approx(estimate * (1 - 16.0 ** -p),
                                                             rel=0.1), m


def test_files_and_printed_lines(verified, scene_file):
    out, data, _, _, values = verified["paper"]
    assert data["user"] == ["soft"] and data["scenes"]["soft"]["scene"] == str(scene_file)
    assert data["scenes"]["soft"]["overrides"] == ["time.scheme=paper"]
    for name in (*verify.FILES, "measures.csv", "measure_orders.csv"):
        assert (out / name).is_file(), name
    for name in ("orders_soft.png", "measures_soft.png"):
        figure = out / "figures" / name
        assert figure.stat().st_size > 20_000 and figure.read_bytes()[:4] == b"\x89PNG"
    errors = _csv(out / "errors.csv")
    assert [int(e["cells"]) for e in errors if e["refined"] == "h"] == [16, 32, 64]
    assert [float(e["dt"]) for e in errors if e["refined"] == "dt"] == [0.005, 0.0025, 0.00125]
    assert {r["measure"] for r in values} >= set(SMOOTH)
    markdown = (out / "orders.md").read_text()
    assert "cells 16, 32, 64 at Δt = 0.005, against 512 cells" in markdown
    assert "| h | u_1_final |" in markdown


def test_same_on_any_number_of_ranks(verified, scene_file):
    """Each ladder is run on one rank (under mpirun -n 2 the two ladders on two ranks): this
    rank's own run of the Δt ladder gives the command's measures and errors bit for bit."""
    _, data, _, _, values = verified["crank-nicolson"]
    user = ladders.UserScene("soft", str(scene_file), ("time.scheme=crank-nicolson",))
    records, measured, _ = refine.run_user_group(ladders.UserGroup(user, "dt"), ladders.QUICK)
    mine = [(r["measure"], r["value"]) for r in measured]
    theirs = [(r["measure"], r["value"]) for r in data["measures"] if r["refined"] == "dt"]
    assert mine == theirs
    points = [p for p in data["points"] if p["refined"] == "dt"]
    assert [[r[m] for m in cv.MEASURES] for r in records] == \
        [[p[m] for m in cv.MEASURES] for p in points]


def test_the_rows_a_scene_keeps_change_nothing(verified, scene_file):
    """The scene keeping every 3rd row of its history (output.history_every = 3): the ladders
    run every step all the same, to the errors and measures of the scene keeping every row."""
    _, data, _, _, _ = verified["crank-nicolson"]
    user = ladders.UserScene("soft", str(scene_file),
                            ("time.scheme=crank-nicolson", "output.history_every=3"))
    records, measured, _ = refine.run_user_group(ladders.UserGroup(user, "dt"), ladders.QUICK)
    points = [p for p in data["points"] if p["refined"] == "dt"]
    assert [[r[m] for m in cv.MEASURES] for r in records] == \
        [[p[m] for m in cv.MEASURES] for p in points]
    theirs = [(r["measure"], r["value"]) for r in data["measures"] if r["refined"] == "dt"]
    assert [(r["measure"], r["value"]) for r in measured] == theirs


def test_a_measure_panel_s_title_fits_its_panel():
    """A measure without an order says why on a line of its own: on one line with the
    measure's name, the title of a panel 640 pixels wide was cut at both ends."""
    from rodfem.post import verify as figures

    rows = [{"method": "direct", "scheme": "paper", "cells": c, "dt": 0.002, "tolerance": None,
             "status": "complete", "value": v} for c, v in ((10, 0.3), (20, 0.31), (40, 0.31))]
    order = {"measure": "last_contact_change", "order": math.nan,
             "note": "the last difference at round-off"}
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    assert figures._measure_panel(ax, rows, order, "h", "Δt = 0.002", False)
    assert ax.get_title().splitlines() == ["last_contact_change: no order",
                                           "(the last difference at round-off)"]


def test_mixed_with_built_in_scenes(scene_file):
    built, users = ladders.parse_scenes(f"{scene_file}, no-contact,paper1")
    assert built == ("paper1", "no-contact")  # in verify's order
    assert users == (ladders.UserScene("soft", str(scene_file), ()),)
    assert ladders.parse_scenes(None) == (verify.available_scenes(), ())


def test_a_failed_rung_keeps_its_place():
    """A rung without measures (its run failed) is a nan in its place, not skipped: the orders
    are of consecutive rungs or none."""
    head = {"scene": "s", "refined": "dt", "method": "direct", "scheme": "paper", "cells": 8,
            "tolerance": None}
    records = [{**head, "dt": dt} for dt in (0.4, 0.2, 0.1, 0.05)]
    measured = [{**head, "dt": dt, "status": "complete", "measure": "m", "value": v}
                for dt, v in ((0.4, 1.0), (0.1, 1.2), (0.05, 1.21))]
    row, = refine.measure_orders(measured, records)
    assert row["note"] == "a run without a value" and row["runs"] == 4
    row, = refine.measure_orders(measured, records[:1] + records[2:])
    assert row["order"] == pytest.approx(math.log2(0.2 / 0.01), abs=1e-12)


def test_adaptive_ladder_in_the_tolerance(scene_file, tmp_path):
    """With adaptive steps the second ladder refines the tolerance (the scheme's default,
    halved), at the scene's cells."""
    user = ladders.UserScene("soft", str(scene_file), ("time.adaptive=true",))
    assert [g.refined for g in ladders.user_groups((user,))] == ["h", "tol"]
    sizes = ladders.ladder(user, "tol", ladders.QUICK)
    assert [s["tolerance"] for s in sizes] == [5e-5, 2.5e-5, 1.25e-5, 1.25e-5 / 16]
    assert {s["cells"] for s in sizes} == {16}


BAD = [
    (["--scenes", "missing.toml"], "--scenes: missing.toml: "),
    (["--scenes", "paper9"], "--scenes: unknown scene 'paper9'; allowed: paper1"),
    (["--scenes", "SCENE", "--set", "mesh.cells=-3"], "--scenes: SCENE: mesh.cells"),
    (["--scenes", "SCENE", "--set", "time.dt=0.003"], "time.end: must be a whole number"),
    (["--scenes", "SCENE", "--set", "model.zetta=1"], "model.zetta"),
    (["--scenes", "paper1", "--set", "mesh.cells=32"], "--set: applies to a scene file"),
    (["--set", "mesh.cells=32"], "--set: applies to a scene file"),
    (["--scenes", "SCENE,SCENE"], "has the name 'soft' of another scene"),
    (["--scenes", "SCENE", "--set", "mesh.cells=400000"],
     "its h ladder's run at cells 12800000, dt 0.005: mesh.cells"),  # the reference: 32 c
]


@pytest.mark.parametrize("args, message", BAD)
def test_bad_input(args, message, scene_file, tmp_path_factory, capsys):
    out = (tmp_path_factory.mktemp("bad") if COMM.rank == 0 else None)
    out = COMM.bcast(out, root=0) / "out"
    args = [a.replace("SCENE", str(scene_file)) for a in args]
    message = message.replace("SCENE", str(scene_file))
    assert_refused(["verify", "--quick", *args, "--out", str(out)], out, message, capsys)


@pytest.mark.skipif(importlib.util.find_spec("rodfem.scene.measures") is None,
                    reason="this rodfem declares no measures in a scene")
def test_declared_measures(scene_file, tmp_path_factory, capsys):
    """The measures a scene declares are measured on every rung: the peak contact force and the
    mean energy late in the run (smooth: P1's order in h, the paper's in Δt, ±0.1 as above), and
    the time in contact, which starts at a step and so has no order of its own."""
    root = tmp_path_factory.mktemp("declared") if COMM.rank == 0 else None
    root = COMM.bcast(root, root=0)
    declared = root / "declared.toml"
    if COMM.rank == 0:
        declared.write_text(SCENE + """
[measures]
peak_force = { column = "contact_force", reduce = "max" }
late_energy = { column = "energy", reduce = "mean", window = [0.2, 0.4] }
""", encoding="utf-8")
    COMM.barrier()
    out = root / "out"
    assert main(["verify", "--quick", "--scenes", str(declared), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "peak_force" in printed or COMM.rank > 0
    measured = _csv(out / "measure_orders.csv")
    for m in ("peak_force", "late_energy"):
        assert float(_order(measured, "h", m)["order"]) == pytest.approx(2.0, abs=0.1), m
        assert float(_order(measured, "dt", m)["order"]) == pytest.approx(1.0, abs=0.1), m
