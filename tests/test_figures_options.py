"""``rodfem plot``'s options: --only, --no-animation, --window, --labels, --colour-by, and --out
with --force; a bad value is exit code 2, one line, and nothing written. The titles say what the
figures show; the animation's obstacle gives way instead of letting the rod through.

Runs are simulated collectively (the suite also runs under mpirun); the command is called on
every rank, figures are checked on rank 0.
"""

import dataclasses
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from test_plot import assert_animation, assert_figure, frames

import rodfem.scene
from conftest import COMM
from rodfem.cli import main

# paper1 (ζ = 0.2), paper2 (ζ = 1) and paper1 with ζ = 0.5, to t = 0.3, fields every 0.025.
RUNS = (("paper1", "zeta02", ()), ("paper2", "zeta1", ()),
        ("paper1", "zeta05", ("model.zeta=0.5",)))
END, EVERY = "time.end=0.3", "output.every=25"
SAVES = 13  # t = 0, 0.025, ..., 0.3


@pytest.fixture(scope="module")
def runs():
    from rodfem.output.directories import prepare_directory
    from rodfem.run import simulate

    root = Path(tempfile.mkdtemp(prefix="rodfem-options-")) if COMM.rank == 0 else None
    root = COMM.bcast(root, root=0)
    dirs = []
    for scene, name, overrides in RUNS:
        out = root / name
        prepare_directory(out, False, COMM)
        simulate(rodfem.scene.load(scene, [END, EVERY, *overrides]), out, COMM, progress=False)
        dirs.append(out)
    yield dirs
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def out(runs):
    """A figure directory beside the runs, removed afterwards."""
    path = runs[0].parent / "figs"
    yield path
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(path, ignore_errors=True)
    COMM.barrier()


def plot(runs, out, *options, capsys):
    """``rodfem plot`` on every rank: its exit code, and (rank 0) the files it listed and what it
    said on stderr."""
    code = main(["plot", *map(str, runs), "--out", str(out), *options])
    captured = capsys.readouterr()
    return code, [Path(line) for line in captured.out.splitlines()], captured.err


def test_only_and_no_animation(runs, out, capsys):
    code, written, _ = plot(runs[:1], out, "--only", "energy,spacetime_theta", capsys=capsys)
    assert code == 0
    if COMM.rank == 0:
        assert written == [out / "energy.png", out / "spacetime_theta.png"]
        assert sorted(out.iterdir()) == sorted(written)
        for path in written:
            assert_figure(path, size=(1200, 900))
    code, written, _ = plot(runs[:1], out / "all", "--no-animation", capsys=capsys)
    assert code == 0
    if COMM.rank == 0:
        assert [p.name for p in written] == ["contact.png", "energy.png", "spacetime_u.png",
                                             "spacetime_theta.png", "spacetime_sigma.png"]


def test_window(runs, out, capsys):
    """The maps and the animation show the saved steps in the window only: 0.1 ≤ t ≤ 0.2 holds
    the saves 0.1, 0.125, ..., 0.2, five frames."""
    code, written, _ = plot(runs[:1], out, "--window", "0.1,0.2", "--only", "rod,contact",
                            capsys=capsys)
    assert code == 0
    if COMM.rank == 0:
        assert [p.name for p in written] == ["contact.png", "rod.gif"]
        assert_figure(out / "contact.png", size=(1200, 900))
        assert len(frames(out / "rod.gif")) == 5
        assert_figure(out / "rod.gif")


def test_curves_in_window():
    from rodfem.post.curves import _in_window

    t = np.linspace(0.0, 1.0, 11)
    keep = _in_window(t, (0.25, 0.55))
    np.testing.assert_array_equal(np.flatnonzero(keep), [2, 3, 4, 5, 6])  # 0.3..0.5 and one beyond
    assert _in_window(t, None).all()


def test_labels(runs, out, capsys):
    from rodfem.post.options import Options
    from rodfem.post.plot import plan
    from rodfem.post.runs import load_run

    code, written, _ = plot(runs[:2], out, "--labels", "ζ = 0.2 ($),ζ = 1",
                            "--only", "energy,spacetime_u", capsys=capsys)
    assert code == 0
    if COMM.rank != 0:
        return
    assert [p.name for p in written] == ["energy.png", "spacetime_u_zeta02.png",
                                         "spacetime_u_zeta1.png"]
    for path in written:
        assert_figure(path, size=(1200, 900))
    loaded = [load_run(r) for r in runs[:2]]
    tasks = plan(loaded, out, Options(labels=("a $x$", "b")))
    assert tasks[0].labels == (r"a \$x\$", "b")  # drawn as written, not as mathtext
    assert [t.labels for t in tasks if t.kind == "rod"] == [("a $x$",), ("b",)]


def test_many_runs_and_a_long_label(runs, out, capsys):
    """Sixty runs overlaid: the legend holds what fits in its rows and counts the rest, the
    panels keep their height. A label of 10,000 characters is cut to a legend's column (it
    overflowed the text's raster), with the per-run figures' titles."""
    from rodfem.post.curves import LEGEND_ROWS, _columns, _fitted, contact_figure, energy_figure
    from rodfem.post.options import Options
    from rodfem.post.plot import LABEL_WIDTH, plan
    from rodfem.post.runs import load_run

    long = "x" * 10_000
    code, written, err = plot(runs[:2], out, "--labels", f"{long},b", "--only", "contact,rod",
                              capsys=capsys)
    assert code == 0, err
    if COMM.rank != 0:
        return
    assert [p.name for p in written] == ["contact.png", "rod_zeta02.gif", "rod_zeta1.gif"]
    assert_figure(out / "contact.png", size=(1200, 900))
    loaded = [load_run(r) for r in runs]
    tasks = plan(loaded[:2], out, Options(labels=(long, "b")))
    assert {len(label) for task in tasks for label in task.labels} == {LABEL_WIDTH, 1}
    many = loaded * 20
    labels = [f"run {i}" for i in range(len(many))]
    handles, names = _fitted([object()] * 62, [*labels, "gap", "contact"], len(many))
    room = LEGEND_ROWS * _columns(names)
    assert len(names) == room == len(handles)
    assert names[-3:] == [f"… and {60 - (room - 3)} more runs", "gap", "contact"]
    assert names[:room - 3] == labels[:room - 3]
    for figure in (contact_figure, energy_figure):
        path = figure(many, labels, out / f"{figure.__name__}.png")
        assert_figure(path, size=(1200, 900))
    assert _fitted([1, 2], ["a", "b"], 2) == ([1, 2], ["a", "b"])  # what fits is left alone


def _has_colour(path: Path, rgb, tolerance: int = 2) -> int:
    image = frames(path)[0].astype(int)
    return int((np.abs(image - np.array(rgb)).max(axis=2) <= tolerance).sum())


def test_colour_by(runs, out, capsys):
    """Coloured by ζ: the sequential map's two ends (ζ = 0.2 and 1) are drawn, tab10's orange
    (the second run's colour in a legend) is not; and the colours follow ζ's order."""
    from rodfem.post import style
    from rodfem.post.runs import load_run

    code, written, _ = plot(runs, out, "--colour-by", "model.zeta", "--only", "contact,energy",
                            capsys=capsys)
    assert code == 0
    code, legend, _ = plot(runs, out / "legend", "--only", "energy", capsys=capsys)
    assert code == 0
    if COMM.rank != 0:
        return
    low, high = (np.rint(np.array(style.SEQUENTIAL(x)[:3]) * 255) for x in (0.0, 1.0))
    orange = (255, 127, 14)
    for path in written:
        assert_figure(path, size=(1200, 900))
        assert _has_colour(path, low) > 100 and _has_colour(path, high) > 100
        assert _has_colour(path, orange, 8) == 0
    assert _has_colour(legend[0], orange) > 100

    colours, mappable = style.run_colours([load_run(r) for r in runs], "model.zeta")
    assert (mappable.norm.vmin, mappable.norm.vmax) == (0.2, 1.0)
    assert np.allclose(colours[0], style.SEQUENTIAL(0.0)) and np.allclose(colours[1],
                                                                           style.SEQUENTIAL(1.0))
    assert np.allclose(colours[2], style.SEQUENTIAL(0.375))  # (0.5 − 0.2) / 0.8


def test_out_refuses_to_replace_without_force(runs, out, capsys):
    code, first, _ = plot(runs[:1], out, "--only", "contact,energy", capsys=capsys)
    assert code == 0
    if COMM.rank == 0:
        (out / "notes.txt").write_text("mine")
        before = {p: p.read_bytes() for p in first}
        Image.new("RGB", (4, 4)).save(out / "energy.png")  # an energy.png of the user's
        before[out / "energy.png"] = (out / "energy.png").read_bytes()
    COMM.barrier()
    code, written, err = plot(runs[:1], out, "--only", "contact,energy", capsys=capsys)
    assert code == 2
    if COMM.rank == 0:
        assert written == [] and err.count("\n") == 1 and "--force" in err
        assert str(out / "contact.png") in err and "Traceback" not in err
        assert all(p.read_bytes() == data for p, data in before.items())  # untouched
    code, written, _ = plot(runs[:1], out, "--only", "contact,energy", "--force", capsys=capsys)
    assert code == 0
    if COMM.rank == 0:
        assert written == first
        assert_figure(out / "energy.png", size=(1200, 900))  # the user's 4×4 image replaced
        assert (out / "notes.txt").read_text() == "mine"  # other files are never touched
        assert sorted(p.name for p in out.iterdir()) == ["contact.png", "energy.png",
                                                         "notes.txt"]


@pytest.mark.parametrize("inside", [False, True], ids=["the file", "inside the file"])
def test_out_at_a_file_is_a_mistake(runs, out, inside, capsys):
    """--out naming a file (or a path through one) is bad input, exit 2, the file untouched."""
    if COMM.rank == 0:
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    COMM.barrier()
    target = out / "notes.txt" / "figs" if inside else out / "notes.txt"
    code, written, err = plot(runs[:1], target, "--only", "energy", capsys=capsys)
    assert code == 2
    if COMM.rank == 0:
        assert written == [] and err.startswith("rodfem: error: ") and err.count("\n") == 1
        assert f"{out / 'notes.txt'} is a file, not a directory" in err, err
        assert (out / "notes.txt").read_text() == "mine"
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_default_directory_is_drawn_again(runs, capsys):
    """A run's own figures/ is redrawn from its files without --force."""
    for _ in range(2):
        assert main(["plot", str(runs[2]), "--only", "energy"]) == 0
    capsys.readouterr()
    COMM.barrier()
    if COMM.rank == 0:
        assert_figure(runs[2] / "figures" / "energy.png", size=(1200, 900))
        shutil.rmtree(runs[2] / "figures")


def test_an_overlay_does_not_replace_a_runs_own_figures(runs, capsys):
    """Several runs drawn into the first one's figures/ (no --out) do not replace the figures it
    holds without --force."""
    assert main(["plot", str(runs[1]), "--only", "contact"]) == 0
    capsys.readouterr()
    own = runs[1] / "figures" / "contact.png"
    before = own.read_bytes() if COMM.rank == 0 else None
    code = main(["plot", str(runs[1]), str(runs[0]), "--only", "contact"])
    err = capsys.readouterr().err
    assert code == 2
    if COMM.rank == 0:
        assert own.read_bytes() == before and "--force" in err and err.count("\n") == 1
    assert main(["plot", str(runs[1]), str(runs[0]), "--only", "contact", "--force"]) == 0
    capsys.readouterr()
    COMM.barrier()
    if COMM.rank == 0:
        assert own.read_bytes() != before
        shutil.rmtree(runs[1] / "figures")
    COMM.barrier()


@pytest.mark.parametrize("options, message", [
    (["--only", "contact,energyy"], "the figures are contact, energy, spacetime"),
    (["--only", ""], "comma-separated"),
    (["--window", "2,1"], "0 <= T0 < T1"),
    (["--window", "0,nan"], "finite"),
    (["--window", "0.1"], "two times"),
    (["--window", "5,6"], "after the runs end (t = 0.3)"),
    (["--labels", "a,b,c"], "3 labels for 2 runs"),
    (["--labels", "a,,"], "without empty items"),
    (["--colour-by", "model.zetta"], "has no such value"),
    (["--colour-by", "obstacle.kind"], "is not a finite number"),
    (["--colour-by", "model.k"], "every run has model.k = 1; colour by a value in which"),
    (["--only", "rod", "--no-animation"], "nothing to draw"),
])
def test_bad_values(runs, out, options, message, capsys):
    code, written, err = plot(runs[:2], out, *options, capsys=capsys)
    assert code == 2
    if COMM.rank == 0:
        assert written == [] and err.startswith("rodfem: error: ") and err.count("\n") == 1
        assert message in err and "Traceback" not in err, err
        assert not out.exists(), "nothing is written"


def test_energy_title_names_figure_5_for_experiments_1_and_2_only(runs):
    if COMM.rank != 0:
        return
    from rodfem.post.curves import energy_title
    from rodfem.post.runs import load_run

    one, two, other = (load_run(r) for r in runs)
    assert (one.experiment, two.experiment, other.experiment) == (1, 2, None)
    four = dataclasses.replace(one, scene={**one.scene, "model.zeta": 1.0, "model.k": 100.0})
    assert four.experiment == 4
    shows = r"$\ln(\hat{E} + 0.01)$ against $t$"
    assert energy_title([one, two]) == shows + ": the paper's Figure 5 (experiments 1 and 2)"
    assert energy_title([two]) == shows + ": the paper's Figure 5 (experiment 2)"
    assert energy_title([four]) == shows  # paper4: no figure in the paper
    assert energy_title([one, other]) == shows


def test_theta_is_centred_on_the_reference_temperature():
    from rodfem.post.animation import _theta_range
    from rodfem.post.spacetime import MAPS

    assert MAPS["theta"][3] is True  # diverging, centred on θ = 0
    assert _theta_range(np.array([[-17.0, 10.0]])) == [-17.0, 17.0]
    assert _theta_range(np.array([[2.0, 10.0]])) == [-10.0, 10.0]


def test_obstacle_gives_way(runs, out):
    """paper1 reaches the obstacle from t ≈ 0.19: the block's face follows the end there (its
    support stays), the hatching stays between face and support, and the block never closes."""
    if COMM.rank != 0:
        return
    import pyvista as pv

    from rodfem.post import backend
    from rodfem.post.animation import HATCHES, _Obstacle, rod_animation
    from rodfem.post.runs import load_run

    backend.off_screen()
    plotter = pv.Plotter(off_screen=True)
    obstacle = _Obstacle(plotter, rest=1.1, back=1.35)
    obstacle.move(1.2, "red")
    xs = np.unique(obstacle.block.points[:, 0])
    np.testing.assert_allclose(xs, [1.2, 1.35], rtol=0, atol=1e-6)  # float32 points
    hatch = obstacle.hatch.points[:, 0]
    assert hatch.size == 2 * HATCHES and np.all((hatch > 1.2) & (hatch < 1.35))
    np.testing.assert_allclose(obstacle.face.points[:, 0], 1.2, rtol=0, atol=1e-6)
    plotter.close()

    run = load_run(runs[0])
    assert (run.fields.u[:, -1] > run.gap).any()
    assert_animation(rod_animation(run, "paper1", out.parent / "rod.gif"), SAVES)


def test_drawing_processes(runs, out):
    """The pool draws what it is given, in order, and hands back a worker's exception."""
    if COMM.rank != 0:
        return
    from rodfem.post.plot import prepare
    from rodfem.post.pool import Drawer
    from rodfem.post.tasks import Task

    tasks = prepare(runs[:1], out, force=True)[:3]
    bad = Task("spacetime", tasks[0].runs, tasks[0].labels, out / "bad.png", field="nope")
    with Drawer(2) as drawer:
        futures = drawer.submit([*tasks, bad])
        assert [f.result() for f in futures[:3]] == [t.path for t in tasks]
        with pytest.raises(KeyError, match="nope"):
            futures[3].result()
    for task in tasks:
        assert_figure(task.path, size=(1200, 900))
    assert not (out / "bad.png").exists()


def test_the_command_line_does_not_load_the_figures():
    """`rodfem run` pays nothing for the figures: building the parser imports no VTK,
    matplotlib or pyvista; and its help for --only names every kind of figure."""
    import subprocess
    import sys

    from rodfem.post.fields import FUNCTIONS
    from rodfem.post.options import KINDS

    code = ("import sys, rodfem.cli; rodfem.cli.parser(); "
            "print(sorted(m for m in ('pyvista', 'matplotlib', 'vtkmodules') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"
    from rodfem.cli import parser

    only = next(a for a in parser()._subparsers._group_actions[0].choices["plot"]._actions
                if a.dest == "only")
    for kind in KINDS:
        if not kind.startswith("spacetime_"):
            assert kind in only.help
    for name in FUNCTIONS:
        assert name in only.help
