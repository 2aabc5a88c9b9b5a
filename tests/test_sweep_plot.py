"""``rodfem plot`` of a sweep directory (rodfem.post.sweep): the figures' names, that each is a
whole PNG with something drawn, and that a bad directory is refused with nothing written."""

import csv

import numpy as np
import pytest
from mpi4py import MPI
from PIL import Image

from conftest import serial_only
from rodfem.output.directories import FIGURE_NAMES
from rodfem.output.measures import NAMES
from rodfem.post.runs import PlotError
from rodfem.post.sweep import plot_sweep
from rodfem.studies.sweep.run import run_sweep

pytestmark = serial_only  # each sweep runs on this process alone (MPI.COMM_SELF)

BASE = '''scene = "paper1"
[set]
"time.end" = 0.2
"solver.method" = "{method}"
"mesh.cells" = 20
'''
ONE = '[grid]\n"model.k" = [0.1, 1, 10, 100]\n'
TWO = '[grid]\n"model.k" = [0.1, 1, 10]\n"model.zeta" = [0.2, 0.5]\n'
THREE = '[grid]\n"model.a" = [0.01, 0.02]\n"model.k" = [0.1, 1, 10]\n"model.zeta" = [0.2, 0.5]\n'
SAMPLE = '''[sample]
method = "random"
count = 6
seed = 1
[sample.ranges]
"model.k" = [0.1, 10]
"model.zeta" = [0.2, 1.0]
'''
FAILING = '[grid]\n"obstacle.epsilon" = [1e-6, 0.1]\n"model.zeta" = [0.2, 0.5]\n'


def informative(out) -> list[str]:
    """The measures drawn by default: results.csv's, but the timing and the iteration count,
    and those with one value (nan aside) in every complete scene (the scenes drawn)."""
    with open(out / "results.csv", encoding="utf-8", newline="") as file:
        rows = [row for row in csv.DictReader(file) if row["status"] == "complete"]
    return [n for n in NAMES if n not in ("loop_seconds", "iterations_max")
            and len({float(r[n]) for r in rows if r[n] != "nan"}) > 1]


def sweep(tmp_path, axes: str, method: str = "direct", name: str = "sweep"):
    spec = tmp_path / f"{name}.toml"
    spec.write_text(BASE.format(method=method) + axes, encoding="utf-8")
    out = tmp_path / name
    run_sweep(spec, out=out, comm=MPI.COMM_SELF)
    return out


def check_png(path):
    assert path.is_file(), path
    with Image.open(path) as image:
        assert image.format == "PNG"
        pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.shape[0] > 100 and pixels.shape[1] > 100
    assert len(np.unique(pixels)) > 2 and pixels.std() > 5, f"{path} is blank"


def check(written, directory, names):
    assert [p.name for p in written] == names
    assert all(p.parent == directory for p in written)
    for path in written:
        check_png(path)
        assert FIGURE_NAMES.match(path.name), path.name
    assert sorted(p.name for p in directory.iterdir()) == sorted(names)  # no temporaries


def test_one_axis(tmp_path):
    out = sweep(tmp_path, ONE)
    written = plot_sweep(out)
    assert len(informative(out)) >= 3
    check(written, out / "figures", [f"sweep_{n}.png" for n in informative(out)])
    assert plot_sweep(out) == written  # deterministic, and drawn again over the old files


def test_two_grid_axes_map_and_lines(tmp_path):
    out = sweep(tmp_path, TWO)
    written = plot_sweep(out, tmp_path / "figs")
    names = [f for n in informative(out) for f in (f"sweep_{n}.png", f"sweep_{n}_lines.png")]
    check(written, tmp_path / "figs", names)
    assert not (out / "figures").exists()


def test_three_grid_axes(tmp_path):
    out = sweep(tmp_path, THREE)
    check(plot_sweep(out), out / "figures", [f"sweep_{n}.png" for n in informative(out)])


def test_random_sample_scatter(tmp_path):
    out = sweep(tmp_path, SAMPLE)
    check(plot_sweep(out), out / "figures", [f"sweep_{n}.png" for n in informative(out)])


def grey_pixels(path) -> int:
    """How many pixels are matplotlib's "lightgrey" (211, 211, 211): the hatched empty cells."""
    with Image.open(path) as image:
        rgb = np.asarray(image.convert("RGB")).astype(int)
    return int(np.all(np.abs(rgb - 211) <= 2, axis=-1).sum())


def test_failed_scenes_are_left_out(tmp_path):
    out = sweep(tmp_path, FAILING, method="picard")  # ε = 1e-6: Picard does not converge
    with open(out / "results.csv", encoding="utf-8", newline="") as file:
        statuses = [row["status"] for row in csv.DictReader(file)]
    assert statuses == ["failed", "failed", "complete", "complete"]
    written = plot_sweep(out)
    names = [f for n in informative(out) for f in (f"sweep_{n}.png", f"sweep_{n}_lines.png")]
    # the failed scenes stop early, but are not drawn: the complete ones all reach T
    assert "t_final" not in informative(out) and "u_1_final" in informative(out)
    check(written, out / "figures", names)
    # the failed column (half the map) is grey; a map of complete scenes has no grey cells
    assert grey_pixels(out / "figures" / "sweep_u_1_final.png") > 20_000
    complete = sweep(tmp_path, TWO, name="complete")
    plot_sweep(complete)
    assert grey_pixels(complete / "figures" / "sweep_u_1_final.png") < 1_000


def test_expressions_that_look_like_numbers_on_two_grid_axes(tmp_path):
    """results.csv reads a column of "0", "1" as numbers, sweep.json keeps the strings: the map
    places each scene in its cell all the same (it raised "0.0 is not in list"), and the lines
    group the scenes by the second axis."""
    out = sweep(tmp_path, '[grid]\n"source.heat" = ["0", "1"]\n'
                          '"source.momentum" = ["0", "0.5", "1"]\n')
    written = plot_sweep(out, measures=["u_1_final"])
    check(written, out / "figures", ["sweep_u_1_final.png", "sweep_u_1_final_lines.png"])
    assert grey_pixels(written[0]) < 1_000  # no empty cell (one is over 10,000 pixels)
    with Image.open(written[1]) as image:
        legend = np.asarray(image.convert("RGB")).astype(int)
    # the lines' colours (tab10's first three), one per value of source.momentum
    for colour in ((31, 119, 180), (255, 127, 14), (44, 160, 44)):
        assert np.all(np.abs(legend - colour) <= 2, axis=-1).sum() > 50, colour


def test_edited_rows_failed_and_nan(tmp_path):
    out = sweep(tmp_path, ONE)
    path = out / "results.csv"
    with open(path, encoding="utf-8", newline="") as file:
        rows = list(csv.reader(file))
    status = rows[0].index("status")
    rows[1][status] = "failed"
    rows[1][status + 1:-1] = ["nan"] * (len(rows[0]) - status - 2)
    rows[2][rows[0].index("u_1_final")] = "nan"
    for row in rows[4:]:  # two complete scenes left, whose measures the figures draw
        row[status] = "interrupted"
    with open(path, "w", encoding="utf-8", newline="") as file:
        csv.writer(file, lineterminator="\n").writerows(rows)
    # t_final: the finite values are all T, so not drawn; the nan rows are left out
    assert "t_final" not in informative(out)
    check(plot_sweep(out), out / "figures", [f"sweep_{n}.png" for n in informative(out)])


@pytest.mark.parametrize("damage", ["no results", "no sweep.json", "bad json", "bad csv",
                                    "not a sweep", "no scenes"])
def test_bad_directory(tmp_path, damage):
    out = sweep(tmp_path, ONE)
    results, meta = out / "results.csv", out / "sweep.json"
    if damage == "no results":
        results.unlink()
    elif damage == "no sweep.json":
        meta.unlink()
    elif damage == "bad json":
        meta.write_text("{not json", encoding="utf-8")
    elif damage == "bad csv":
        results.write_text("a,b\n1,2\n", encoding="utf-8")
    elif damage == "not a sweep":
        meta.write_text('{"sweep": {"scene": 1}, "name": "x", "base": {}, "source": "x"}',
                        encoding="utf-8")
    else:
        results.write_text(results.read_text(encoding="utf-8").splitlines()[0] + "\n",
                           encoding="utf-8")
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(PlotError) as error:
        plot_sweep(out)
    message = str(error.value)
    assert message and "\n" not in message and str(out) in message
    assert sorted(p.name for p in out.iterdir()) == before  # nothing written
    assert not (out / "figures").exists()


def test_missing_directory(tmp_path):
    with pytest.raises(PlotError) as error:
        plot_sweep(tmp_path / "nowhere")
    assert "\n" not in str(error.value)
    assert not (tmp_path / "nowhere").exists()


def test_options(tmp_path, capsys):
    """--only chooses measures, --out keeps its figures without --force (and --force replaces
    only them); options of runs, or an unknown measure, are refused: exit 2, one line."""
    from rodfem.cli import main

    out, figs = sweep(tmp_path, ONE), tmp_path / "figs"
    written = plot_sweep(out, figs, measures=["u_1_final"])
    check(written, figs, ["sweep_u_1_final.png"])
    with pytest.raises(PlotError, match="sweep_u_1_final.png exists"):
        plot_sweep(out, figs, measures=["u_1_final"])
    (figs / "mine.txt").write_text("mine")
    assert plot_sweep(out, figs, force=True, measures=["u_1_final"]) == written
    assert sorted(p.name for p in figs.iterdir()) == ["mine.txt", "sweep_u_1_final.png"]
    capsys.readouterr()
    for options, message in ((["--only", "u_1_finall"], "the measures are "),
                             (["--window", "0,1"], "--window applies to runs"),
                             (["--colour-by", "model.k"], "--colour-by applies to runs"),
                             (["--labels", "a"], "--labels applies to runs")):
        bad = tmp_path / "bad"
        assert main(["plot", str(out), "--out", str(bad), *options]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err and "Traceback" not in err, err
        assert not bad.exists()
    assert main(["plot", str(out), "--out", str(figs), "--only", "u_1_final"]) == 2
    assert "--force" in capsys.readouterr().err
