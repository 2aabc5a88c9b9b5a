"""``rodfem verify`` says what its orders are worth: each observed order checked against the
scheme's (outside the band: "pre-asymptotic: refine further", and no Richardson estimate), no
order at all for the measures set by the steps, the h ladder of adaptive steps at a tighter
tolerance and flagged where their time error may carry it, and the scenes of a sweep file
verified one by one, the same tables serially and under mpirun.

The logic is tested on synthetic ladders m_k = L + C s_k^p, whose order is known; the command on
the stiff obstacle a user met (ε = 1e-4: its peak penetration sampled at the steps converges at
0.48 in Δt on the quick ladder, against the paper scheme's 1) and on a small sweep of the soft
obstacle of tests/test_verify_scene.py (16 cells, T = 0.2: about 1 s a scene).
"""

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import COMM, assert_refused, serial_only
from rodfem.cli import main
from rodfem.output.measures import NAMES, TIMINGS
from rodfem.scene import load
from rodfem.scene.measures import REDUCTIONS
from rodfem.studies import asymptotic
from rodfem.studies.verification import ladders, refine, verify
from rodfem.studies.verification import convergence as cv
from test_verify_scene import SCENE

RODFEM = str(Path(sys.executable).with_name("rodfem"))
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
HEAD = {"scene": "s", "method": "direct", "cells": 8, "tolerance": None, "status": "complete"}


def _ladder(refined, scheme, p, name="m", limit=2.0, c=0.3, size=0.1):
    """A ladder's records and measured values m_k = limit + c (size/2^k)^p, k = 0, 1, 2."""
    steps = [size / 2 ** k for k in range(3)]
    head = {**HEAD, "refined": refined, "scheme": scheme}
    records = [{**head, "dt": s} for s in steps]
    measured = [{**head, "dt": s, "measure": name, "value": limit + c * s ** p} for s in steps]
    return records, measured


def _csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _shared(tmp_path_factory, name):
    root = tmp_path_factory.mktemp(name) if COMM.rank == 0 else None
    return COMM.bcast(root, root=0)


# --- the expected orders and the band ---------------------------------------------------------

def test_expected_orders():
    """P1's 2 in h, each scheme's own order in Δt, q/(q + 1) in a tolerance, none in h = Δt."""
    assert asymptotic.expected("h", "paper") == asymptotic.expected("h", "crank-nicolson") == 2
    assert asymptotic.expected("dt", "paper") == 1 and \
        asymptotic.expected("dt", "crank-nicolson") == 2
    assert asymptotic.expected("tol", "paper") == 0.5
    assert asymptotic.expected("tol", "crank-nicolson") == pytest.approx(2 / 3, abs=1e-15)
    assert math.isnan(asymptotic.expected("h=dt", "paper"))


@pytest.mark.parametrize("refined, scheme", [("dt", "paper"), ("dt", "crank-nicolson"),
                                             ("h", "paper"), ("tol", "paper")])
def test_an_order_outside_the_band_gets_no_estimate(refined, scheme):
    """An observed order 0.3 off the expected: kept, flagged pre-asymptotic, no estimate; 0.2
    off: the estimate with the expected order, which is exact for m_k = L + C s_k^q."""
    expect = asymptotic.expected(refined, scheme)
    far = refine.measure_orders(*reversed(_ladder(refined, scheme, expect - 0.3)))[0]
    assert far["order"] == pytest.approx(expect - 0.3, abs=1e-9)
    assert far["note"] == asymptotic.PRE_ASYMPTOTIC and math.isnan(far["richardson"])
    near = refine.measure_orders(*reversed(_ladder(refined, scheme, expect + 0.2)))[0]
    assert near["note"] == "" and near["expected"] == expect
    records, measured = _ladder(refined, scheme, expect)
    exact = refine.measure_orders(measured, records)[0]
    assert exact["richardson"] == pytest.approx(2.0 - measured[-1]["value"], rel=1e-9)


def test_the_estimate_takes_the_expected_order():
    """m_k = L + C Δt_k + D Δt_k²: the observed order is off 1 by D's share, and the estimate
    with order 1 removes C's term exactly, so it is off by D's alone."""
    steps = [0.05 / 2 ** k for k in range(3)]
    values = [2.0 + 0.3 * s + 0.5 * s * s for s in steps]
    records = [{**HEAD, "refined": "dt", "scheme": "paper", "dt": s} for s in steps]
    measured = [{**r, "measure": "m", "value": v} for r, v in zip(records, values, strict=True)]
    row, = refine.measure_orders(measured, records)
    assert row["note"] == "" and row["order"] != pytest.approx(1.0, abs=0.01)
    with_observed = (values[2] - values[1]) / (2.0 ** row["order"] - 1.0)
    truth = 2.0 - values[2]
    assert abs(row["richardson"] - truth) < abs(with_observed - truth)
    # (m₂ − m₁) − (L − m₂) = D (s₂² − s₁²) + D s₂² = −2 D s₂² for s₁ = 2 s₂
    assert row["richardson"] - truth == pytest.approx(-2 * 0.5 * steps[2] ** 2, rel=1e-6)


def test_orders_table_checks_each_norm():
    """verify's orders: each norm's order checked against the expected one."""
    records = []
    for refined, scheme, p in (("dt", "paper", 0.5), ("dt", "crank-nicolson", 2.1),
                               ("h", "paper", 2.0), ("h=dt", "paper", 0.6)):
        for k in range(3):
            s = 0.1 / 2 ** k
            records.append({**HEAD, "refined": refined, "scheme": scheme,
                            "cells": round(1 / s) if refined != "dt" else 8, "dt": s,
                            **{m: s ** p for m in cv.MEASURES}})
    rows = {(r["refined"], r["scheme"]): r for r in verify.orders(records)}
    assert rows["dt", "paper"]["check_u_T"] == "pre-asymptotic"
    assert rows["dt", "crank-nicolson"]["check_u_T"] == ""
    assert rows["h", "paper"]["check_theta_T"] == ""
    assert rows["h=dt", "paper"]["check_u_T"] == ""  # no expected order: told under the table
    assert math.isnan(rows["h=dt", "paper"]["expected"])


# --- measures set by the steps -----------------------------------------------------------------

def test_every_measure_and_reduction_is_judged():
    """A new built-in measure or reduction must be classed: set by the steps, or smooth."""
    judged = (*asymptotic.STEPPED_MEASURES, *asymptotic.FIXED_STEP_MEASURES,
              *asymptotic.SMOOTH_MEASURES)
    assert sorted(judged) == sorted(n for n in NAMES if n not in TIMINGS)
    assert sorted((*asymptotic.STEPPED_REDUCTIONS, *asymptotic.SMOOTH_REDUCTIONS)) == \
        sorted(REDUCTIONS)


def test_measures_set_by_the_steps(tmp_path):
    """Counts and the time reached always; the contact's fraction and last change with fixed
    steps only (an adaptive run locates the events); declared: the time of a row's peak and any
    reduction of the steps' own columns."""
    path = tmp_path / "declared.toml"
    path.write_text(SCENE + """
[measures]
peak = { column = "sigma_1", reduce = "max_abs" }
peak_time = { column = "sigma_1", reduce = "time_of_max_abs" }
above = { column = "u_1", reduce = "time_positive" }
touching = { column = "contact", reduce = "integral" }
""", encoding="utf-8")
    fixed = asymptotic.stepped(load(str(path)))
    assert set(fixed) == {"t_final", "contact_intervals", "iterations_max", "contact_fraction",
                          "last_contact_change", "peak_time", "touching"}
    adaptive = asymptotic.stepped(load(str(path), ["time.adaptive=true"]))
    assert set(adaptive) == set(fixed) - {"contact_fraction", "last_contact_change"}


def test_a_stepped_measure_gets_no_order_however_it_converges():
    """A time set by the steps whose values happen to fall at order 1: no order, no estimate."""
    records, measured = _ladder("dt", "paper", 1.0, name="last_contact_change")
    row, = refine.measure_orders(measured, records, {"s": ("last_contact_change",)})
    assert row["note"] == asymptotic.STEPPED
    assert math.isnan(row["order"]) and math.isnan(row["richardson"])
    row, = refine.measure_orders(measured, records, {"other": ("last_contact_change",)})
    assert row["note"] == ""


# --- the h ladder of adaptive steps ------------------------------------------------------------

def test_adaptive_h_ladder_runs_at_the_finest_tolerance(tmp_path):
    path = tmp_path / "soft.toml"
    path.write_text(SCENE, encoding="utf-8")
    user = ladders.UserScene("soft", str(path), ("time.adaptive=true",))
    for sizes in (ladders.QUICK, ladders.DEFAULT):
        tol = ladders.ladder(user, "tol", sizes)
        h = ladders.ladder(user, "h", sizes)
        assert {s["tolerance"] for s in h} == {tol[sizes.rungs - 1]["tolerance"]}
        assert tol[sizes.rungs - 1]["cells"] == h[0]["cells"]  # the same run: its error known


@pytest.mark.parametrize("time_error, flagged", [(0.04, False), (0.06, True)])
def test_time_error_flags_the_h_orders(time_error, flagged):
    """The h ladder's finest error 1 (and a measure's last difference 1): a time error at its
    tolerance (the tolerance ladder's finest against its reference, scaled by
    1/(1 − 16^(−1/2)) = 4/3) above a twentieth of it flags the order in h."""
    measured_error = time_error * 0.75
    user = ladders.UserScene("s", "s.toml", ())
    head = {"scene": "s", "method": "direct", "scheme": "paper", "dt": 0.01}
    records = [{**head, "refined": "h", "cells": c, "tolerance": 1e-5, "status": "complete",
                **dict.fromkeys(cv.MEASURES, e)} for c, e in ((8, 16.0), (16, 4.0), (32, 1.0))]
    records += [{**head, "refined": "tol", "cells": 8, "tolerance": t, "status": "complete",
                 **dict.fromkeys(cv.MEASURES, measured_error)} for t in (4e-5, 2e-5, 1e-5)]
    measured = [{**r, "measure": "m", "value": v} for r, v in
                zip(records, (10.0, 6.0, 5.0, 3.0, 3.0, 3.0 + measured_error), strict=True)]
    orders = verify.orders(records)
    rows = refine.measure_orders(measured, records)
    references = {"s/tol": {"measures": {"m": 3.0}}}
    refine.flag_time_errors(orders, rows, records, measured, references, (user,),
                            ladders.QUICK)
    h, = [r for r in orders if r["refined"] == "h"]
    assert all((h[f"check_{m}"] == "time error") == flagged for m in cv.MEASURES)
    row, = [r for r in rows if r["refined"] == "h"]
    assert (row["note"] == asymptotic.TIME_ERROR) == flagged
    assert math.isnan(row["richardson"]) == flagged


# --- the stiff obstacle a user met -------------------------------------------------------------

STIFF = 'scene = "stiff"\n\n[obstacle]\nepsilon = 1e-4\n'


@pytest.fixture(scope="module")
def stiff(tmp_path_factory):
    """``rodfem verify --quick`` of stiff with ε = 1e-4, fixed and adaptive steps."""
    root = _shared(tmp_path_factory, "stiff")
    path = root / "stiff4.toml"
    if COMM.rank == 0:
        path.write_text(STIFF, encoding="utf-8")
    COMM.barrier()
    runs = {}
    for name, extra in (("fixed", []), ("adaptive", ["--set", "time.adaptive=true"])):
        out = root / name
        assert main(["verify", "--quick", "--scenes", str(path), *extra, "--out",
                     str(out)]) == 0
        runs[name] = (json.loads((out / "orders.json").read_text()),
                      (out / "orders.md").read_text())
    return runs


def test_stiff_orders_are_checked(stiff):
    """Every order shown with an estimate is within the band of the expected one; every other
    says why; the peak penetration's 0.48 in Δt is among them, and the table says so."""
    data, markdown = stiff["fixed"]
    flagged = 0
    for row in data["measure_orders"]:
        expect = asymptotic.expected(row["refined"], row["scheme"])
        estimate = row["richardson"]
        if row["note"] == "":
            assert abs(row["order"] - expect) <= asymptotic.BAND
            assert estimate is not None and math.isfinite(estimate)
        else:
            assert estimate is None  # nan, as JSON writes it
        if row["order"] is not None and abs(row["order"] - expect) > asymptotic.BAND:
            assert row["note"] == asymptotic.PRE_ASYMPTOTIC
            flagged += 1
    assert flagged >= 1
    peak, = [r for r in data["measure_orders"]
             if (r["refined"], r["measure"]) == ("dt", "max_penetration")]
    assert peak["note"] == asymptotic.PRE_ASYMPTOTIC
    assert "max_penetration | 0." in markdown and "pre-asymptotic: refine further" in markdown
    for row in data["orders"]:
        for m in cv.MEASURES:
            rate = row[f"rate_{m}"]
            far = rate is not None and abs(rate - row["expected"]) > asymptotic.BAND
            assert (row[f"check_{m}"] == "pre-asymptotic") == far


def test_stiff_stepped_measures_have_no_order(stiff):
    data, markdown = stiff["fixed"]
    for row in data["measure_orders"]:
        if row["measure"] in ("last_contact_change", "contact_fraction", "contact_intervals",
                              "iterations_max", "t_final"):
            assert row["note"] == asymptotic.STEPPED and row["richardson"] is None
    assert "| last_contact_change |" in markdown and "— (set by the steps, no order)" in markdown


def test_stiff_adaptive_h_ladder(stiff):
    """The h ladder at the tolerance ladder's finest; each order in h flagged exactly where the
    time error measured there exceeds a twentieth of the finest h rung's error."""
    data, markdown = stiff["adaptive"]
    points = data["points"]
    tol = [p for p in points if p["refined"] == "tol"]
    h = [p for p in points if p["refined"] == "h"]
    assert {p["tolerance"] for p in h} == {tol[-1]["tolerance"]}
    scale = 1.0 / (1.0 - ladders.QUICK.dt_reference ** -0.5)
    row, = [r for r in data["orders"] if r["refined"] == "h"]
    for m in cv.MEASURES:
        polluted = scale * tol[-1][m] > asymptotic.POLLUTION * h[-1][m]
        assert (row[f"check_{m}"] == "time error") == polluted, m
    if any(row[f"check_{m}"] for m in cv.MEASURES):
        assert "time error: the adaptive steps' time error" in markdown


# --- a sweep file ------------------------------------------------------------------------------

SWEEP = 'scene = "soft.toml"\n\n[set]\n"time.end" = 0.2\n\n[grid]\n' \
        '"obstacle.epsilon" = [1.0, 0.1, 0.01]\n'


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """``rodfem verify --quick`` of scenes 0 and 2 of a sweep of three."""
    root = _shared(tmp_path_factory, "swept")
    if COMM.rank == 0:
        (root / "soft.toml").write_text(SCENE, encoding="utf-8")
        (root / "study.toml").write_text(SWEEP, encoding="utf-8")
    COMM.barrier()
    out = root / "out"
    assert main(["verify", "--quick", "--scenes", str(root / "study.toml"), "--select", "2,0",
                 "--out", str(out)]) == 0
    return root, out, json.loads((out / "orders.json").read_text())


def test_a_sweep_s_scenes_each_get_their_tables(swept):
    root, out, data = swept
    assert data["user"] == ["study-0", "study-2"]
    assert data["scenes"]["study-2"]["values"] == "obstacle.epsilon = 0.01"
    markdown = (out / "orders.md").read_text()
    for key in ("study-0", "study-2"):
        assert f"## {key}" in markdown and (out / "figures" / f"orders_{key}.png").is_file()
    assert "study-1" not in markdown
    assert "scene 2 of the sweep" in markdown


def test_a_sweep_s_scene_is_verified_as_its_scene_file(swept):
    """Scene 2 of the sweep gives, bit for bit, the measures and errors of a scene file with its
    values (on this rank alone, whatever the command's ranks)."""
    root, _, data = swept
    path = root / f"alone{COMM.rank}.toml"
    path.write_text('scene = "soft.toml"\n\n[obstacle]\nepsilon = 0.01\n\n[time]\nend = 0.2\n',
                    encoding="utf-8")
    alone = ladders.UserGroup(ladders.UserScene("alone", str(path), ()), "dt")
    records, measured, _ = refine.run_user_group(alone, ladders.QUICK)
    theirs = [(r["measure"], r["value"]) for r in data["measures"]
              if (r["scene"], r["refined"]) == ("study-2", "dt")]
    assert [(r["measure"], r["value"]) for r in measured] == theirs
    points = [p for p in data["points"] if (p["scene"], p["refined"]) == ("study-2", "dt")]
    assert [[r[m] for m in cv.MEASURES] for r in records] == \
        [[p[m] for m in cv.MEASURES] for p in points]


@serial_only
@pytest.mark.slow  # two mpirun processes; each scene's ladders are dealt as the built-in ones
def test_a_sweep_verified_under_mpirun_gives_the_serial_tables(swept):
    root, out, _ = swept
    parallel = root / "parallel"
    import os
    done = subprocess.run(["mpirun", "-n", "2", RODFEM, "verify", "--quick", "--scenes",
                           str(root / "study.toml"), "--select", "0,2", "--out", str(parallel)],
                          env={**os.environ, **MPI_ENV}, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    for name in ("orders.csv", "measure_orders.csv", "measures.csv"):
        assert (out / name).read_bytes() == (parallel / name).read_bytes(), name

    def untimed(path):  # the errors' tables end with each run's wall time
        return [line.rsplit("|", 2)[0] if line.startswith("| direct") else line
                for line in path.read_text().splitlines()]
    assert untimed(out / "orders.md") == untimed(parallel / "orders.md")


@pytest.mark.parametrize("args, message", [
    (["--scenes", "paper1", "--select", "1"], "--select: applies to a sweep file"),
    (["--select", "1"], "--select: applies to a sweep file"),
    (["--scenes", "SWEEP", "--select", "1,x"], "--select: 'x' is not the index of a scene"),
    (["--scenes", "SWEEP", "--select", "3"], "--select: study.toml has 3 scenes, indices 0 to 2"),
    (["--scenes", "SWEEP", "--set", "model.k=-1"], "model.k"),
])
def test_bad_select(args, message, swept, tmp_path_factory, capsys):
    root, _, _ = swept
    out = _shared(tmp_path_factory, "bad") / "out"
    args = [a.replace("SWEEP", str(root / "study.toml")) for a in args]
    assert_refused(["verify", "--quick", *args, "--out", str(out)], out, message, capsys)


def test_the_figures_leave_out_the_measures_set_by_the_steps():
    """measures_<scene>.png draws no slopes beside a measure without an order."""
    from rodfem.post.verify import NO_FIGURE

    assert asymptotic.STEPPED in NO_FIGURE
