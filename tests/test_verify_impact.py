"""The impact benchmark (rodfem.model.impact) in ``rodfem verify`` and ``rodfem work-precision``,
at their quick sizes: a ladder refining h = Δt against the exact solution, every measure of it,
its orders under their own heading; and work-precision's ladders for each mass matrix, with the
choices the scene rejects reported with the scene's own reason."""

import csv
import dataclasses
import json
import math

import numpy as np
import pytest

import rodfem
from conftest import COMM
from rodfem.cli import main
from rodfem.model import impact
from rodfem.output.columns import INDEX
from rodfem.scene import METHODS, SceneError
from rodfem.scene.schema import MASSES
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification import verify, workprecision
from rodfem.studies.verification.verify import schemes


def _csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _exact_l1(h: float, **overrides) -> float:
    """GetFEM's L¹ error of a run of the impact, as the model measures it."""
    result = rodfem.simulate(impact.scene(h, overrides=[f"{k}={v}" for k, v in overrides.items()]))
    assert result.status == "complete", result.summary
    return impact.errors(result.history)["u1_l1"]


def test_impact_is_a_verify_scene():
    assert "impact" in verify.parse_scenes(None)
    assert verify.parse_scenes("impact") == ("impact",)
    assert [g.refined for g in verify.groups(("impact",))] == ["h=dt"] * len(schemes())
    # one ladder, h = Δt: 1/h cells and Δt = 1/cells at every rung
    assert verify.QUICK.ladder("h=dt") == [(50, 1 / 50), (100, 1 / 100), (200, 1 / 200)]
    assert [c for c, _ in verify.DEFAULT.ladder("h=dt")] == [100, 500, 1000, 2000]


def test_verify_quick_impact(shared_dir, capsys):
    """--scenes impact runs only the impact: every rung complete, each error falling as h = Δt
    falls, against the exact solution (u1_l1 as rodfem.model.impact measures it), no θ;
    Crank–Nicolson with the scene's redistributed mass at an order above ½ (measured 0.71), the
    paper scheme's near ½ (0.56); the orders in their own column and table."""
    out = shared_dir / "verify"
    assert main(["verify", "--quick", "--scenes", "impact", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    if COMM.rank == 0:
        assert "impact       h=Δt direct paper" in printed
        assert "orders (exact solution)" in printed
    points = _csv(out / "errors.csv")
    assert {p["scene"] for p in points} == {"impact"} and {p["refined"] for p in points} == \
        {"h=dt"}
    assert len(points) == 3 * len(schemes()) and all(p["status"] == "complete" for p in points)
    for scheme in schemes():
        mine = [p for p in points if p["scheme"] == scheme]
        assert [float(p["dt"]) for p in mine] == [1 / 50, 1 / 100, 1 / 200]
        assert all(float(p["dt"]) == 1 / int(p["cells"]) for p in mine)
        for m in ("u1_max", "u1_l1", "u1_l2", "u_T"):
            e = [float(p[m]) for p in mine]
            assert all(b < a for a, b in zip(e, e[1:], strict=False)), (scheme, m, e)
        assert all(math.isnan(float(p["theta_T"])) for p in mine)
    finest = next(p for p in points if p["scheme"] == "crank-nicolson" and p["cells"] == "200")
    assert float(finest["u1_l1"]) == pytest.approx(_exact_l1(5e-3), rel=1e-12)
    data = json.loads((out / "orders.json").read_text())
    assert data["exact"] == ["impact"] and data["references"] == {}
    assert data["scenes"] == {"impact": {"scene": "impact", "overrides": []}}
    orders = {r["scheme"]: r for r in _csv(out / "orders.csv")}
    assert float(orders["crank-nicolson"]["rate_u1_l1"]) > 0.5
    assert 0.4 < float(orders["paper"]["rate_u1_l1"]) < 0.7
    assert float(orders["crank-nicolson"]["rate_u1_l1"]) > float(orders["paper"]["rate_u1_l1"])
    assert orders["paper"]["rate_theta_T"] == "nan"
    text = (out / "orders.md").read_text()
    assert "Observed orders in h = Δt (against the exact solution):" in text
    assert "| h = Δt: u(1,·) L¹(0,T) |" in text and "| Δt: " not in text
    assert "Errors, h = Δt ladder (against the exact solution):" in text
    assert "h ladder: cells" not in text  # no reference ladders were run
    figure = out / "figures" / "orders_impact.png"
    assert figure.stat().st_size > 20_000 and figure.read_bytes()[:4] == b"\x89PNG"


def test_work_precision_quick_impact(shared_dir):
    """Each (mass, scheme, method) exactly once: a complete ladder h = Δt whose L¹ error of
    u(1, ·) falls at every rung, or a rejected choice with the scene's own message (picard with
    the rigid obstacle; Crank–Nicolson with it on a mass at x = 1; the dispersion-free mass with
    the paper scheme); the dispersion-free mass the most accurate."""
    from rodfem.post.workprecision import plot_work_precision

    out = shared_dir / "wp"
    plan = dataclasses.replace(workprecision.default_plan(quick=True), scenes=(),
                               impact_h=(2e-2, 1e-2), tolerances=())
    data = workprecision.run_work_precision(out, plan, False, False, COMM)
    rows = _csv(out / "workprecision.csv")
    assert tuple(rows[0]) == workprecision.COLUMNS
    assert set(verify.ERROR_COLUMNS) < set(rows[0]) and "mass" in rows[0]
    assert {r["scene"] for r in rows} == {"impact"} and {r["mass"] for r in rows} == set(MASSES)
    ran = {}
    for r in rows:
        assert r["status"] == "complete" and r["refined"] == "h=dt", r
        ran.setdefault((r["mass"], r["scheme"], r["method"]), []).append(float(r["u1_l1"]))
    assert all(len(e) == 2 and e[1] < e[0] for e in ran.values()), ran
    # the direct method's L¹ error is the model's
    assert ran["consistent", "paper", "direct"][-1] == pytest.approx(
        _exact_l1(1e-2, **{"discretisation.mass": "consistent", "time.scheme": "paper"}),
        rel=1e-12)
    rejected = {(r["mass"], r["scheme"], r["method"]): r["message"] for r in data["rejected"]}
    assert len(rejected) == len(data["rejected"])
    every = {(m, s, k) for m in MASSES for s in schemes() for k in METHODS}
    assert set(ran) | set(rejected) == every and not set(ran) & set(rejected)
    for mass, scheme, method in rejected:
        with pytest.raises(SceneError) as err:
            impact.scene(1e-2, overrides=[f"discretisation.mass={mass}",
                                          f"time.scheme={scheme}", f"solver.method={method}"])
        assert rejected[mass, scheme, method] == str(err.value)
    assert {k for k in rejected if k[2] != "picard"} == {
        (m, "crank-nicolson", k) for m in ("lumped", "consistent") for k in ("direct", "newton")
    } | {("dispersion-free", "paper", k) for k in ("direct", "newton")}
    assert ("redistributed", "crank-nicolson", "direct") in ran
    summary = data["impact"]
    assert summary["best"] == "dispersion-free, crank-nicolson, direct" or \
        summary["best"] == "dispersion-free, crank-nicolson, newton"
    assert summary["rejected"] == len(rejected) and data["reach"] is None
    if COMM.rank == 0:
        figure = plot_work_precision(out)
        assert [p.name for p in figure] == ["workprecision_impact.png"]
        assert figure[0].stat().st_size > 20_000
    COMM.barrier()


def test_the_impact_measures_are_the_exact_solutions():
    """impact_errors on a run: u(1, ·) against impact.end_displacement (the model's L¹ and max),
    the L² norm of the same errors, u(·, T) against impact.displacement by quadrature."""
    scene = impact.scene(1e-2, end=1.5)
    result, _ = cv.timed_run(scene)
    errors = verify.impact_errors(scene)(result)
    history = {k: result.history[:, INDEX[k]] for k in ("t", "u_1", "sigma_1", "energy")}
    model = impact.errors(history)
    assert errors["u1_l1"] == pytest.approx(model["u1_l1"], rel=1e-13)
    assert errors["u1_max"] == pytest.approx(model["u1_max"], rel=1e-13)
    t, u = history["t"], history["u_1"]
    e = u - impact.end_displacement(t)
    assert errors["u1_l2"] == pytest.approx(math.sqrt(np.sum(0.01 * e[1:] ** 2)), rel=1e-12)
    x = np.linspace(0.0, 1.0, 20001)
    fine = np.interp(x, result.x, result.u) - impact.displacement(x, 1.5)
    assert errors["u_T"] == pytest.approx(math.sqrt(np.mean(fine**2)), rel=1e-3)
    assert 0.0 < errors["u_T"] < 0.05 and math.isnan(errors["theta_T"])


def test_work_precision_quick_impact_adaptive(shared_dir):
    """The adaptive ladders of the impact, its own mass: h and the tolerance refined together,
    the first step h, by the direct method; the L¹ error of u(1, ·) falls at every rung and is
    the model's, each step counted with its own size."""
    out = shared_dir / "wp"
    plan = dataclasses.replace(workprecision.default_plan(quick=True), scenes=(),
                               impact_h=(2e-2, 1e-2), impact_masses=(), tolerances=(1e-2, 1e-3))
    data = workprecision.run_work_precision(out, plan, False, False, COMM)
    rows = _csv(out / "workprecision.csv")
    assert {r["mass"] for r in rows} == {workprecision.IMPACT_MASS}
    ran = {}
    for r in rows:
        assert r["status"] == "complete", r
        assert float(r["dt"]) == 1 / int(r["cells"]) and int(r["steps"]) > 0
        ran.setdefault((r["scheme"], r["method"]), []).append(
            (float(r["tolerance"]), float(r["u1_l1"])))
    assert set(ran) == {(s, "direct") for s in schemes()}
    for ladder in ran.values():
        assert [t for t, _ in ladder] == [1e-2, 1e-3] and ladder[1][1] < ladder[0][1], ladder
    assert ran["crank-nicolson", "direct"][-1][1] == pytest.approx(
        _exact_l1(1e-2, **{"time.adaptive": "true", "time.tolerance": 1e-3}), rel=1e-12)
    assert data["rejected"] == []
    best = data["impact"]["finest"][data["impact"]["best"]]
    assert best["tolerance"] == 1e-3 and best["dt"] == 1e-2
