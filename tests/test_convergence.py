"""The verification harness: the error measures and rate fits of
``rodfem.studies.verification.convergence``, and the ``rodfem verify`` and ``rodfem work-precision``
commands at their quick sizes."""

import csv
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import COMM
from rodfem.cli import main
from rodfem.output.columns import INDEX
from rodfem.studies.verification import convergence as cv
from rodfem.studies.verification.verify import schemes

EPS = np.finfo(float).eps



def earlier_result(out, command: str) -> None:
    """An empty earlier result of ``command`` in ``out``: its marker, as the command leaves it."""
    from rodfem.output.directories import finish, prepare_directory

    prepare_directory(out, False, COMM, command=command, files=("orders.csv", "figures"))
    finish(out, "complete", COMM)

def test_l2_difference_closed_forms():
    # x on one cell against the hat at 1/2 on two: ∫₀^½ x² + ∫_½^1 (3x − 2)² = 1/24 + 1/8 = 1/6
    assert cv.l2_difference([0, 1], [0, 1], [0, 0.5, 1], [0, 1, 0]) \
        == pytest.approx(1 / math.sqrt(6), rel=4 * EPS)
    # a linear function is P1 on every mesh: ‖x − 0‖ = 1/√3, whatever the fine mesh
    fine = np.linspace(0, 1, 13)
    assert cv.l2_difference([0, 0.25, 0.5, 0.75, 1], [0, 0.25, 0.5, 0.75, 1], fine,
                            np.zeros(13)) == pytest.approx(1 / math.sqrt(3), rel=16 * EPS)
    # the same function on both meshes: no difference at all
    assert cv.l2_difference([0, 0.5, 1], [1, 3, 2], fine, np.interp(fine, [0, 0.5, 1],
                                                                     [1, 3, 2])) == 0.0


def test_l2_difference_against_gauss_quadrature():
    """Random values on nested uniform meshes (4 and 12 cells): the exact formula against
    2-point Gauss quadrature of the square of the P1 difference, exact for quadratics."""
    rng = np.random.default_rng(5)
    xc, xf = np.linspace(0, 1, 5), np.linspace(0, 1, 13)
    fc, ff = rng.normal(size=5), rng.normal(size=13)
    g = 0.5 + np.array([-0.5, 0.5]) / math.sqrt(3)
    a, h = xf[:-1], np.diff(xf)
    points = (a[:, None] + h[:, None] * g[None, :]).ravel()
    d = np.interp(points, xc, fc) - np.interp(points, xf, ff)
    quadrature = math.sqrt(float(np.sum(np.repeat(h / 2, 2) * d**2)))
    assert cv.l2_difference(xc, fc, xf, ff) == pytest.approx(quadrature, rel=64 * EPS)


def test_l2_difference_needs_nested_meshes():
    with pytest.raises(ValueError, match="not nested"):
        cv.l2_difference(np.linspace(0, 1, 4), np.zeros(4), np.linspace(0, 1, 5), np.zeros(5))


def test_time_errors_and_the_sampling_check():
    t_fine, t_coarse = np.linspace(0, 1, 9), np.linspace(0, 1, 5)
    c = 3e-3  # y_c − y_f = c t at the coarse times
    e_max, e_l1, e_l2 = cv.time_errors(t_coarse, t_coarse * (1 + c), t_fine, t_fine)
    assert e_max == pytest.approx(c, rel=4 * EPS)
    # Σ_{n≥1} ¼ c tₙ = c ¼ (1/4 + 1/2 + 3/4 + 1) = 5c/8
    assert e_l1 == pytest.approx(5 * c / 8, rel=8 * EPS)
    # (Σ_{n≥1} ¼ (c tₙ)²)^½ = c (¼ (1/16 + 1/4 + 9/16 + 1))^½ = c √(15/32)
    assert e_l2 == pytest.approx(c * math.sqrt(15 / 32), rel=8 * EPS)
    with pytest.raises(ValueError, match="not one of the fine run's times"):
        cv.time_errors(np.linspace(0, 1, 4), np.zeros(4), t_fine, np.zeros(9))  # Δt 1/3 vs 1/8
    with pytest.raises(ValueError, match="not one of the fine run's times"):
        cv.time_errors(t_coarse, np.zeros(5), t_fine[:5], np.zeros(5))  # fine run ends at 0.5


def _history(t, u_1):
    """A run's history with only t and u(1, ·) filled in."""
    rows = np.zeros((len(t), len(INDEX)))
    rows[:, INDEX["t"]], rows[:, INDEX["u_1"]] = t, u_1
    return rows


def test_u1_l1_is_the_sum_of_dt_times_the_error():
    """A hand-made pair of runs, the coarse one off the fine one at its times by
    e = (5, −1, 2, −3, 4)·10⁻³ with Δt = 1/4: u1_l1 = Σ_{n≥1} Δt |eₙ| = (1 + 2 + 3 + 4)/4·10⁻³,
    the start left out and the signs not cancelling; the max takes the start in, the L² norm
    not; the end fields equal, so no error at T."""
    t_fine, t_coarse = np.linspace(0, 1, 9), np.linspace(0, 1, 5)
    y_fine = np.sin(3 * t_fine)
    e = np.array([5, -1, 2, -3, 4]) * 1e-3
    x = np.linspace(0, 1, 5)
    coarse = SimpleNamespace(history=_history(t_coarse, y_fine[::2] + e), x=x, u=x**2,
                             theta=np.cos(x))
    fine = SimpleNamespace(history=_history(t_fine, y_fine), x=np.linspace(0, 1, 9),
                           u=np.interp(np.linspace(0, 1, 9), x, x**2),
                           theta=np.interp(np.linspace(0, 1, 9), x, np.cos(x)))
    errors = cv.errors_against(coarse, fine)
    assert set(errors) == set(cv.MEASURES)
    assert errors["u1_l1"] == pytest.approx(10e-3 / 4, rel=8 * EPS)
    assert errors["u1_max"] == pytest.approx(5e-3, rel=4 * EPS)
    assert errors["u1_l2"] == pytest.approx(math.sqrt(30e-6 / 4), rel=8 * EPS)
    assert errors["u_T"] == 0.0 and errors["theta_T"] == 0.0
    # the same sum from the norms of an error alone, whatever the steps
    t = np.array([0.0, 0.1, 0.3, 0.4])
    assert cv.time_norms(t, [9.0, -1.0, 2.0, -4.0])[1] == pytest.approx(0.1 + 0.4 + 0.4,
                                                                        rel=8 * EPS)


def test_rate_is_the_slope_of_power_laws():
    h = np.array([0.1, 0.05, 0.025, 0.0125])
    assert cv.rate(h, 3.0 * h**1.7) == pytest.approx(1.7, abs=1e-13)
    assert cv.rate(1 / h, 3.0 * h**2) == pytest.approx(-2.0, abs=1e-13)  # against cells
    # least squares: ±δ alternately about a slope-1 line moves the fitted slope by a known amount
    wobble = np.exp(0.01 * np.array([1, -1, 1, -1]))
    x = np.log(h)
    expected = 1 + np.polyfit(x, 0.01 * np.array([1, -1, 1, -1]), 1)[0]
    assert cv.rate(h, h * wobble) == pytest.approx(expected, abs=1e-13) and expected != 1
    # a failed (nan) or zero error is left out; fewer than two points give nan
    assert cv.rate(h, [np.nan, *(h[1:] ** 2)]) == pytest.approx(2.0, abs=1e-13)
    assert math.isnan(cv.rate(h[:1], h[:1]))
    assert math.isnan(cv.rate(h, [1.0, 0.0, np.nan, -1.0]))


def test_time_to_reach_interpolates_log_log():
    t = np.array([0.01, 0.1, 1.0, 10.0])
    e = t**-2 * 1e-4  # error 1e-4 t⁻²: it reaches 1e-3 at t = 10^-0.5
    assert cv.time_to_reach(t, e, 1e-3) == pytest.approx(10**-0.5, rel=1e-13)
    assert cv.time_to_reach(t, e, 1.0) == 0.01  # already at the first point: its time
    assert math.isnan(cv.time_to_reach(t, e, 1e-12))  # never
    assert cv.time_to_reach(t, [1.0, np.nan, 1e-6, 1e-8], 1e-3) == 1.0  # after a failed point


def _csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_verify_quick_orders(shared_dir, capsys):
    """The quick ladders on the scene without contact: order 1 in Δt for the paper scheme
    (measured 0.96-1.05 over the four measures), 2 in h for every scheme, 2 in Δt for
    Crank–Nicolson (2.00-2.05). Written over an earlier result, which --force replaces."""
    out = shared_dir / "verify"
    earlier_result(out, "verify")
    if COMM.rank == 0:
        (out / "figures").mkdir(parents=True)
        (out / "orders.csv").write_text("old")
        (out / "figures" / "orders_paper1.png").write_bytes(b"old")
    COMM.barrier()
    argv = ["verify", "--quick", "--scenes", "no-contact", "--out", str(out), "--force"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("verify: ") or COMM.rank > 0
    assert not (out / "figures" / "orders_paper1.png").exists()
    for name in ("orders.csv", "orders.md", "orders.json", "errors.csv"):
        assert (out / name).is_file()
    figure = out / "figures" / "orders_no-contact.png"
    assert figure.stat().st_size > 20_000 and figure.read_bytes()[:4] == b"\x89PNG"
    data = json.loads((out / "orders.json").read_text())  # strict JSON
    assert data["machine"]["mpi_ranks"] == COMM.size and data["reference_method"] == "direct"
    rows = {(r["refined"], r["scheme"]): r for r in _csv(out / "orders.csv")}
    assert set(rows) == {(d, s) for d in ("h", "dt") for s in schemes()}
    for m in cv.MEASURES:
        assert float(rows["dt", "paper"][f"rate_{m}"]) == pytest.approx(1.0, abs=0.1), m
        for s in schemes():
            assert float(rows["h", s][f"rate_{m}"]) == pytest.approx(2.0, abs=0.1), (s, m)
        if "crank-nicolson" in schemes():
            cn = rows["dt", "crank-nicolson"]
            assert float(cn[f"rate_{m}"]) == pytest.approx(2.0, abs=0.1), m
            # second order wins where the solution is smooth: at the same Δt, a smaller error
            assert float(cn[f"finest_{m}"]) < float(rows["dt", "paper"][f"finest_{m}"])
    errors = _csv(out / "errors.csv")
    assert len(errors) == 2 * 3 * len(schemes()) and all(e["status"] == "complete"
                                                        for e in errors)


def test_work_precision_quick(shared_dir, capsys):
    """The paper scenes' quick ladders against their references (the impact's are
    tests/test_verify_impact.py's)."""
    out = shared_dir / "wp"
    assert main(["work-precision", "--quick", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "paper5: time to reach" in printed or COMM.rank > 0
    assert "impact: smallest L¹ error of u(1,·)" in printed or COMM.rank > 0
    data = json.loads((out / "workprecision.json").read_text())
    every = [r for r in _csv(out / "workprecision.csv") if r["scene"] != "impact"]
    rows = [r for r in every if not r["tolerance"]]  # fixed steps
    assert len(rows) == 2 * 3 * len(schemes())
    assert all(r["mass"] == "lumped" for r in rows)  # the paper scenes' own
    assert (out / "figures" / "workprecision_impact.png").stat().st_size > 20_000
    for scene in ("paper1", "paper5"):
        assert (out / "figures" / f"workprecision_{scene}.png").stat().st_size > 20_000
        for s in schemes():  # each rung of a ladder is more accurate than the last
            errors = [float(r["u1_max"]) for r in rows if (r["scene"], r["scheme"])
                      == (scene, s)]
            assert all(b < a for a, b in zip(errors, errors[1:], strict=False)), (scene, s)
    # the adaptive ladders: each tolerance more accurate than the last, on a finer mesh
    adaptive = [r for r in every if r["tolerance"]]
    assert len(adaptive) == 2 * 3 * len(schemes())
    for scene in ("paper1", "paper5"):
        for s in schemes():
            mine = [r for r in adaptive if (r["scene"], r["scheme"]) == (scene, s)]
            assert [float(r["tolerance"]) for r in mine] == [1e-2, 1e-3, 1e-4]
            assert all(r["status"] == "complete" and int(r["steps"]) > 0 for r in mine)
            errors = [float(r["u1_max"]) for r in mine]
            assert all(b < a for a, b in zip(errors, errors[1:], strict=False)), (scene, s)
    # the figures tell the adaptive points from the fixed ones (whose tolerance reads as nan)
    from rodfem.post.verify import adaptive, read
    points = read(out / "workprecision.json")["points"]
    assert sum(map(adaptive, points)) == len([r for r in _csv(out / "workprecision.csv")
                                               if r["tolerance"]]) > 0
    reach = data["reach"]
    assert set(reach["seconds"]) == {f"direct, {s}{a}" for s in schemes()
                                     for a in ("", ", adaptive")}
    assert reach["paper_choice"] == "picard, paper" and reach["ratio"] is None  # not run


BAD = [
    (["verify", "--scenes", "paper9"], "--scenes: unknown scene 'paper9'; allowed: paper1"),
    (["verify", "--scenes", "paper1,"], "--scenes: unknown scene ''"),
]


@pytest.mark.parametrize("args, message", BAD)
def test_bad_input(args, message, shared_dir, capsys):
    out = shared_dir / "out"
    assert main([*args, "--out", str(out), "--quick"]) == 2
    err = capsys.readouterr().err
    assert not out.exists()
    if COMM.rank == 0:
        assert err.startswith("rodfem: error: ") and message in err, err
        assert err.count("\n") == 1


@pytest.mark.parametrize("command", ["verify", "work-precision"])
def test_existing_directory(command, shared_dir, capsys):
    """Never overwritten without --force; with it, never if it holds a file of someone else's."""
    out = shared_dir / "out"
    earlier_result(out, command)
    if COMM.rank == 0:
        (out / "notes.txt").write_text("mine")
    COMM.barrier()
    assert main([command, "--quick", "--out", str(out)]) == 2
    assert "exists; use --force" in capsys.readouterr().err or COMM.rank > 0
    assert main([command, "--quick", "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert "holds notes.txt" in err and err.count("\n") == 1
    assert (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "rodfem.json", "rodfem.lock"]

