"""The warning on a fixed step that is coarse for the scene's contact (rodfem.model.timescales):
one line on stderr after a complete run that touched the obstacle, with the fix; the paper's
scenes, quasi-static scenes, scenes that never touch and adaptive scenes say nothing; the rigid
obstacle says so whatever the step; a sweep says it once for each kind; the API warns with
:class:`rodfem.CoarseStepWarning`; the run itself never changes."""

import warnings

import numpy as np
import pytest

import rodfem
import rodfem.output.results
import rodfem.scene
from conftest import COMM, history_rows
from rodfem.cli import main
from rodfem.model.timescales import ERROR_THERE, STEPS_NEEDED, coarse_step

SHORT = ["time.end=0.5", "mesh.cells=40", "solver.method=direct"]  # the first contact: t ≈ 0.2
STIFF = [*SHORT, "obstacle.epsilon=1e-4"]  # √(b ε) = 0.01: 10 steps of the default 1e-3


def run(out, *overrides, scene="paper1", capsys=None):
    argv = ["run", scene, "--out", str(out), "--quiet"]
    for item in overrides:
        argv += ["--set", item]
    code = main(argv)
    err = capsys.readouterr().err
    return code, COMM.bcast(err if COMM.rank == 0 else None, root=0)


@pytest.mark.parametrize("name", [f"paper{i}" for i in range(1, 6)])
def test_the_papers_scenes_say_nothing(name, shared_dir, capsys):
    assert coarse_step(rodfem.scene.load(name)) is None  # the whole scene, as the paper ran it
    code, err = run(shared_dir / name, "time.end=0.5", scene=name, capsys=capsys)
    assert code == 0 and err == ""


def test_a_stiff_obstacle_warns_in_one_line_and_the_run_is_the_same(shared_dir, capsys):
    out = shared_dir / "stiff"
    code, err = run(out, *STIFF, capsys=capsys)
    assert code == 0
    assert err.count("\n") == 1 and err.startswith("rodfem: warning: time.dt = 0.001 is coarse")
    for said in ("10 steps per contact time √(b ε) = 0.01", "needs 100",
                 "peak contact stress", "fix: time.adaptive = true, or time.dt = 0.0001"):
        assert said in err, err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        quiet = rodfem.simulate("paper1", STIFF)
    assert quiet.status == "complete" and (quiet.history["sigma_1"] < 0).any()
    rows = np.column_stack([quiet.history[name] for name in quiet.history.dtype.names])
    assert history_rows(out).tobytes() == rows.astype(float).tobytes()
    # the step it offers does not warn
    code, err = run(shared_dir / "fixed", *STIFF, "time.dt=0.0001", capsys=capsys)
    assert code == 0 and err == ""


def peak(scene: str, *overrides: str) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
        result = rodfem.simulate(scene, [*overrides, "output.every=1000000"])
    assert result.status == "complete"
    return float(np.abs(result.history["sigma_1"]).max())


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
def test_the_fix_keeps_its_promise_where_the_calibration_is_tightest(scheme):
    """``stiff`` (ζ = 0.1, ε = 1e-4: the calibration's worst point, docs/time-schemes.md): the
    step the warning offers does not warn, and its peak |σ(1)| is within the error the line
    states of the converged peak (Crank–Nicolson, adaptive steps at a tolerance of 1e-7: within
    5e-6 of 1e-8's); so is a step of exactly STEPS_NEEDED per √(b ε), the most the rounding of
    the offered step can give (T raised to a whole number of steps)."""
    chosen = [f"time.scheme={scheme}"]
    found = coarse_step(rodfem.scene.load("stiff", chosen))
    assert found is not None and f"within {ERROR_THERE[scheme]}" in found.line
    fixed = [*chosen, f"time.dt={found.fix_dt!r}"]
    assert f"time.dt = {found.fix_dt:g}" in found.line
    assert coarse_step(rodfem.scene.load("stiff", fixed)) is None
    bound = float(ERROR_THERE[scheme].removesuffix(" %")) / 100.0
    reference = peak("stiff", "time.scheme=crank-nicolson", "time.adaptive=true",
                     "time.tolerance=1e-7")
    exact = found.scale / STEPS_NEEDED[scheme]
    for overrides in (fixed, [*chosen, f"time.dt={exact!r}",
                              f"time.end={float(exact * np.ceil(0.5 / exact - 1e-9))!r}"]):
        error = peak("stiff", *overrides) / reference - 1.0
        assert abs(error) <= bound, (overrides, error)
    # and the step it offered before (50 steps per √(b ε): Δt = 2e-4) broke the promise
    if scheme == "paper":
        assert abs(peak("stiff", "time.dt=0.0002") / reference - 1.0) > bound


def test_crank_nicolson_needs_fewer_steps(shared_dir, capsys):
    scene = rodfem.scene.load("paper1", [*STIFF, "time.scheme=crank-nicolson"])
    found = coarse_step(scene)
    assert found.steps == pytest.approx(10.0) and found.fix_dt == 0.0005
    assert STEPS_NEEDED["crank-nicolson"] < STEPS_NEEDED["paper"]
    assert coarse_step(rodfem.scene.load("paper1", [*STIFF, "time.scheme=crank-nicolson",
                                                    "time.dt=0.0005"])) is None


def test_the_rigid_obstacle_says_so_with_adaptive_steps_as_the_fix(shared_dir, capsys):
    code, err = run(shared_dir / "rigid", *SHORT, "obstacle.kind=rigid", "time.dt=0.0001",
                    capsys=capsys)
    assert code == 0 and err.count("\n") == 1, err
    assert err.startswith("rodfem: warning: the rigid obstacle's impacts take no time")
    assert "fix: time.adaptive = true (a step ends at each impact)" in err
    assert "or time.dt" not in err  # no fixed step resolves an impact
    found = coarse_step(rodfem.scene.load("impact"))
    assert found.kind == "rigid" and found.scale == 0.0 and found.fix_dt is None


def test_quiet_runs_say_nothing(shared_dir, capsys):
    """b = 0 is quasi-static; a scene that never touches its obstacle (gap 10) has no contact to
    resolve; a failed run says why it failed, in its one line."""
    code, err = run(shared_dir / "static", *STIFF, "model.b=0", capsys=capsys)
    assert code == 0 and err == ""
    assert coarse_step(rodfem.scene.load("paper1", [*STIFF, "model.b=0"])) is None
    code, err = run(shared_dir / "far", *STIFF, "obstacle.gap=10", capsys=capsys)
    assert code == 0 and err == ""
    assert coarse_step(rodfem.scene.load("paper1", [*STIFF, "obstacle.gap=10"])) is not None
    code, err = run(shared_dir / "failed", *STIFF, "solver.method=picard", "time.dt=0.01",
                    "solver.max_iterations=3", capsys=capsys)
    assert code == 3 and err.count("\n") == 1 and "warning" not in err, err


class Adaptive:
    """A scene with ``time.adaptive = true`` (before the key exists: its data say so)."""

    def __init__(self, scene):
        self.scene = scene

    def __getitem__(self, key):
        return self.scene[key]

    def data(self):
        data = self.scene.data()
        data["time"]["adaptive"] = True
        return data


def test_an_adaptive_scene_is_never_coarse():
    for overrides in (STIFF, [*SHORT, "obstacle.kind=rigid"]):
        scene = rodfem.scene.load("paper1", overrides)
        assert coarse_step(scene) is not None
        assert coarse_step(Adaptive(scene)) is None


def test_the_api_warns_with_its_own_category():
    if COMM.rank == 0:
        with pytest.warns(rodfem.CoarseStepWarning, match="time.dt = 0.001 is coarse") as said:
            rodfem.simulate("paper1", STIFF)
        assert len(said) == 1 and said[0].filename == __file__
    else:
        rodfem.simulate("paper1", STIFF)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert rodfem.simulate("paper1", SHORT).status == "complete"


def test_a_sweep_says_it_once_for_each_kind(shared_dir, capsys):
    spec = shared_dir / "stiff.toml"
    if COMM.rank == 0:
        spec.write_text('scene = "paper1"\n[set]\n"time.end" = 0.5\n"mesh.cells" = 40\n'
                        '"solver.method" = "direct"\n[grid]\n'
                        '"obstacle.kind" = ["elastic", "rigid"]\n'
                        '"obstacle.epsilon" = [1e-4, 2e-4, 0.01]\n', encoding="utf-8")
    COMM.barrier()
    code = main(["sweep", str(spec), "--out", str(shared_dir / "sweep"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 0
    if COMM.rank == 0:
        lines = err.splitlines()
        assert len(lines) == 2, err
        assert lines[0].startswith("rodfem: warning: scenes 0, 1 of 6 (the coarsest: scene 0): "
                                   "time.dt = 0.001 is coarse for this obstacle: 10 steps"), err
        assert lines[1].startswith("rodfem: warning: scenes 3–5 of 6: the rigid"), err
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        result = rodfem.sweep(str(spec))
    lines = COMM.bcast(err.splitlines() if COMM.rank == 0 else None, root=0)
    assert result.coarse_steps == tuple(line.removeprefix("rodfem: warning: ") for line in lines)
    if COMM.rank == 0:  # rank 0 warns, once for each kind
        assert [str(w.message) for w in said] == list(result.coarse_steps)
        assert all(w.category is rodfem.CoarseStepWarning for w in said)
    else:
        assert not said


def test_resume_says_it_as_run_does(shared_dir, capsys):
    out = shared_dir / "extended"
    code, err = run(out, *STIFF[1:], "time.end=0.1", capsys=capsys)  # before the first contact
    assert code == 0 and err == ""
    code = main(["resume", str(out), "--quiet", "--set", "time.end=0.5"])
    err = capsys.readouterr().err
    assert code == 0
    if COMM.rank == 0:
        assert err.count("\n") == 1 and err.startswith("rodfem: warning: time.dt = 0.001"), err


MIXED = {"scene": "paper1", "set": {"time.end": 0.5, "mesh.cells": 40, "solver.method": "direct"},
         "grid": {"time.adaptive": [False, True],
                  "obstacle.epsilon": [1e-4, 0.01, 2e-4, 4e-4, 9e-4, 0.02]}}


def test_a_sweep_names_every_coarse_scene_and_flags_each_row(shared_dir):
    """results.csv's ``coarse`` is coarse_run of each scene's run alone, ``steps`` and
    ``rejected_steps`` its summary's; the warning names every coarse scene (the fixed steps
    against ε < 0.01, not the adaptive ones); the same table under mpirun as on one rank."""
    from mpi4py import MPI

    from rodfem.model.timescales import coarse_run
    from rodfem.output.measures import TIMINGS
    from rodfem.studies.sweep import design
    from rodfem.studies.sweep.run import load_sweep, run_sweep

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
        result = run_sweep(MIXED, shared_dir / "mixed")
        sweep = design.parse(MIXED, "mixed")
        flagged = []
        for i in range(len(sweep)):
            alone = rodfem.simulate(sweep.scene(i), comm=MPI.COMM_SELF)
            coarse = coarse_run(alone.scene, {**alone.summary, "status": alone.status})
            flagged += [i] if coarse is not None else []
            assert result["coarse"][i] == (coarse is not None)
            assert result["steps"][i] == alone.summary["steps"]
            assert result["rejected_steps"][i] == alone.summary.get("adaptive", {}).get(
                "rejected", 0)
    assert flagged == [0, 2, 3, 4]
    assert result.coarse_steps[0].startswith("scenes 0, 2–4 of 12 (the coarsest: scene 0): "
                                             "time.dt = 0.001 is coarse"), result.coarse_steps
    assert len(result.coarse_steps) == 1
    assert (result["rejected_steps"][6:] > 0).any() and (result["rejected_steps"][:6] == 0).all()
    assert (result["steps"][:6] == 500).all()
    read = load_sweep(shared_dir / "mixed")
    for name in ("coarse", "steps", "rejected_steps"):
        assert read[name].dtype.kind == "i" and read[name].tolist() == result[name].tolist()
    assert "coarse" not in rodfem.output.results.measure_names(tuple(read.columns))
    if COMM.size > 1:  # the same table as one rank alone
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", rodfem.CoarseStepWarning)
            alone = run_sweep(MIXED, comm=MPI.COMM_SELF)
        assert alone.coarse_steps == result.coarse_steps
        for name in result.columns:
            if name not in TIMINGS:
                assert result[name].tolist() == alone[name].tolist(), name


STUDY = """scene = "paper1"
samples = 4
outputs = ["u_1_final"]
[set]
"mesh.cells" = 40
"time.end" = 0.5
"solver.method" = "direct"
[parameters]
"obstacle.epsilon" = { log = [1e-4, 0.1] }
"""


def test_a_sensitivity_study_counts_its_coarse_runs_in_one_line(shared_dir, capsys):
    """The paper's step (1e-3) is coarse below ε = 0.01 (fewer than 100 steps per √ε): the
    runs there that touched are counted in one warning line, with the fix, flagged in
    runs/results.csv, and said again by load_sensitivity."""
    study, out = shared_dir / "sobol.toml", shared_dir / "sobol"
    if COMM.rank == 0:
        study.write_text(STUDY, encoding="utf-8")
    COMM.barrier()
    code = main(["sensitivity", str(study), "--out", str(out), "--quiet"])
    err = COMM.bcast(capsys.readouterr().err if COMM.rank == 0 else None, root=0)
    assert code == 0
    runs = rodfem.load_sweep(out / "runs")
    expected = (runs["obstacle.epsilon"] < 0.01) & (runs["contact_intervals"] > 0)
    assert 0 < expected.sum() < len(runs)
    assert runs["coarse"].tolist() == expected.astype(int).tolist()
    lines = [line for line in err.splitlines() if "coarse" in line]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"rodfem: warning: {expected.sum()} of the {len(runs)} runs had a "
                               "fixed step coarse for their contact (flagged in the coarse "
                               "column of runs/results.csv); the coarsest: time.dt = 0.001"), err
    assert "fix: time.adaptive = true, or time.dt = " in lines[0]
    loaded = rodfem.load_sensitivity(out)
    assert lines[0].removeprefix("rodfem: warning: ") in loaded.warnings


def test_a_fit_counts_its_coarse_runs_in_fit_json_and_one_line(shared_dir, capsys):
    """The fit of test_fit.py (ε near 0.012 with Δt = 2e-3: 55 steps per √ε, where the paper's
    scheme needs 100) runs every point with a coarse step: fit.json counts them, the command
    says so in one line; at Δt = 2e-4 (158 steps per √ε at ε = 1e-3, the range's stiffest) it
    counts none and says nothing."""
    from test_fit import FIT, write_fit

    for dt, coarse in ((0.002, True), (0.0002, False)):
        fit = write_fit(shared_dir / f"in{dt}", FIT.replace('"time.dt" = 0.002',
                                                            f'"time.dt" = {dt}'))
        code = main(["fit", str(fit), "--out", str(shared_dir / f"out{dt}"), "--quiet"])
        err = COMM.bcast(capsys.readouterr().err if COMM.rank == 0 else None, root=0)
        assert code == 0, err
        numbers = rodfem.load_fit(shared_dir / f"out{dt}").numbers
        lines = [line for line in err.splitlines() if "coarse" in line]
        if coarse:
            runs = numbers["runs"]
            assert numbers["coarse_runs"] == runs > 3
            assert lines == [f"rodfem: warning: {numbers['coarse_warning']}"], err
            assert numbers["coarse_warning"].startswith(
                f"{runs} of the {runs} runs had a fixed step coarse for their contact "
                "(fit.json's coarse_runs); the coarsest: time.dt = 0.002 is coarse"), err
        else:
            assert numbers["coarse_runs"] == 0 and numbers["coarse_warning"] is None
            assert lines == [], err
