"""Where a method fails: exit code 3, the reason in the message (for Picard, the paper's
condition), and the steps computed so far kept on disk."""

import json

import numpy as np

from conftest import COMM, history_rows
from rodfem.cli import main


def test_picard_failure_is_reported_and_results_kept(shared_dir, capsys):
    out = shared_dir / "fail"
    # Δt = 50 εζ: far outside the paper's sufficient condition Δt < εζ.
    code = main(["run", "paper1", "--out", str(out), "--set", "time.dt=0.01",
                 "--set", "obstacle.epsilon=0.001", "--set", "time.end=2"])
    err = capsys.readouterr().err
    assert code == 3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    history = history_rows(out)
    assert history.shape[0] == summary["steps"] + 1 >= 2
    assert (out / "fields.xdmf").is_file() and (out / "scene.toml").is_file()
    if COMM.rank == 0:
        step = summary["steps"] + 1
        assert f"did not converge at step {step} (t = {step * 0.01:g})" in err
        assert "Δt < εζ and a < 1, here Δt/(εζ) = 50" in err
        # what really decides (rodfem stability): the contraction w/ε, w from the direct method
        assert "contracts by about w/ε = 2.18 (needs < 1; w = 0.00218" in err
        assert "after 100 iterations" in err and "increment" in err
        assert err.count("\n") == 1 and "Traceback" not in err


def test_tight_iteration_budget_fails_inside_the_condition(shared_dir, capsys):
    """Inside the condition Picard converges, but not in one iteration: max_iterations = 1 fails
    at the first Picard step (n = 2), with steps 0 and 1 kept."""
    out = shared_dir / "budget"
    code = main(["run", "paper1", "--out", str(out), "--set", "solver.max_iterations=1"])
    capsys.readouterr()
    assert code == 3
    assert json.loads((out / "summary.json").read_text())["steps"] == 1


def test_newton_failure_is_reported(shared_dir, capsys):
    """Δt = 0.05 and ε = 1e-4: where the rod first touches, the first guess (the last increment)
    has the wrong contact state and semismooth Newton needs a second iteration; with a budget of
    one, SNES stops with DIVERGED_MAX_IT and the run with exit code 3."""
    out = shared_dir / "newton"
    code = main(["run", "paper1", "--out", str(out), "--set", "time.dt=0.05",
                 "--set", "obstacle.epsilon=1e-4", "--set", "time.end=2",
                 "--set", "solver.method=newton", "--set", "solver.max_iterations=1"])
    err = capsys.readouterr().err
    assert code == 3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["method"] == "newton"
    step = summary["steps"] + 1
    if COMM.rank == 0:
        assert f"Newton's method (SNES) did not converge at step {step}" in err
        assert "DIVERGED_MAX_IT after 1 iterations" in err
        assert err.count("\n") == 1 and "Traceback" not in err
    # With its default budget the same scene completes, the failing step in two iterations.
    code = main(["run", "paper1", "--out", str(shared_dir / "newton2"), "--quiet",
                 "--set", "time.dt=0.05", "--set", "obstacle.epsilon=1e-4", "--set", "time.end=2",
                 "--set", "solver.method=newton"])
    assert code == 0
    history = history_rows(shared_dir / "newton2")
    assert history[step, 6] == 2


def test_scene_toml_repeats_the_run(simulate, shared_dir):
    """scene.toml holds the resolved scene: running it again gives the same history, bit for bit,
    whatever characters its description holds."""
    from conftest import COMM
    from rodfem.scene import load

    scene_file = shared_dir / "mine.toml"
    if COMM.rank == 0:
        scene_file.write_text('description = "ζ = 1, ε → 0 😀 \\"quoted\\""\n[model]\nzeta = 1.0\n'
                              '[time]\nend = 0.3\n', encoding="utf-8")
    COMM.barrier()
    _, first = simulate(str(scene_file))
    again = load(str(first / "scene.toml"))
    assert again.description == 'ζ = 1, ε → 0 😀 "quoted"'
    _, second = simulate(str(first / "scene.toml"))
    assert history_rows(first).tobytes() == history_rows(second).tobytes()


def test_source_that_is_not_finite_mid_run_stops_it(shared_dir, capsys):
    """A source infinite at t = 0.5 only (validation checks the first and last times): the run
    stops there with exit code 3 and says which source, keeping the steps before."""
    out = shared_dir / "source"
    code = main(["run", "manufactured", "--out", str(out), "--set", "source.heat=1/(t - 0.5)",
                 "--set", "solver.method=direct"])
    err = capsys.readouterr().err
    assert code == 3
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["steps"] == 49
    if COMM.rank == 0:
        assert "source.heat is not finite at t = 0.5" in err and err.count("\n") == 1
    history = history_rows(out)
    assert history.shape[0] == 50 and np.isfinite(history).all()
