"""Review of rodfem sensitivity: options of the other method, the lines a user reads, and the
directories other commands are given."""

import json
import shutil
import tomllib
from pathlib import Path

import pytest
from test_sensitivity import GOOD

import rodfem
from conftest import COMM, assert_refused, serial_only
from rodfem.cli import main


@serial_only
def test_a_morris_option_without_method_morris_is_refused(tmp_path, capsys):
    """levels without method = "morris" is a forgotten method: Sobol indices would ignore it."""
    study = tmp_path / "levels.toml"
    study.write_text("levels = 4\n" + GOOD)
    assert_refused(["sensitivity", str(study), "--out", str(tmp_path / "out")],
                   tmp_path / "out", 'levels is an option of Morris\' screening; give method = '
                   '"morris"', capsys)
    study.write_text('method = "morris"\nlevels = 4\n' + GOOD.replace(
        "[parameters]\n", '[parameters]\n"model.theta_A" = [5.0, 15.0]\n'))
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "out"), "--quiet"]) == 0


@serial_only
def test_morris_of_one_parameter_is_refused_in_one_line(tmp_path, capsys):
    """SALib's Morris sampling of one parameter raised a TypeError (a traceback)."""
    study = tmp_path / "one.toml"
    study.write_text('method = "morris"\n' + GOOD)
    assert_refused(["sensitivity", str(study), "--out", str(tmp_path / "out")],
                   tmp_path / "out", "Morris' screening ranks 2 parameters or more", capsys)


@serial_only
def test_one_measure_one_parameter_lines_and_plot_of_the_directory(tmp_path, capsys):
    study = tmp_path / "one.toml"
    study.write_text(GOOD)
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "Sobol indices of 1 of 1 measure over 1 parameter ->" in out, out
    # rodfem plot of the study's directory says where its figures are (it said the directory
    # was not a run's, for want of a history.h5)
    assert main(["plot", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == (f"rodfem: error: {tmp_path / 'out'} is a sensitivity study, drawn in "
                   f"{tmp_path / 'out' / 'sensitivity.png'}; 'rodfem plot "
                   f"{tmp_path / 'out' / 'runs'}' draws the figures of its runs\n"), err
    assert not (tmp_path / "out" / "figures").exists()
    assert main(["plot", str(tmp_path / "out" / "runs")]) == 0


@serial_only
def test_the_help_of_resume_names_sensitivity_studies(capsys):
    with pytest.raises(SystemExit):
        main(["resume", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a stopped sensitivity study runs the rest of its runs" in text, text
    assert "'rodfem sensitivity'" in text


def test_the_repr_of_one_measure_and_one_parameter_is_singular():
    from rodfem.studies.sensitivity.files import SensitivityResult

    row = {"measure": "u_1_final", "parameter": "model.zeta", "S1": 0.5, "S1_conf": 0.1,
           "ST": 0.6, "ST_conf": 0.1}
    result = SensitivityResult("sobol", ("S1", "S1_conf", "ST", "ST_conf"), (row,),
                               ("model.zeta",), ("u_1_final",), "complete")
    assert repr(result).startswith("<rodfem.SensitivityResult complete: Sobol indices, "
                                   "1 measure × 1 parameter>")
    assert "1 measure × 1 parameter&gt;</b>" in result._repr_html_()
    empty = SensitivityResult("sobol", result.columns, (), ("model.zeta",), ("u_1_final",),
                              "complete", warnings=("u_1_final has no indices: it is constant",))
    with pytest.raises(KeyError, match="measures with indices: none"):
        empty.indices("u_1_final")
    assert "<tbody></tbody>" in empty._repr_html_() and "constant" in empty._repr_html_()


def test_a_campaign_in_memory_says_how_long_its_runs_took():
    result = rodfem.sensitivity(tomllib.loads(GOOD))
    assert result.path is None and result.numbers["runs"] == 12
    assert result.numbers["run_seconds"] > 0  # was 0.0 in memory


@pytest.mark.parametrize("phase", ["analysis", "figure"])
def test_a_signal_after_the_runs_stops_the_study_and_resume_finishes_it(phase, shared_dir,
                                                                      capsys, monkeypatch):
    """SIGTERM during the analysis or as its figure is drawn (the runs done) was let wait and
    the study ended complete, exit 0, seconds after the signal: it now stops there, exit 143,
    the study interrupted, and resume finishes it to the files of an unstopped study. Under
    mpirun the signal reaches rank 0 alone (which draws), and every rank stops alike."""
    import os
    import signal

    import rodfem.post.sensitivity as chart
    from rodfem.output import interrupts
    from rodfem.studies.sensitivity import indices

    study = shared_dir / "good.toml"
    if COMM.rank == 0:
        study.write_text(GOOD)
    COMM.barrier()
    assert main(["sensitivity", str(study), "--out", str(shared_dir / "whole"), "--quiet"]) == 0
    monkeypatch.setattr(interrupts, "_received", [])  # the signal is this test's alone
    module, name = (indices, "analyse") if phase == "analysis" else (chart, "plot_indices")
    original = getattr(module, name)

    def interrupted(*args):
        os.kill(os.getpid(), signal.SIGTERM)
        return original(*args)

    monkeypatch.setattr(module, name, interrupted)
    out = shared_dir / "out"
    capsys.readouterr()
    assert main(["sensitivity", str(study), "--out", str(out)]) == 143
    COMM.barrier()  # rank 0 marks the directory as the others end
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert err.startswith("rodfem: interrupted by SIGTERM") and err.count("\n") == 1, err
        assert f"'rodfem resume {out}'" in err
    assert rodfem.load_sensitivity(out).status == "interrupted"
    monkeypatch.setattr(module, name, original)
    interrupts._received.clear()
    assert main(["resume", str(out), "--quiet"]) == 0
    COMM.barrier()
    assert rodfem.load_sensitivity(out).status == "complete"
    for name in ("sensitivity.csv", "sensitivity.png"):
        assert (out / name).read_bytes() == (shared_dir / "whole" / name).read_bytes(), name


def _stale(marker: Path) -> None:
    """A marker as a kill leaves it: running, its process gone."""
    data = json.loads(marker.read_text())
    data.update(status="running", pid=2 ** 22 + 1)
    data.pop("finished", None)
    marker.write_text(json.dumps(data))


@serial_only
def test_a_campaign_killed_as_its_runs_directory_was_made_resumes(tmp_path, capsys):
    """Killed between marking runs/ and writing its sweep.json, resume said 'no readable
    sweep.json' and exit 2; now it runs the runs, to the indices of an unstopped campaign."""
    study = tmp_path / "good.toml"
    study.write_text(GOOD)
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "whole"), "--quiet"]) == 0
    out = tmp_path / "out"
    shutil.copytree(tmp_path / "whole", out)
    for entry in (out / "runs").iterdir():
        if entry.name not in ("rodfem.json", "rodfem.lock"):
            shutil.rmtree(entry) if entry.is_dir() else entry.unlink()
    for name in ("sensitivity.csv", "sensitivity.png"):
        (out / name).unlink()
    _stale(out / "rodfem.json")
    _stale(out / "runs" / "rodfem.json")
    capsys.readouterr()
    assert main(["resume", str(out), "--quiet"]) == 0, capsys.readouterr().err
    assert (out / "sensitivity.csv").read_bytes() == \
        (tmp_path / "whole" / "sensitivity.csv").read_bytes()
    # a runs/ holding a file of the user's is not replaced: one line, exit 2, the file kept
    for name in ("sensitivity.csv", "sensitivity.png"):
        (out / name).unlink()
    shutil.rmtree(out / "runs")
    (out / "runs").mkdir()
    (out / "runs" / "notes.txt").write_text("mine")
    _stale(out / "rodfem.json")
    capsys.readouterr()
    assert main(["resume", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rodfem: error: ") and err.count("\n") == 1, err
    assert (out / "runs" / "notes.txt").read_text() == "mine"
    assert rodfem.load_sensitivity(out).status == "interrupted"  # not 'gone' for a live run


@pytest.mark.parametrize("method, samples", [("morris", 4), ("sobol", 8)])
def test_a_study_leaves_the_callers_random_numbers_alone(method, samples):
    """SALib's Morris sampling and analysis seed NumPy's global generator: a notebook's
    random numbers after a screening were the same whatever its seed."""
    import numpy as np

    from rodfem.studies.sensitivity import indices
    from rodfem.studies.sweep.parameters import Parameter

    parameters = (Parameter("a", 0.0, 1.0, False), Parameter("b", 0.0, 1.0, False))
    np.random.seed(123)
    expected = np.random.rand(3)
    np.random.seed(123)
    plan = indices.plan(parameters, method, samples)
    indices.analyse(plan, {"y": plan.values[:, 0] + plan.values[:, 1] ** 2})
    assert np.array_equal(np.random.rand(3), expected)


@serial_only
def test_one_bootstrap_resample_is_refused(tmp_path, capsys):
    """resamples = 1 gave confidence intervals that are not numbers (and NumPy's warnings)."""
    study = tmp_path / "one.toml"
    study.write_text("resamples = 1\n" + GOOD)
    assert_refused(["sensitivity", str(study), "--out", str(tmp_path / "out")],
                   tmp_path / "out", "resamples must be an integer from 2 to", capsys)


@serial_only
def test_loading_an_edited_table_is_one_scene_error(tmp_path, capsys):
    study = tmp_path / "good.toml"
    study.write_text(GOOD)
    assert main(["sensitivity", str(study), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    table = tmp_path / "out" / "sensitivity.csv"
    lines = table.read_text().splitlines()
    for edited in (lines[1].rsplit(",", 1)[0], lines[1].rsplit(",", 1)[0] + ",abc", "x"):
        table.write_text("\n".join([lines[0], edited]) + "\n")
        with pytest.raises(rodfem.SceneError, match="sensitivity.csv, line 2: not a row"):
            rodfem.load_sensitivity(tmp_path / "out")


@serial_only
def test_a_signal_before_the_runs_begin_says_how_to_resume(tmp_path, capsys, monkeypatch):
    """A signal between the study's directory and its runs (the sweep raises it as it starts)
    said 'stopped outside a time loop, nothing half-written' and no word of resume."""
    import signal

    import rodfem.studies.sweep.run as engine
    from rodfem.output import interrupts

    def stopped(*args, **kwargs):
        raise interrupts.Interrupted(signal.SIGTERM)

    monkeypatch.setattr(engine, "run_sweep", stopped)
    monkeypatch.chdir(tmp_path)
    Path("good.toml").write_text(GOOD)
    assert main(["sensitivity", "good.toml", "--out", "out"]) == 143
    err = capsys.readouterr().err
    assert err == ("rodfem: interrupted by SIGTERM; stopped outside a time loop, nothing "
                   "half-written; 'rodfem resume out' continues it\n"), err
    assert rodfem.load_sensitivity(tmp_path / "out").status == "interrupted"
    monkeypatch.undo()
    assert main(["resume", str(tmp_path / "out"), "--quiet"]) == 0
    assert len(rodfem.load_sensitivity(tmp_path / "out").table) == 1
