"""``rodfem periodic``: the hot rod's periodic intermittent contact found by shooting, against
long time runs of the same scene and scheme; the orbit's multipliers; the command's files,
refusals and MPI."""

import csv
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM, assert_refused, serial_only
from rodfem.cli import main
from rodfem.studies.steady import barber
from rodfem.studies.steady import orbit as po
from rodfem.studies.steady import periodic as pe
from test_steady_command import MPI_ENV

HOT = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
       "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
       "obstacle.epsilon=0.1", "model.zeta=0.01", "time.dt=0.001", "solver.method=direct"]
CHEAP = [*HOT, "mesh.cells=20"]


def flags(overrides):
    return [word for value in overrides for word in ("--set", value)]


@pytest.fixture(scope="module")
def cheap():
    """The hot rod's orbit at ζ = 0.01 on 20 cells."""
    point = pe.analyse("barber", CHEAP, COMM)
    assert point.orbit is not None, point.why
    return point


def test_period_is_the_long_runs(cheap):
    """The orbit's period is the one a long run of the same scene and scheme settles on
    (measured from t = 250 to 300, the docs' window): to 1e-4, though the orbit's step is
    T/N ≤ time.dt and the run's time.dt itself (the period moves by about 9 per unit of Δt)."""
    orbit = cheap.orbit
    state, _ = pe.steady_state(rodfem.scene.load("barber", CHEAP))
    run = barber.run("barber", [*CHEAP, "time.end=300", *barber.at_rest(state, pe.KICK)])
    measured = barber.period(run.t, run.u_1 - state.u_1, 250, 300)
    assert abs(orbit.period - measured) < 1e-4 * measured
    cycle = barber.cycle(run, 250)
    assert orbit.u_min == pytest.approx(cycle.u_min, abs=2e-5)
    assert orbit.u_max == pytest.approx(cycle.u_max, abs=2e-5)
    assert orbit.contact_fraction == pytest.approx(cycle.contact_fraction, abs=2e-3)
    assert orbit.steps == po.steps_of(orbit.period, 0.001)
    assert orbit.period / orbit.steps <= 0.001 < orbit.period / (orbit.steps - 1)


def test_orbit_reproduces_itself_by_the_petsc_loop(cheap):
    """One period of steps of h = T/N by the PETSc loop (a method made for h, not the compiled
    step family the shots use) returns to the orbit's state to Newton's tolerance."""
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.solver.methods import make_method

    orbit = cheap.orbit
    h = orbit.period / orbit.steps
    scene = rodfem.scene.load("barber", [*CHEAP, f"time.dt={h!r}", f"time.end={orbit.period!r}"])
    method = make_method(Discretisation(scene, COMM))
    n = method.values.size // 3
    state = orbit.state.copy()
    state[n:2 * n] *= h
    method.restore({"state": state, "u_prev": state[2 * n:] - state[n:2 * n],
                    "step": np.array([1, 0]), "pressure": np.array([0.0])})
    for _ in range(orbit.steps):
        method.advance()
    end = method.values.copy()
    end[n:2 * n] /= h
    sizes = [np.max(np.abs(orbit.state[k * n:(k + 1) * n])) for k in range(3)]
    worst = max(np.max(np.abs(end - orbit.state)[k * n:(k + 1) * n]) / sizes[k]
                for k in range(3))
    assert worst < 1e-9
    assert orbit.residual <= po.TOLERANCE


def test_shots_are_bit_for_bit(cheap):
    """A shot depends on its state, T and N alone: again, and after other shots, the same bits."""
    point = cheap
    scene = rodfem.scene.load("barber", [*CHEAP, *barber.at_rest(
        pe.steady_state(point.scene)[0], pe.KICK)])
    flow = pe.flow_of(scene, COMM)
    orbit = point.orbit
    first = flow.shoot(orbit.state, orbit.period, orbit.steps)
    flow.shoot(flow.initial(), 0.7, 700)
    again = flow.shoot(orbit.state, orbit.period, orbit.steps)
    assert np.array_equal(first.view(np.int64), again.view(np.int64))


def test_cycle_is_stable_by_its_multipliers(cheap):
    """The long run settles on the cycle, so its non-trivial multipliers are inside the unit
    circle: the first vibration's pair, decaying at its own rate over a period."""
    orbit = cheap.orbit
    assert orbit.stable is True
    largest = abs(orbit.multipliers[0])
    assert largest < 1.0 - orbit.multiplier_error
    assert abs(orbit.trivial - 1.0) <= orbit.multiplier_error < 0.01
    # the slowest is a complex pair: the first vibration (growth rate about -0.05 here)
    assert abs(orbit.multipliers[0].imag) > 0.1
    assert np.log(largest) / orbit.period == pytest.approx(-0.06, abs=0.03)


def test_no_orbit_where_the_state_is_stable():
    """Above the scheme's onset (ζ = 0.03) the kicked run returns to the state: no orbit, and a
    row that says so, with no number made up."""
    point = pe.analyse("barber", [*CHEAP, "model.zeta=0.03"], COMM)
    assert point.orbit is None and "stable" in point.why
    row = pe.row(point.orbit, 0.03, "model.zeta", point.u_star, point.why)
    assert row["found"].startswith("no: ") and row["period"] is None and row["stable"] is None


def read(path: Path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_command_writes_its_files(shared_dir, capsys):
    out = shared_dir / "orbit"
    assert main(["periodic", "barber", *flags(CHEAP), "--set", "mesh.cells=12", "--out",
                 str(out)]) == 0
    captured = capsys.readouterr()
    rows = read(out / "periodic.csv")
    assert list(rows[0]) == list(pe.COLUMNS) and len(rows) == 1
    row = rows[0]
    assert row["found"] == "yes" and row["parameter"] == "" and row["stable"] == "true"
    assert float(row["period"]) == pytest.approx(1.1159, abs=1e-4)
    orbit = read(out / "orbit.csv")
    assert list(orbit[0]) == ["t", "u_1", "theta_1", "p", "sigma_1"]
    assert len(orbit) == int(row["steps"]) + 1
    assert float(orbit[-1]["t"]) == pytest.approx(float(row["period"]), rel=1e-12)
    assert float(orbit[0]["u_1"]) == pytest.approx(float(row["u_star"]), abs=1e-12)
    assert all(float(r["sigma_1"]) == -float(r["p"]) for r in orbit)
    assert float(row["u_min"]) == min(float(r["u_1"]) for r in orbit)
    assert (out / "settled.csv").is_file() and (out / "figures" / "orbit.png").is_file()
    if COMM.rank == 0:
        assert "period" in captured.out and str(out / "periodic.csv") in captured.out
        assert captured.err == ""


@pytest.mark.slow
def test_continuation_writes_a_row_for_each_value(shared_dir, capsys):
    """Each value a row; where the state is stable, a row that says so and a warning line."""
    out = shared_dir / "continued"
    assert main(["periodic", "barber", *flags(CHEAP), "--set", "mesh.cells=12", "--out",
                 str(out), "--continue", "model.zeta=0.01:0.03:2"]) == 0
    captured = capsys.readouterr()
    rows = read(out / "periodic.csv")
    assert [r["parameter"] for r in rows] == ["0.01", "0.03"]
    assert rows[0]["found"] == "yes" and rows[1]["found"].startswith("no: ")
    assert rows[1]["period"] == "" and rows[1]["stable"] == "" and rows[1]["u_star"] != ""
    assert (out / "figures" / "periodic.png").is_file()
    if COMM.rank == 0:
        warnings = captured.err.strip().splitlines()
        assert len(warnings) == 1 and warnings[0].startswith(
            "rodfem: warning: no periodic orbit at model.zeta = 0.03: ")


def test_every_rank_finds_the_same_orbit(cheap):
    """The columns of the Jacobian are dealt to the ranks and gathered: every rank ends with the
    same bits (the suite under mpirun -n 2 checks it; serially it is one rank)."""
    orbit = cheap.orbit
    mine = (orbit.period, orbit.state.tobytes(), orbit.multipliers.tobytes())
    assert all(other == mine for other in COMM.allgather(mine))


@pytest.mark.parametrize("extra, message", [
    (["--continue", "model.zeta"], "is not KEY=a:b:n"),
    (["--continue", "model.zeta=0.01:0.02:1"], "2 <= n <="),
    (["--continue", "output.every=1:2:3"], "does not change the orbit"),
    (["--continue", "model.nothing=1:2:3"], "unknown scene key"),
    (["--continue", "model.zeta=0.01:0.02:2", "--continue", "model.b=1:2:2"], "give it once"),
    (["--set", "time.adaptive=true"], "fixed steps"),
    (["--set", "solver.method=newton"], "compiled time loop"),
    (["--set", "mesh.cells=5000"], "monodromy matrix is dense"),
    (["--set", "model.zeta=-1"], "model.zeta"),
])
def test_bad_input_is_one_line(shared_dir, capsys, extra, message):
    out = shared_dir / "refused"
    assert_refused(["periodic", "barber", *flags(CHEAP), "--out", str(out), *extra], out,
                   message, capsys)


def _cli(out: Path, ranks: int) -> str:
    command = [str(Path(sys.executable).with_name("rodfem")), "periodic", "barber",
               *flags(CHEAP), "--set", "mesh.cells=12", "--out", str(out)]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    subprocess.run(command, env=MPI_ENV, capture_output=True, text=True, timeout=300,
                   check=True)
    return "".join((out / name).read_text() for name in (pe.PERIODIC, pe.ORBIT, pe.SETTLED))


@serial_only
@pytest.mark.slow
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_command_under_mpirun_writes_the_serial_tables(tmp_path):
    assert _cli(tmp_path / "n2", 2) == _cli(tmp_path / "n1", 1)


@pytest.mark.slow
def test_period_is_the_long_runs_on_80_cells():
    """The docs' figures: 80 cells, the cycle's period 1.11830 from the long run."""
    point = pe.analyse("barber", [*HOT, "mesh.cells=80"], COMM)
    state, _ = pe.steady_state(point.scene)
    run = barber.run("barber", [*HOT, "mesh.cells=80", "time.end=300",
                                *barber.at_rest(state, pe.KICK)])
    measured = barber.period(run.t, run.u_1 - state.u_1, 250, 300)
    assert abs(point.orbit.period - measured) < 1e-4 * measured
    assert point.orbit.stable is True
