"""Fits at the edges: data the history cannot reach, weights and tolerances the optimiser cannot
use, the messages' grammar, and a fit directory given to rodfem plot."""

import json
import shutil
import subprocess
import types

import numpy as np
import pytest
from mpi4py import MPI
from test_fit import ENV, FIT, rodfem_command, write_fit

import rodfem
from conftest import serial_only
from rodfem.api import scene_of
from rodfem.cli import main
from rodfem.studies.fit.data import Data
from rodfem.studies.fit.optimiser import statistics

DATA_TO_END = "t,u_1\n0.1,0.03\n0.5,0.12\n1.0,0.1\n"


def one_line_exit_2(fit: str, data: str, tmp_path, capsys) -> str:
    out = tmp_path / "out"
    assert main(["fit", str(write_fit(tmp_path, fit, data)), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rodfem: error: ") and not out.exists(), err
    return err


@serial_only
def test_data_after_the_last_row_the_history_keeps_are_refused(tmp_path, capsys):
    """500 steps, one row in 7 kept: the last at step 497, t = 0.994; the data's t = 1 would be
    compared with u(0.994) held by the interpolation."""
    fit = FIT.replace("[parameters]", '"output.history_every" = 7\n[parameters]')
    err = one_line_exit_2(fit, DATA_TO_END, tmp_path, capsys)
    assert "t = 1 lies after the last row of the scene's history, at t = 0.994" in err, err
    assert "output.history_every = 7" in err


def test_a_run_whose_history_ends_before_the_data_is_a_failed_run():
    """Adaptive steps: where the history ends is known only once run."""
    scene = scene_of("paper1", {"time.adaptive": True, "output.history_every": 7})
    data = Data(np.array([0.1, 0.5, 8.0]), ("u_1",), np.zeros((3, 1)), np.ones(1))
    why = data.after(np.array([0.0, 0.5, 7.9]), scene)
    assert "ends at t = 7.9, before the data's last time t = 8" in why
    assert "output.history_every = 7" in why
    end = scene["time.end"]
    assert data.after(np.array([0.0, end - 1e-12 * end]), scene) is None  # round-off: at it


@serial_only
def test_a_fit_whose_first_run_ends_before_the_data_stops_with_exit_3(tmp_path, capsys):
    fit = FIT.replace("[parameters]", '"time.adaptive" = true\n"output.history_every" = 7\n'
                      "[parameters]")
    out = tmp_path / "out"
    assert main(["fit", str(write_fit(tmp_path, fit, DATA_TO_END)), "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "failed: its history ends at t = 0.99" in err, err


@serial_only
@pytest.mark.parametrize("weight", ["1e300", "1e-300"])
def test_weights_beyond_what_float64_squares_hold_are_refused(weight, tmp_path, capsys):
    """1e300: the squares overflow (a traceback from the optimiser); 1e-300: they underflow to
    0, and the fit 'converged' at its start with standard errors nan."""
    fit = FIT.replace("[set]", f"[weights]\nu_1 = {weight}\n[set]")
    err = one_line_exit_2(fit, DATA_TO_END, tmp_path, capsys)
    assert "weights u_1: must be from 1e-100 to 1e+100" in err, err


@serial_only
def test_residuals_whose_squares_overflow_stop_the_fit_with_exit_3(tmp_path, capsys):
    data = "t,u_1\n0.1,1e200\n0.5,1e200\n"
    out = tmp_path / "out"
    fit = FIT.replace("[set]", "[weights]\nu_1 = 1e100\n[set]")
    assert main(["fit", str(write_fit(tmp_path, fit, data)), "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "weighted residuals overflows" in err, err


def test_no_standard_errors_where_float64_cannot_hold_them():
    flat = types.SimpleNamespace(derivatives=lambda _: np.ones(2))
    tiny = np.array([[1e-310, 0.0], [0.0, 1e-320], [0.0, 0.0]])  # full rank, its s² underflow
    stderr, correlation, why = statistics(flat, np.zeros(2), np.full(3, 1e-300), tiny)
    assert stderr is None and correlation is None and "float64" in why
    exact = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # |r| = 0: errors 0, no correlation
    stderr, correlation, why = statistics(flat, np.zeros(2), np.zeros(3), exact)
    assert list(stderr) == [0.0, 0.0] and correlation is None and why is None


@serial_only
def test_a_tolerance_below_float64s_epsilon_is_refused(tmp_path, capsys):
    fit = FIT.replace("[set]", "tolerance = 1e-20\n[set]")
    err = one_line_exit_2(fit, DATA_TO_END, tmp_path, capsys)
    assert "tolerance: must be a number between 2.22045e-16 and 1, got 1e-20" in err, err


ONE = ('scene = "paper1"\ndata = "data.csv"\nmax_evaluations = 1\n[set]\n"mesh.cells" = 16\n'
       '"time.dt" = 0.002\n"time.end" = 1.0\n"solver.method" = "direct"\n'
       '"obstacle.epsilon" = 0.012\n[parameters]\n"model.zeta" = [0.1, 1.0]\n')


@serial_only
def test_the_lines_count_one_in_the_singular(tmp_path, capsys):
    """One parameter, one datum, one evaluation: the start and its Jacobian, two runs."""
    out = tmp_path / "out"
    fit = write_fit(tmp_path, ONE, "t,u_1\n0.5,0.12\n")
    assert main(["fit", str(fit), "--out", str(out), "--progress"]) == 0
    captured = capsys.readouterr()
    assert "after 2 runs (1 iteration) ->" in captured.out, captured.out
    assert "fit: batch 1: 1 run (1 point in all)" in captured.err, captured.err
    assert "1 value to fit for 1 parameter: no standard errors" in captured.err
    loaded = rodfem.load_fit(out)
    assert "1 parameter, 1 time × 1 column, " in repr(loaded), repr(loaded)
    assert "2 runs</p>" in loaded._repr_html_()


@serial_only
def test_plot_of_a_fit_directory_says_where_its_figures_are(tmp_path, capsys):
    from rodfem.output.directories import finish, prepare_directory
    from rodfem.studies.fit.files import FILES

    out = tmp_path / "fit"
    prepare_directory(out, False, MPI.COMM_SELF, command="fit", files=FILES)
    finish(out, "complete", MPI.COMM_SELF)
    assert main(["plot", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{out} is a fit study, with no fit.png, .pdf, .svg drawn" \
        in err, err
    assert f"'rodfem plot {out}/fitted'" in err
    (out / "fit.pdf").write_bytes(b"%PDF-")  # the figure is named with the suffix it has
    assert main(["plot", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{out} is a fit study, drawn in {out}/fit.pdf" in err, err
    assert f"'rodfem plot {out}/fitted'" in err


@serial_only
@pytest.mark.parametrize("data, expected", [
    ("t,u_1\n0.1,0.03\n0.09999999,0.04\n", "row 3 has t = 0.09999999 after t = 0.1"),
    ("t,u_1\n0.1,0.03\n1.0000001,0.04\n", "t = 1.0000001 lies after the scene's end time.end = 1"),
])
def test_times_in_messages_are_shown_apart_from_those_they_are_set_against(
        data, expected, tmp_path, capsys):
    assert expected in one_line_exit_2(FIT, data, tmp_path, capsys)


@serial_only
def test_a_directory_named_as_the_data_is_refused_asking_for_a_csv_file(tmp_path, capsys):
    fit = write_fit(tmp_path, FIT.replace("data.csv", "measured"), "")
    (tmp_path / "measured").mkdir()
    assert main(["fit", str(fit), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "not a regular file but a directory; give a CSV file" in err, err


@serial_only
def test_resume_refuses_a_journal_of_another_fit_naming_its_file(tmp_path, capsys):
    data = "t,u_1\n0.5,0.12\n"
    first, second = tmp_path / "first", tmp_path / "second"
    assert main(["fit", str(write_fit(tmp_path / "a", ONE, data)), "--out", str(first)]) == 0
    other = ONE.replace("[0.1, 1.0]", "[0.2, 1.0]")
    assert main(["fit", str(write_fit(tmp_path / "b", other, data)), "--out", str(second)]) == 0
    stranger = first / "journal" / "part-0009-00000.bin"
    shutil.copy(second / "journal" / "part-0000-00000.bin", stranger)
    marker = json.loads((first / "rodfem.json").read_text())
    (first / "rodfem.json").write_text(json.dumps({**marker, "status": "interrupted"}))
    capsys.readouterr()
    assert main(["resume", str(first)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{stranger} holds points of another fit" in err, err
    assert "sweep" not in err


# time.dt between 0.0005 and 0.002: its middle and ends divide time.end = 1, the Jacobian's step
# from the middle does not
STEPS = ('scene = "paper1"\ndata = "data.csv"\n[set]\n"mesh.cells" = 16\n"time.end" = 1.0\n'
         '"solver.method" = "direct"\n"obstacle.epsilon" = 0.012\n[parameters]\n'
         '"model.zeta" = [0.1, 1.0]\n"time.dt" = [0.0005, 0.002]\n')


@serial_only
@pytest.mark.parametrize("ranks", [1, 2])
def test_a_point_whose_scene_is_refused_stops_the_fit_with_exit_3(ranks, tmp_path):
    """Under mpirun the rank that took the point raised alone, and the other waited for it for
    ever."""
    fit = write_fit(tmp_path, STEPS, DATA_TO_END)
    done = subprocess.run(rodfem_command("fit", fit, "--out", tmp_path / "out", ranks=ranks),
                          env=ENV, capture_output=True, text=True, timeout=120)
    assert done.returncode == 3, done.stderr
    assert "rodfem: error: the scene at model.zeta = 0.31622776601683794, time.dt = " in \
        done.stderr and "is refused: time.end: must be a whole number of steps" in done.stderr


@serial_only
def test_load_fit_refuses_data_edited_since_the_fit(tmp_path, capsys):
    """A data.csv cut to half its rows gave 20 times against a model at 40; one without the
    fitted column a ValueError."""
    out = tmp_path / "out"
    data = "t,u_1\n0.25,0.05\n0.5,0.12\n"
    assert main(["fit", str(write_fit(tmp_path, ONE, data)), "--out", str(out)]) == 0
    assert len(rodfem.load_fit(out).t) == 2
    (out / "data.csv").write_text("t,u_1\n0.25,0.05\n")
    with pytest.raises(rodfem.SceneError, match="data.csv is not the data this fit was run"):
        rodfem.load_fit(out)


@serial_only
def test_an_optimum_held_at_an_end_of_its_range_is_warned_of(tmp_path, capsys):
    """The data are of ζ = 0.25; its range starts at 0.3."""
    fit = write_fit(tmp_path, FIT.replace("[0.1, 1.0]", "[0.3, 1.0]"))
    out = tmp_path / "out"
    assert main(["fit", str(fit), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "rodfem: warning: model.zeta = 0.3 at the low end of its range [0.3, 1]: " in err, err
    assert "obstacle.epsilon" not in err
    assert rodfem.load_fit(out).numbers["warning"].startswith("model.zeta = 0.3 at the low end")


@serial_only
def test_resume_of_a_fit_stopped_before_its_study_json_says_to_run_it_again(tmp_path, capsys):
    from rodfem.output.directories import finish, prepare_directory
    from rodfem.studies.fit.files import FILES

    out = tmp_path / "fit"
    prepare_directory(out, False, MPI.COMM_SELF, command="fit", files=FILES)
    finish(out, "interrupted", MPI.COMM_SELF)
    assert main(["resume", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no readable study.json (No such file or directory): the " \
        "fit stopped before it began; run it again with --force" in err, err


@serial_only
def test_data_of_times_alone_are_refused_naming_the_columns_wanted(tmp_path, capsys):
    err = one_line_exit_2(FIT, "t\n0.1\n0.5\n", tmp_path, capsys)
    assert "data.csv: no column beside t; it needs the measured histories' columns too, e.g. " \
        "t,u_1 (those that can be fitted: u_1, u_half" in err, err


def test_a_data_file_from_a_spreadsheet_reads_as_a_plain_one(tmp_path):
    """A byte-order mark, Windows line ends and quoted names, as spreadsheets export them."""
    from rodfem.studies.fit.data import read_csv

    plain, exported = tmp_path / "plain.csv", tmp_path / "exported.csv"
    plain.write_bytes(DATA_TO_END.encode())
    exported.write_bytes(b"\xef\xbb\xbf" + DATA_TO_END.replace("t,u_1", '"t","u_1"')
                         .replace("\n", "\r\n").encode())
    (header, rows), (header_exported, rows_exported) = (read_csv(plain, "fit"),
                                                        read_csv(exported, "fit"))
    assert header == header_exported == ["t", "u_1"]
    assert rows.tobytes() == rows_exported.tobytes() and rows.shape == (3, 2)
