"""``rodfem steady --continue KEY=a:b``: the bifurcation diagram's files, its Hopf points, the
two-parameter curves of ``--follow``, serial and under MPI, and bad input."""

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
import rodfem.scene
from rodfem.cli import main
from rodfem.solver.spectrum import Spectra
from rodfem.studies.steady import continuation as ct
from rodfem.studies.steady import points as pt

MPI_ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
HOT = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
       "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
       "obstacle.epsilon=0.1"]


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def sets(items):
    return [x for item in items for x in ("--set", item)]


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs the command itself")
def test_the_diagram_writes_its_points_and_ordered_branches(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["steady", "barber", "--set", "mesh.cells=10", "--out", str(out),
                 "--continue", "obstacle.temperature=0:30"]) == 0
    printed = capsys.readouterr().out
    points = rows(out / "points.csv")
    kinds = sorted(p["kind"] for p in points)
    assert kinds == ["fold", "grazing", "hopf", "hopf"]
    assert "grazing at obstacle.temperature = 25.8823529412" in printed
    branch = rows(out / "branches.csv")
    assert [int(r["point"]) for r in branch] == list(range(len(branch)))  # one branch, in order
    grazing = next(p for p in points if p["kind"] == "grazing")
    assert (grazing["before"], grazing["after"], grazing["turns"]) == ("stable", "unstable",
                                                                       "true")
    assert (out / "figures" / "branches.png").stat().st_size > 10_000


def test_a_hopf_point_is_a_crossing_located_to_round_off():
    """The located point's pair lies on the imaginary axis to round-off of its eigenvalue, the
    branch's points either side have ψ of opposite signs, and its period is 2π/ω."""
    scene = rodfem.scene.load("barber", [*HOT, "mesh.cells=20"])
    found = rodfem.bifurcation(scene, "model.zeta", 0.005, 0.04)
    (hopf,) = [p for p in found["points"] if p["kind"] == "hopf"]
    assert (hopf["before"], hopf["after"]) == ("unstable", "stable")
    assert hopf["period"] == pytest.approx(2 * math.pi / hopf["omega"], rel=1e-15)
    curve = ct.Curve(scene, "model.zeta", 0.005, 0.04)
    spectral = pt.Spectral(curve, Spectra())
    point = ct.Point(curve.problem(hopf["parameter"]).roots()[0][0], hopf["parameter"])
    rate, pair = pt.psi(spectral.eigenvalues(point))
    assert abs(rate) <= 1e-10 * abs(pair) and pair.imag == pytest.approx(hopf["omega"])
    step = 1e-9 * hopf["parameter"]
    for sign in (-1, 1):
        moved = ct.Point(point.t, hopf["parameter"] + sign * step)
        assert np.sign(spectral.test(moved)) == -sign  # unstable below, stable above


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs mpirun itself")
def test_the_diagram_and_curves_under_mpirun_are_the_serial_files(tmp_path):
    def cli(out: Path, ranks: int) -> None:
        command = [str(Path(sys.executable).with_name("rodfem")), "steady", "barber",
                   "--set", "mesh.cells=8", "--out", str(out), "--continue",
                   "obstacle.temperature=0:30", "--follow", "fold", "--along",
                   "heat_exchange.k1=500:1500:5"]
        if ranks > 1:
            command = ["mpirun", "-n", str(ranks), *command]
        subprocess.run(command, env=MPI_ENV, capture_output=True, text=True, timeout=300,
                       check=True)

    cli(tmp_path / "n1", 1)
    cli(tmp_path / "n2", 2)
    for name in ("steady.csv", "branches.csv", "points.csv", "curves.csv", "counts.csv"):
        assert (tmp_path / "n1" / name).read_bytes() == (tmp_path / "n2" / name).read_bytes()
    curves = rows(tmp_path / "n1" / "curves.csv")
    assert {r["kind"] for r in curves} == {"fold", "grazing"}
    assert len({r["parameter2"] for r in curves}) == 5
    assert (tmp_path / "n1" / "figures" / "curves.png").is_file()


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs the command itself")
@pytest.mark.parametrize("extra, message", [
    (["--follow", "fold"], "--follow and --along go together"),
    (["--along", "heat_exchange.k1=1:2"], "--follow and --along go together"),
    (["--follow", "fold", "--along", "obstacle.temperature=1:2"], "is the key of --continue"),
    (["--follow", "fold", "--along", "heat_exchange.k1=1"], "is not KEY2=a:b"),
    (["--follow", "fold", "--along", "mesh.cells=1:2"], "is not a real scene key"),
    (["--follow", "fold", "--along", "model.nothing=1:2"], "unknown scene key"),
    (["--follow", "fold", "--along", "heat_exchange.k1=-1:2"], "heat_exchange.k1"),
])
def test_bad_follow_input(tmp_path, capsys, extra, message):
    out = tmp_path / "bad"
    code = main(["steady", "barber", "--set", "mesh.cells=8", "--out", str(out),
                 "--continue", "obstacle.temperature=0:30", *extra])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs the command itself")
def test_follow_needs_a_followed_continuation(tmp_path, capsys):
    out = tmp_path / "bad"
    code = main(["steady", "barber", "--out", str(out), "--continue",
                 "obstacle.temperature=0:30:4", "--follow", "fold", "--along",
                 "heat_exchange.k1=1:2"])
    assert code == 2 and "needs --continue KEY=a:b" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow
def test_the_barber_points_quoted_in_the_docs_are_the_diagrams():
    """docs/thermal-contact.md quotes barber's points over θ_O as one diagram gives them."""
    text = (Path(__file__).resolve().parent.parent / "docs" / "thermal-contact.md").read_text()
    points = rodfem.bifurcation("barber", "obstacle.temperature", 0, 30)["points"]
    grazing = next(p for p in points if p["kind"] == "grazing")
    fold = next(p for p in points if p["kind"] == "fold")
    hopf = sorted((p for p in points if p["kind"] == "hopf"), key=lambda p: p["parameter"])
    assert f"{grazing['parameter']:.11g}" in text and f"{fold['parameter']:.11g}" in text
    assert f"{hopf[0]['parameter']:.8g}" in text and f"{hopf[0]['period']:.4g}" in text
    assert f"{hopf[1]['parameter']:.8g}" in text and f"{hopf[1]['period']:.3g}" in text


def _hopf_continuum(cells: int) -> dict:
    scene = rodfem.scene.load("barber", [*HOT, f"mesh.cells={cells}"])
    found = rodfem.bifurcation(scene, "model.zeta", 0.005, 0.04, extrapolate=True)
    (hopf,) = [p for p in found["points"] if p["kind"] == "hopf"]
    return hopf


@pytest.mark.parametrize("cells, within", [
    (20, 1e-4),  # 20, 40, 80 cells
    pytest.param(100, 1e-6, marks=pytest.mark.slow),  # 100, 200, 400 cells
])
def test_the_hopf_point_extrapolated_is_the_rods(cells, within):
    """The Hopf point located on three meshes and extrapolated in h² is the continuous
    problem's (the exact characteristic equation, tests/characteristic.py), and the error
    estimate beside it covers its error."""
    from characteristic import FOUND

    hopf = _hopf_continuum(cells)
    exact_zeta, exact_period = FOUND["hot rod Hopf ζ"], 2 * math.pi / FOUND["hot rod Hopf ω"]
    assert hopf["asymptotic"] is True
    assert hopf["parameter_continuum"] == pytest.approx(exact_zeta, rel=within)
    assert hopf["period_continuum"] == pytest.approx(exact_period, rel=within)
    assert abs(hopf["parameter_continuum"] - exact_zeta) <= hopf["parameter_error"]
    assert abs(hopf["period_continuum"] - exact_period) <= hopf["period_error"]
    # the mesh's own point is further off: the extrapolation earns its digits
    assert abs(hopf["parameter"] - exact_zeta) > abs(hopf["parameter_continuum"] - exact_zeta)


@pytest.mark.slow
def test_the_hopf_point_quoted_in_the_docs_is_one_runs():
    """docs/barber.md's table of the hot rod's onset is what one extrapolated diagram gives."""
    text = (Path(__file__).resolve().parent.parent / "docs" / "barber.md").read_text()
    hopf = _hopf_continuum(80)
    row = (f"| 80 cells | {hopf['parameter']:.6g} | {hopf['period']:.7g} |")
    rod = (f"| the rod (extrapolated in $h^2$) | {hopf['parameter_continuum']:.7g} ± "
           f"{hopf['parameter_error']:.1e} | {hopf['period_continuum']:.9g} ± "
           f"{hopf['period_error']:.1e} |")
    assert row in text and rod in text, (row, rod)


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs the command itself")
def test_a_hopf_point_followed_is_located_again_at_each_value(tmp_path):
    """--follow hopf: each point of the curve is the Hopf point a diagram at that value of the
    second key locates, to the doubles' resolution."""
    out = tmp_path / "hopf"
    assert main(["steady", "barber", *sets([*HOT, "mesh.cells=12"]), "--out", str(out),
                 "--continue", "model.zeta=0.005:0.04", "--follow", "hopf", "--along",
                 "heat_exchange.k1=500:2000:4"]) == 0
    curve = rows(out / "curves.csv")
    assert [float(r["parameter2"]) for r in curve] == [500.0, 1000.0, 1500.0, 2000.0]
    for r in curve:
        again = rodfem.bifurcation("barber", "model.zeta", 0.005, 0.04,
                                   [*HOT, "mesh.cells=12", f"heat_exchange.k1={r['parameter2']}"])
        (hopf,) = [p for p in again["points"] if p["kind"] == "hopf"]
        assert float(r["parameter"]) == pytest.approx(hopf["parameter"], rel=1e-12)
        assert float(r["period"]) == pytest.approx(hopf["period"], rel=1e-12)
    zetas = [float(r["parameter"]) for r in curve]
    assert zetas == sorted(zetas)  # the onset rises with the exchange


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs the command itself")
def test_extrapolated_rates_are_the_rods_within_their_estimates(tmp_path, capsys):
    """--extrapolate: the separated and the unstable state's rates against the exact equation,
    each within its error estimate; the pressed state's rate, the mesh's shortest waves
    crowding at −1/ζ, is said to be pre-asymptotic, not extrapolated."""
    from characteristic import FOUND

    out = tmp_path / "x"
    assert main(["steady", "barber", "--set", "mesh.cells=25", "--extrapolate",
                 "--out", str(out)]) == 0
    assert "pre-asymptotic" in capsys.readouterr().out
    separated, unstable, pressed = rows(out / "steady.csv")
    for row, exact in ((separated, FOUND["barber separated"].real),
                       (unstable, FOUND["barber unstable"].real)):
        assert abs(float(row["continuum_rate"]) - exact) <= float(row["continuum_error"])
        assert abs(float(row["continuum_rate"]) - exact) < abs(float(row["growth_rate"]) - exact)
    assert pressed["continuum_rate"] == "nan"
