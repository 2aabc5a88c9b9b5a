"""A study says what it will cost before it starts (its runs × their steps × the µs per step
measured on a few steps), from a minute on, and one estimated beyond a day is refused in one
line, exit code 2, nothing written, unless --yes: the same on every rank, without a hang."""

import tomllib

import pytest

from conftest import COMM, assert_refused
from rodfem.cli import main
from rodfem.studies import cost
from rodfem.studies.sweep.design import parse

VALUES = [round(0.5 + i / 100, 3) for i in range(100)]
# 10,000 scenes of 100,000,000 steps each: months at any speed of a step measured here (at
# 1,000,000 steps, a step of 8 cells at 5 µs makes 14 hours on 1 rank: under a day, and so run)
HUGE = (f'scene = "paper1"\n[set]\n"time.end" = 100000\n"mesh.cells" = 8\n[grid]\n'
        f'"model.zeta" = {VALUES}\n"model.k" = {VALUES}\n')
SMALL = ('scene = "paper1"\n[set]\n"time.end" = 0.2\n"mesh.cells" = 8\n'
         '"solver.method" = "direct"\n[grid]\n"model.zeta" = [0.5, 1.0]\n')


def _write(directory, name, text):
    if COMM.rank == 0:
        (directory / name).write_text(text)
    COMM.barrier()
    return directory / name


def test_a_sweep_of_days_is_refused_unless_yes(shared_dir, capsys):
    sweep = _write(shared_dir, "huge.toml", HUGE)
    out = shared_dir / "out"
    assert_refused(["sweep", str(sweep), "--out", str(out)], out,
                   "10,000 runs of 100,000,000 steps: about ", capsys)
    assert_refused(["sweep", str(sweep), "--out", str(out), "--quiet"], out,
                   f"on {COMM.size} rank", capsys)
    parsed = parse(tomllib.loads(HUGE), "huge")
    found = cost.check(parsed.scene, len(parsed), COMM, yes=True)  # --yes: said, not refused
    assert found.runs == 10_000 and found.steps == 100_000_000 and found.ranks == COMM.size
    assert found.seconds > cost.BOUND_SECONDS and "more than" not in found.line()


@pytest.mark.parametrize("command", ["sensitivity", "fit"])
def test_studies_of_days_are_refused_alike(command, shared_dir, capsys):
    """A sensitivity study of 10,000 runs and a fit of at most 100 × 3 runs, each of 10⁸ steps
    (the issue's study, 524,288 runs of 500,000 steps, takes seconds to draw: scaled down)."""
    _write(shared_dir, "data.csv", "t,u_1\n0.1,0.0\n1.0,0.0\n")
    study = _write(shared_dir, f"{command}.toml", {
        "sensitivity": 'scene = "paper1"\nsamples = 2048\noutputs = ["u_1_final"]\n[set]\n'
                       '"time.end" = 100000\n"mesh.cells" = 8\n[parameters]\n'
                       '"model.zeta" = [0.5, 1.0]\n"model.k" = [0.5, 1.0]\n"model.a" = [0, 0.5]\n',
        "fit": 'scene = "paper1"\ndata = "data.csv"\n[set]\n"time.end" = 100000\n'
               '"mesh.cells" = 8\n[parameters]\n"model.zeta" = [0.1, 1.0]\n'
               '"model.k" = [0.5, 2.0]\n'}[command])
    out = shared_dir / "out"
    assert_refused([command, str(study), "--out", str(out)], out,
                   {"sensitivity": "10,240 runs of 100,000,000 steps: about ",
                    "fit": "at most 300 runs of 100,000,000 steps: about "}[command], capsys)


@pytest.mark.parametrize("quiet", [False, True])
def test_the_estimate_is_said_before_the_study_starts(quiet, shared_dir, capsys, monkeypatch):
    """Said from a minute on: with that bound at 0 s, a small sweep says its own, and runs."""
    monkeypatch.setattr(cost, "SAY_SECONDS", 0.0)
    sweep = _write(shared_dir, "small.toml", SMALL)
    capsys.readouterr()
    args = ["sweep", str(sweep), "--out", str(shared_dir / "out"), *(["--quiet"] * quiet)]
    assert main(args) == 0
    err = capsys.readouterr().err
    if COMM.rank == 0:
        said = [line for line in err.splitlines() if "runs of" in line]
        if quiet:
            assert not said, err
        else:
            assert len(said) == 1 and said[0].startswith(
                f"rodfem: 2 runs of 200 steps: about 0 s on {COMM.size} rank"), err
            assert "µs/step, measured)" in said[0]


def test_short_studies_are_not_measured(monkeypatch):
    """Below a minute even at the slowest step, nothing is run to measure one."""
    monkeypatch.setattr(cost, "_probe", lambda scene: pytest.fail("measured"))
    parsed = parse(tomllib.loads(SMALL), "small")
    assert cost.estimate(parsed.scene, len(parsed), 1) is None


@pytest.mark.parametrize("seconds, words", [(3 * 7 * 86400 + 5, "3 weeks"), (86400, "1 day"),
                                            (90, "2 minutes"), (40.4, "40 s"),
                                            (2 * 365.25 * 86400, "2 years")])
def test_durations_are_said_in_the_largest_unit(seconds, words):
    assert cost.duration(seconds) == words


def test_the_step_is_timed_twice_and_the_faster_taken(monkeypatch):
    """A scene's first run on a machine compiles its forms and loops (seconds, where a step
    takes microseconds): the estimate takes the faster of two measurements, so that a fresh
    machine does not announce hours for a study of seconds."""
    times = iter([13720.0, 8.0])
    monkeypatch.setattr(cost, "_probe", lambda scene: next(times))
    monkeypatch.setattr(cost, "SAY_SECONDS", 0.0)
    parsed = parse(tomllib.loads(SMALL), "small")
    found = cost.estimate(parsed.scene, len(parsed), 1)
    assert found.us_per_step == 8.0 and found.seconds == pytest.approx(2 * 200 * 8e-6)
