"""Fit data as spreadsheets write them: columns separated by semicolons (with decimal commas) or
tabs fitted to the comma file's fit bit for bit; empty cells read as values not measured, each
column's residuals only where it has values, the same fit serially, under mpirun and resumed;
and the data whose separator or values cannot be read refused in one line."""

import json
import shutil
import subprocess

import numpy as np
import pytest
from mpi4py import MPI
from test_fit import ENV, FIT, SET, SIGMA, TIMES, TRUTH, rodfem_command, write_fit
from test_fit_review import one_line_exit_2

import rodfem
from conftest import serial_only
from rodfem.cli import main
from rodfem.output import journal
from rodfem.studies.fit.data import read_csv
from rodfem.studies.fit.run import problem_of, study_of

COLUMNS = ("u_1", "u_half")
FIT2 = FIT.replace("[set]", 'columns = ["u_1", "u_half"]\n[set]')


@pytest.fixture(scope="module")
def measured():
    """u(1, t) and u(1/2, t) of the truth at 40 times, plus Gaussian noise of SIGMA (a fixed
    seed): times × (t, u_1, u_half)."""
    history = rodfem.simulate("paper1", {**SET, **TRUTH}, comm=MPI.COMM_SELF).history
    t = np.linspace(1.0 / TIMES, 1.0, TIMES)
    noise = np.random.default_rng(33).normal(0.0, SIGMA, (TIMES, 2))
    return np.column_stack([t] + [np.interp(t, history["t"], history[c]) + noise[:, j]
                                  for j, c in enumerate(COLUMNS)])


def csv_text(header, rows, sep: str = ",", decimal: str = ".") -> str:
    """A data file: each number at full precision, None an empty cell."""
    def cell(x):
        return "" if x is None else repr(float(x)).replace(".", decimal)
    return sep.join(header) + "\n" + "".join(sep.join(map(cell, row)) + "\n" for row in rows)


def fitted(directory, data: str, fit: str = FIT2):
    """The fit of ``data`` by the command, in this process: its directory."""
    out = directory / "out"
    assert main(["fit", str(write_fit(directory, fit, data)), "--out", str(out), "--yes"]) == 0
    return out


@pytest.fixture(scope="module")
def complete(measured, tmp_path_factory):
    """The fit of the complete rows: both columns at every other time, comma-separated."""
    return fitted(tmp_path_factory.mktemp("complete"), csv_text(("t", *COLUMNS), measured[::2]))


def test_a_semicolon_or_tab_file_reads_as_the_comma_file(measured, tmp_path):
    """The same numbers, bit for bit: a semicolon file with decimal commas (and a spreadsheet's
    byte-order mark, Windows line ends and quoted names), a tab file with decimal points."""
    files = {"comma": csv_text(("t", *COLUMNS), measured),
             "semicolon": '\ufeff"t";"u_1";"u_half"\r\n' + csv_text(
                 ("t", *COLUMNS), measured, ";", ",").split("\n", 1)[1].replace("\n", "\r\n"),
             "tab": csv_text(("t", *COLUMNS), measured, "\t")}
    read = {}
    for name, text in files.items():
        (tmp_path / f"{name}.csv").write_text(text, encoding="utf-8", newline="")
        read[name] = read_csv(tmp_path / f"{name}.csv", "fit")
    assert "0,0" in files["semicolon"] and "." not in files["semicolon"]
    for name in ("semicolon", "tab"):
        assert read[name][0] == ["t", *COLUMNS]
        assert read[name][1].tobytes() == read["comma"][1].tobytes() == measured.tobytes()


@serial_only
@pytest.mark.parametrize("sep, decimal", [(";", ","), ("\t", ".")])
def test_a_semicolon_or_tab_file_is_fitted_as_the_comma_file_bit_for_bit(
        sep, decimal, measured, complete, tmp_path):
    out = fitted(tmp_path, csv_text(("t", *COLUMNS), measured[::2], sep, decimal))
    assert (out / "fit.json").read_bytes() == (complete / "fit.json").read_bytes()


@serial_only
def test_rows_with_no_value_in_a_fitted_column_play_no_part(measured, complete, tmp_path):
    """The complete rows, and between them rows of a column not fitted alone (sigma_1): the
    residuals are the complete rows', bit for bit, and so is fit.json."""
    rows = [(*row, None) if i % 2 == 0 else (row[0], None, None, -row[1])
            for i, row in enumerate(measured)]
    out = fitted(tmp_path, csv_text(("t", *COLUMNS, "sigma_1"), rows))
    assert (out / "fit.json").read_bytes() == (complete / "fit.json").read_bytes()
    numbers = json.loads((out / "fit.json").read_text())
    assert numbers["points"] == TIMES // 2 and numbers["counts"] == dict.fromkeys(COLUMNS, 20)


def sheet(measured) -> list:
    """u_1 at every time, u_half at every other one (its other cells empty)."""
    return [row if i % 2 == 0 else (*row[:2], None) for i, row in enumerate(measured)]


def test_each_columns_residuals_are_those_of_its_values_alone(measured, tmp_path):
    """The residuals of the sheet are those of u_1's 40 values and then u_half's 20, each
    column read from a file of its own without empty cells: the same numbers, bit for bit."""
    history = rodfem.simulate("paper1", {**SET, "model.zeta": 0.3, "obstacle.epsilon": 0.01},
                              comm=MPI.COMM_SELF).history
    names = ("t", *COLUMNS)
    rows = np.column_stack([history[c] for c in names])

    def data(directory, text, columns):  # files of this rank's own (no write_fit)
        directory.mkdir()
        (directory / "data.csv").write_text(text)
        (directory / "fit.toml").write_text(FIT.replace(
            "[set]", f"columns = {json.dumps(columns)}\n[set]"))
        return problem_of(*study_of(directory / "fit.toml")).data

    whole = data(tmp_path / "sheet", csv_text(names, sheet(measured)), list(COLUMNS))
    u_1 = data(tmp_path / "u_1", csv_text(("t", "u_1"), measured[:, :2]), ["u_1"])
    u_half = data(tmp_path / "u_half", csv_text(("t", "u_half"), measured[::2, ::2]),
                  ["u_half"])
    r = whole.residuals(rows, names)
    assert whole.count == len(r) == 60 and whole.counts() == {"u_1": 40, "u_half": 20}
    expected = np.concatenate([u_1.residuals(rows, names), u_half.residuals(rows, names)])
    assert r.tobytes() == expected.tobytes()
    model = whole.model(r)
    assert np.array_equal(np.isnan(model), np.isnan(whole.values))
    assert np.isnan(whole.values[1::2, 1]).all() and not np.isnan(whole.values[::2]).any()


@pytest.fixture(scope="module")
def partial(measured, tmp_path_factory):
    """The fit of the sheet by the command, serially: its fit file and directory."""
    root = tmp_path_factory.mktemp("partial")
    return root / "fit.toml", fitted(root, csv_text(("t", *COLUMNS), sheet(measured)))


@serial_only
def test_a_sheet_with_empty_cells_is_fitted_to_its_values(partial):
    """Each parameter within 3 standard errors of the truth, |r| that of the noise of the 60
    values measured, the model null where a column has no value, and the fit read back."""
    _, out = partial
    result = rodfem.load_fit(out)
    numbers = result.numbers
    assert numbers["points"] == 40 and numbers["counts"] == {"u_1": 40, "u_half": 20}
    for key, truth in TRUTH.items():
        value, stderr = result.parameters[key]
        assert abs(value - truth) < 3 * stderr, key
    assert 0.7 < result.residual_norm / (SIGMA * np.sqrt(60 - 2)) < 1.3  # χ of 58: ±2.7 sd
    assert numbers["model"]["u_half"][1::2] == [None] * 20
    assert None not in numbers["model"]["u_1"] + numbers["model"]["u_half"][::2]
    for c in COLUMNS:  # NaN where the data have no value, at the same times
        assert np.array_equal(np.isnan(result.model[c]), np.isnan(result.data[c]))
    # the residuals fit.json's model gives are those of its norm (weights 1)
    r = np.concatenate([result.model[c] - result.data[c] for c in COLUMNS])
    assert np.linalg.norm(r[~np.isnan(r)]) == pytest.approx(result.residual_norm, rel=1e-11)
    assert "40 times × 2 columns (60 values)" in repr(result)
    assert (out / "fit.png").stat().st_size > 0


@serial_only
def test_a_sheet_with_empty_cells_gives_the_same_fit_json_under_mpirun(partial, tmp_path):
    fit, out = partial
    done = subprocess.run(rodfem_command("fit", fit, "--out", tmp_path / "mpi", "--yes",
                                         ranks=2),
                          env=ENV, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "mpi" / "fit.json").read_bytes() == (out / "fit.json").read_bytes()


@serial_only
def test_a_sheet_with_empty_cells_resumes_from_its_journal_to_the_same_fit_json(
        partial, tmp_path, capsys):
    """Its fit.json gone and the directory marked interrupted: the resumed fit replays every
    point from the journal, runs none again, and writes the same fit.json."""
    _, out = partial
    copy = shutil.copytree(out, tmp_path / "copy")
    (copy / "fit.json").unlink()
    marker = json.loads((copy / "rodfem.json").read_text())
    (copy / "rodfem.json").write_text(json.dumps({**marker, "status": "interrupted"}))
    before = len(journal.read(copy))
    assert main(["resume", str(copy)]) == 0, capsys.readouterr().err
    assert (copy / "fit.json").read_bytes() == (out / "fit.json").read_bytes()
    assert len(journal.read(copy)) == before == json.loads((out / "fit.json").read_text())["runs"]


ONE = FIT.replace('"obstacle.epsilon" = [1e-3, 1e-1]\n', "").replace(
    "[set]", 'max_evaluations = 1\n[set]\n"obstacle.epsilon" = 0.012')


@serial_only
def test_the_statistics_count_only_the_values_measured(tmp_path, capsys):
    """Two rows, one of them with no value beside its time: one value for one parameter."""
    fitted(tmp_path, "t,u_1,u_half\n0.25,0.05,0.02\n0.5,,\n", ONE.replace(
        "[set]", 'columns = ["u_1"]\n[set]'))
    assert "1 value to fit for 1 parameter: no standard errors" in capsys.readouterr().err


@serial_only
@pytest.mark.parametrize("data, expected", [
    ("t u_1\n0.1 0.03\n", "data.csv: its header 't u_1' has no comma, semicolon or tab between "
     "its names; separate the columns by one of those"),
    ("t;u_1,u_half\n0.1;0.03,0.01\n", "data.csv: the separator of its columns cannot be "
     "decided: its header 't;u_1,u_half' holds a comma and a semicolon; separate the columns by "
     "one of a comma, a semicolon or a tab, and no other"),
    ("t;u_1\n0.1;1.234,5\n", "data.csv: row 2, column u_1: '1.234,5' is not a number"),
    ("t,u_1\n0.1,0,03\n", "data.csv: row 2 has 3 cells; the header has 2"),
    ("t,u_1,u_half\n0.1,0.03,\n0.5,0.1,\n", "data.csv: column u_half has no values (every cell "
     'of it is empty); fill it, or fit the others alone: columns = ["u_1"]'),
    ("t;u_1\n0.1;\n", "data.csv: column u_1 has no values (every cell of it is empty); fill it"),
    ("t,u_1\n0.1,0.03\n,0.04\n", "data.csv: row 3 has no time t; every row needs one"),
])
def test_data_whose_separator_or_cells_cannot_be_read_are_refused(data, expected, tmp_path,
                                                                 capsys):
    assert expected in one_line_exit_2(FIT, data, tmp_path, capsys)
