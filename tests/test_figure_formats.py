"""Every figure rodfem draws, by every command that draws one and by the ``.plot()`` of the
Python API, in each format (PNG, PDF, SVG): the file is what its name says and not blank, no text
of a matplotlib figure reaches outside its canvas (from the renderer's extents), and every axis
label of a quantity with a dimension names its unit. The space-time map of ``stiff`` reaches the
peak |σ(1)| of the run's history, which its saved frames miss. The figures of verify,
work-precision and stability are vectors in PDF and SVG (text and paths, no picture). The run,
sweep, fit, sensitivity, steady, verify and stability directories are made once, tiny, and shared.
"""

import json
import math
import re
import shutil
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from mpi4py import MPI
from PIL import Image

import rodfem
from conftest import assert_refused, serial_only
from rodfem.cli import main
from rodfem.output import figures

pytestmark = serial_only  # the commands draw on this process; their runs are tiny

FORMATS = figures.FORMATS
# Symbols of quantities with a dimension (rodfem.output.names): an axis label holding one names
# its unit, "[$...$]" (θ, ζ, ε, k, counts and fractions have none).
DIMENSIONAL = (r"$t$", r"$t ", "$x$", "u(", "u_t", r"\sigma", r"\hat{E}", r"\Delta t", "$g$",
               "$p$", "$T$", "$h$", "wall time")
UNIT = re.compile(r"\[\$[^$]+\$\]")
SWEEP = ('scene = "paper1"\n[set]\n"time.end" = 0.3\n"mesh.cells" = 8\n"time.dt" = 0.002\n'
         '[measures]\npeak_stress = { column = "sigma_1", reduce = "min" }\n'
         '[grid]\n"model.zeta" = [0.2, 1.0]\n"obstacle.epsilon" = [0.001, 0.01]\n')
FIT = ('scene = "paper1"\ndata = "data.csv"\n[set]\n"mesh.cells" = 8\n"time.dt" = 0.01\n'
       '"time.end" = 0.3\n"solver.method" = "direct"\n[parameters]\n"model.zeta" = [0.1, 1.0]\n'
       '"model.k" = [0.5, 5.0]\n')
SENSITIVITY = ('scene = "paper1"\nsamples = 4\noutputs = ["u_1_final", "peak_stress"]\n[set]\n'
               '"mesh.cells" = 8\n"time.end" = 0.2\n"solver.method" = "direct"\n'
               '[measures]\npeak_stress = { column = "sigma_1", reduce = "min" }\n'
               '[parameters]\n"model.zeta" = [0.5, 1.0]\n"model.k" = [0.5, 2.0]\n')
# A scene file of verify's (its measures have a figure of their own): a soft obstacle, short.
SOFT = ('[model]\na = 0.017\nb = 1.0\nzeta = 0.2\nk = 1.0\ntheta_A = 10.0\n'
        '[obstacle]\nepsilon = 1.0\ngap = 0.1\n[initial]\n'
        'theta0 = "theta_A*(cos(2*pi*x) - sin(pi*x/2))"\nu0 = "0"\nu1 = "20*x*(x - 1)**2"\n'
        '[mesh]\ncells = 8\n[time]\ndt = 0.01\nend = 0.2\n[solver]\nmethod = "direct"\n')
# The figures drawn by verify, work-precision and stability (once with VTK, as pictures).
STUDIES = ("orders_", "measures_", "workprecision_", "stability_")


@pytest.fixture(scope="module")
def drawn():
    """Every matplotlib figure saved during the module, by file: rodfem.output.figures.save,
    which every matplotlib figure of rodfem goes through, recorded."""
    found = {}
    original = figures.save

    def keep(fig, path, dpi=100):
        written = original(fig, path, dpi)
        found[Path(path).resolve()] = fig
        return written

    figures.save = keep
    yield found
    figures.save = original


@pytest.fixture(scope="module")
def made(tmp_path_factory, drawn):
    """The directories of every command that draws, tiny, each drawn in every format."""
    root = tmp_path_factory.mktemp("formats")
    files = {f: [] for f in FORMATS}

    def command(*args):
        assert main([*map(str, args)]) == 0, args

    command("run", "stiff", "--out", root / "stiff", "--quiet")
    (root / "sweep.toml").write_text(SWEEP)
    command("sweep", root / "sweep.toml", "--out", root / "sweep", "--histories", "--quiet")
    truth = rodfem.simulate("paper1", {"mesh.cells": 8, "time.dt": 0.01, "time.end": 0.3,
                                       "model.zeta": 0.3, "model.k": 2.0},
                            comm=MPI.COMM_SELF).history
    (root / "fit").mkdir()
    (root / "fit" / "fit.toml").write_text(FIT)
    (root / "fit" / "data.csv").write_text("t,u_1\n" + "".join(
        f"{float(t)!r},{float(u)!r}\n" for t, u in zip(truth["t"][1::3], truth["u_1"][1::3],
                                                     strict=True)))
    (root / "sensitivity.toml").write_text(SENSITIVITY)
    (root / "soft.toml").write_text(SOFT)
    command("verify", "--quick", "--scenes", f"{root / 'soft.toml'},no-contact", "--out",
            root / "verify")
    work_precision(root / "verify", root / "wp")
    command("stability", "--out", root / "stability", "--dt", "0.01", "--epsilon", "0.01",
            "--zeta", "1", "--a", "0.1", "--end", "0.02", "--methods", "direct")
    from rodfem.post.stability import plot_stability
    from rodfem.post.verify import plot_orders
    from rodfem.post.workprecision import plot_work_precision

    (root / "api").mkdir()
    result = rodfem.load(root / "stiff")
    sweep = rodfem.load_sweep(root / "sweep")
    for f in FORMATS:
        out = root / f"plots-{f}"
        command("plot", root / "stiff", "--out", out, "--no-animation", "--format", f)
        command("plot", root / "sweep", "--out", out, "--measures", "peak_stress,u_1_final",
                "--format", f)
        command("plot", root / "sweep", "--out", out / "overlay", "--overlay", "--format", f)
        command("fit", root / "fit" / "fit.toml", "--out", root / f"fit-{f}", "--quiet",
                "--format", f)
        command("sensitivity", root / "sensitivity.toml", "--out", root / f"sensitivity-{f}",
                "--quiet", "--format", f)
        command("steady", "barber", "--out", root / f"steady-{f}", "--set", "mesh.cells=20",
                "--continue", "obstacle.temperature=0:30:16", "--format", f)
        files[f] += [p for p in sorted(out.rglob(f"*.{f}"))]
        files[f] += [root / f"fit-{f}" / f"fit.{f}", root / f"sensitivity-{f}" / f"sensitivity.{f}",
                     root / f"steady-{f}" / "figures" / f"branches.{f}"]
        files[f] += plot_orders(root / "verify", f) + plot_stability(root / "stability", format=f)
        files[f] += plot_work_precision(root / "wp", f)
        result.plot(path=root / "api" / "result", format=f)
        sweep.plot("peak_stress", path=root / "api" / "sweep", format=f)
        files[f] += [root / "api" / f"result.{f}", root / "api" / f"sweep.{f}"]
    yield root, files
    shutil.rmtree(root, ignore_errors=True)


def work_precision(verified: Path, out: Path) -> None:
    """A workprecision.json made of verify's runs of no-contact (each with its wall time and
    errors), once as they are and once as the impact's, a mass per time scheme: the figures of
    ``rodfem work-precision`` without its runs."""
    data = json.loads((verified / "orders.json").read_text())
    points = [p for p in data["points"] if p["scene"] == "no-contact"]
    masses = {"paper": "lumped", "crank-nicolson": "dispersion-free"}
    impact = [{**p, "scene": "impact", "refined": "h=dt", "mass": masses[p["scheme"]]}
              for p in points]
    target = sorted(p["u1_max"] for p in points)[len(points) // 2]
    out.mkdir()
    (out / "workprecision.json").write_text(json.dumps(
        {"points": points + impact, "end": data["plan"]["end"], "target": target,
         "target_scenes": ["no-contact"], "plan": {"impact_end": 3.0}}))


def assert_not_blank(path: Path) -> None:
    """PNG: more than one colour; PDF: a page with its text's fonts (where matplotlib drew text)
    or an image; SVG: parsed, with drawn paths and (matplotlib's) text groups or an image."""
    data = path.read_bytes()
    if path.suffix == ".png":
        with Image.open(path) as image:
            assert image.format == "PNG"
            pixels = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(np.int32)
        colours = (pixels[:, 0] << 16) | (pixels[:, 1] << 8) | pixels[:, 2]  # one int each
        assert np.unique(colours).size > 16, f"{path.name} is blank"
    elif path.suffix == ".pdf":
        assert data.startswith(b"%PDF-") and data.rstrip().endswith(b"%%EOF"), path.name
        assert b"/Type /Page" in data and len(data) > 5_000, path.name
        assert b"/Font" in data or b"/Subtype /Image" in data, path.name
    else:
        root = ElementTree.fromstring(data)
        assert root.tag.endswith("svg"), path.name
        ids = [e.get("id", "") for e in root.iter()]
        tags = [e.tag.rsplit("}", 1)[-1] for e in root.iter()]
        if "image" not in tags:  # drawn as vectors: text (as glyph paths) and lines
            assert any(i.startswith("text_") for i in ids) and tags.count("path") > 5, path.name


def test_every_figure_in_every_format_is_written_and_not_blank(made):
    _, files = made
    names = {f: sorted(p.name.rsplit(".", 1)[0] for p in files[f]) for f in FORMATS}
    assert names["png"] == names["pdf"] == names["svg"]  # the same figures in each format
    expected = {"contact", "energy", "spacetime_u", "spacetime_theta", "spacetime_sigma",
                "sweep_peak_stress", "sweep_peak_stress_lines", "sweep_scenes_contact",
                "sweep_scenes_energy", "fit", "sensitivity", "branches",
                "orders_no-contact", "orders_soft", "measures_soft", "workprecision_no-contact",
                "workprecision_impact", "stability_direct", "result", "sweep"}
    assert expected <= set(names["png"]), expected - set(names["png"])
    for f in FORMATS:
        for path in files[f]:
            assert path.suffix == f".{f}"
            assert_not_blank(path)
    # a vector file holds its text as text or glyph paths, not one picture of the figure
    contact = next(p for p in files["svg"] if p.name == "contact.svg")
    assert b"<image" not in contact.read_bytes()


def test_the_study_figures_are_vectors(made, drawn):
    """Verify's, work-precision's and stability's figures: drawn with matplotlib, in PDF and
    SVG their text is text (fonts, glyph groups) and their lines paths, no picture of the page."""
    _, files = made
    studies = {f: [p for p in files[f] if p.name.startswith(STUDIES)] for f in FORMATS}
    assert len(studies["png"]) == 6 and {p.stem for p in studies["pdf"]} == \
        {p.stem for p in studies["svg"]} == {p.stem for p in studies["png"]}
    for path in (*studies["png"], *studies["pdf"], *studies["svg"]):
        assert path.resolve() in drawn, path.name  # through matplotlib and figures.save
    for path in studies["pdf"]:
        data = path.read_bytes()
        assert b"/Font" in data and b"/Subtype /Image" not in data, path.name
    for path in studies["svg"]:
        data = path.read_bytes()
        root = ElementTree.fromstring(data)
        tags = [e.tag.rsplit("}", 1)[-1] for e in root.iter()]
        assert "image" not in tags and tags.count("path") > 20, path.name
        # each title and axis label drawn as a text (glyphs, after a comment that names it)
        written = set(re.findall(r"<!-- (.*?) -->", data.decode(), flags=re.S))
        fig = drawn[path.resolve()]
        texts = [t for ax in fig.axes for t in (ax.get_title(), ax.get_xlabel(), ax.get_ylabel())
                 if t] + [t.get_text() for t in fig.texts if t.get_text()]
        lines = {line for text in texts for line in text.split("\n")}  # a comment per line
        assert len(texts) >= 3 and lines <= written, (path.name, lines - written)


def test_no_text_outside_the_canvas(made, drawn):
    _, files = made
    checked = 0
    for f in FORMATS:
        for path in files[f]:
            fig = drawn[path.resolve()]  # every figure is matplotlib's
            assert figures.outside(fig) == [], (path.name, [t.get_text() for t in
                                                             figures.outside(fig)])
            checked += 1
    assert checked == sum(map(len, files.values())) >= 3 * 20


def test_every_dimensional_axis_label_names_its_unit(made, drawn):
    _, files = made
    labels, studies = 0, 0
    for path in files["png"]:
        fig = drawn[path.resolve()]
        for ax in fig.axes:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                if any(symbol in label for symbol in DIMENSIONAL):
                    assert UNIT.search(label), (path.name, label)
                    labels += 1
                    studies += path.name.startswith(STUDIES)
    assert labels > 20 and studies >= 30  # orders and measures: both axes of every panel


def test_the_checks_can_fail():
    """A text placed beyond the edge is found; a title too long for its figure is set smaller
    until it fits; a label without its unit is told from one with it."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    fig.text(1.05, 0.5, "beyond the right edge")
    assert len(figures.outside(fig)) == 1
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.add_subplot()
    ax.set_title("a title far too long for a figure four inches wide: model.k = 2, zeta = 0.3")
    assert figures.outside(fig)
    figures.fit_texts(fig)
    assert figures.outside(fig) == []
    assert not UNIT.search("$\\sigma(1, t)$") and UNIT.search("$\\sigma(1, t)$ [$E$]")


def test_wide_tick_labels_move_the_panels_in_rather_than_shrink_the_label():
    """A narrow range's tick labels (4.8600 … 4.8450: the energy of a run stopped after two
    steps) pushed the y label of a figure with fixed margins off the canvas, which then set it in
    6-point type, and the last t tick too: the axes move in instead, the texts keep their size."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 9), dpi=100)
    grid = fig.add_gridspec(1, 1, left=0.075, right=0.98, bottom=0.15, top=0.91)
    ax = fig.add_subplot(grid[0, 0])
    ax.plot([0.0, 0.001], [4.8615, 4.8437])
    ax.set_xlim(0.0, 0.001)
    ax.set_ylabel(r"$\ln(\hat{E} + 0.01)$, $\hat{E}$ in [$EL$]", fontsize=15)
    ax.tick_params(labelsize=12)
    assert figures.outside(fig)  # as drawn: beyond the left and right edges
    sizes = [t.get_fontsize() for t in (ax.yaxis.label, *ax.get_xticklabels())]
    assert figures.fit_texts(fig)
    assert figures.outside(fig) == []
    assert [t.get_fontsize() for t in (ax.yaxis.label, *ax.get_xticklabels())] == sizes
    assert ax.get_position().x0 > 0.075


@pytest.mark.parametrize("fmt", figures.FORMATS)
def test_the_same_figure_drawn_twice_is_the_same_bytes(fmt, tmp_path):
    """A resumed study draws its figure again: the file is the one an unstopped study writes
    (SVG's clip paths and markers were given random ids, PDF and SVG a date)."""
    from matplotlib.figure import Figure

    def drawn(name):
        fig = Figure(figsize=(4, 3), layout="constrained")
        ax = fig.add_subplot()
        ax.plot([0, 1, 2], [1, 0, 2], "o-")
        ax.set_title("twice")
        return figures.save(fig, tmp_path / f"{name}.{fmt}").read_bytes()

    assert drawn("a") == drawn("b")


def test_the_stiff_map_reaches_the_peak_stress_of_the_history(made, drawn):
    """The saved frames (every 0.05) miss the impact: the colour range of σ's map is that of
    the history, whose peak |σ(1)| it reaches to 1 %, and the figure says the frames miss it."""
    from matplotlib.collections import QuadMesh

    from rodfem.post.runs import load_run
    from rodfem.post.spacetime import colour_range

    root, _ = made
    run = load_run(root / "stiff")
    peak = float(np.max(np.abs(run.history.sigma_1)))
    saved = float(np.max(np.abs(run.fields.sigma)))
    assert saved < 0.5 * peak  # what the frames show of the impact
    limits = colour_range(run.fields, "sigma", run.history, run.gap)
    assert abs(max(abs(limits.lo), abs(limits.hi)) - peak) <= 0.01 * peak
    for f in FORMATS:
        fig = drawn[(root / f"plots-{f}" / f"spacetime_sigma.{f}").resolve()]
        mesh = next(c for ax in fig.axes for c in ax.collections if isinstance(c, QuadMesh))
        assert abs(max(abs(mesh.norm.vmin), abs(mesh.norm.vmax)) - peak) <= 0.01 * peak
        assert np.max(np.abs(mesh.get_array())) == pytest.approx(saved, rel=1e-12)
        assert any("miss the extreme" in t.get_text() for t in fig.texts)


def test_the_sensitivity_chart_stays_within_0_and_1(made, drawn):
    """Bars and error bars of Sobol indices within [0, 1], the parameters' ranges under them,
    the panels named in words."""
    root, _ = made
    fig = drawn[(root / "sensitivity-png" / "sensitivity.png").resolve()]
    for ax in fig.axes:
        assert ax.get_ylim() == (0.0, 1.05)
        for bar in ax.patches:
            assert 0.0 <= bar.get_height() <= 1.0
        bars = [c for c in ax.collections if hasattr(c, "get_segments")]  # the error bars
        assert bars
        for segment in (s for c in bars for s in c.get_segments()):
            assert np.all(segment[:, 1] >= 0.0) and np.all(segment[:, 1] <= 1.0), segment
        ticks = [t.get_text() for t in ax.get_xticklabels()]
        assert any("[0.5, 1]" in t for t in ticks) and any("[0.5, 2]" in t for t in ticks)
    titles = [ax.get_title() for ax in fig.axes]
    assert any("peak_stress: min" in t for t in titles) and "final $u(1)$" in titles


def test_the_branch_figure_explains_its_colours_and_shows_the_pressure(made, drawn):
    root, _ = made
    fig = drawn[(root / "steady-png" / "figures" / "branches.png").resolve()]
    legend = [t.get_text() for ax in fig.axes if ax.get_legend() for t in
              ax.get_legend().get_texts()]
    assert {"in contact", "free", "stable", "unstable"} <= set(legend)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert any("contact pressure" in label for label in labels)
    pressure = next(ax for ax in fig.axes if "contact pressure" in ax.get_ylabel())
    values = np.concatenate([line.get_ydata() for line in pressure.lines])
    assert np.ptp(values) > 0  # not flat: the states in contact differ in pressure


def test_the_scene_chooses_the_format_and_the_command_line_overrides_it(made, capsys):
    root, _ = made
    out = root / "scene-format"
    assert main(["run", "paper1", "--out", str(out), "--set", "time.end=0.05", "--set",
                 "mesh.cells=8", "--set", "output.figure_format=svg", "--quiet"]) == 0
    assert main(["plot", str(out), "--only", "energy"]) == 0
    assert (out / "figures" / "energy.svg").is_file()
    assert main(["plot", str(out), "--only", "energy", "--format", "pdf"]) == 0
    assert (out / "figures" / "energy.pdf").is_file()
    capsys.readouterr()
    with pytest.raises(SystemExit) as stopped:  # the argument parser's one line
        main(["plot", str(out), "--format", "jpg"])
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and err.count("\n") == 1
    # (argparse quotes the choices up to Python 3.11, not from 3.13 on)
    assert re.search(r"--format: invalid choice: 'jpg' \(choose from '?png'?, '?pdf'?, '?svg'?\)",
                     err), err
    assert_refused(["run", "paper1", "--out", str(root / "bad"), "--set",
                    "output.figure_format=jpg"], root / "bad",
                   'output.figure_format: must be one of "png" | "pdf" | "svg"', capsys)
    with pytest.raises(figures.FormatError, match="the formats are png, pdf, svg"):
        rodfem.load(out).plot(path=root / "api-bad", format="jpg")


def test_a_map_says_when_its_frames_are_sparser_than_a_contact():
    """Frames every 0.1 around a contact of 0.02 that the history holds: the colour range
    reaches the history's extreme and the notes say both what the frames miss and that they
    are sparser than the contact; frames that hold the extreme get neither note."""
    from rodfem.output.readers import Fields, History
    from rodfem.post.spacetime import colour_range

    x = np.linspace(0.0, 1.0, 5)
    t = np.arange(0.0, 0.55, 0.1)
    sigma = np.tile(np.linspace(-1.0, 1.0, 4), (t.size, 1))  # within [-1, 1] at every frame
    fields = Fields(x=x, t=t, x_cells=0.5 * (x[1:] + x[:-1]), sigma=sigma)
    steps = np.arange(0.0, 0.5001, 0.01)
    u_1 = np.where((steps > 0.225) & (steps < 0.255), 0.02, 0.0)  # in contact for 0.02
    sigma_1 = np.where(u_1 > 0.01, -4.0, 0.0)
    names = ("t", "u_1", "sigma_1")
    history = History(np.column_stack([steps, u_1, sigma_1]), names)
    limits = colour_range(fields, "sigma", history, gap=0.01)
    assert (limits.lo, limits.hi) == (-4.0, 4.0) and len(limits.notes) == 2
    assert "miss the extreme" in limits.notes[0] and "= -4" in limits.notes[0]
    assert "shortest contact (0.02)" in limits.notes[1]
    held = colour_range(fields, "sigma", History(np.column_stack([steps, 0 * u_1, 0 * u_1]),
                                                  names), gap=0.01)
    assert (held.lo, held.hi) == (-1.0, 1.0) and held.notes == []
    alone = colour_range(fields, "sigma")
    assert (alone.lo, alone.hi) == (-1.0, 1.0) and alone.notes == []


def _stopped_copy(directory: Path, to: Path, drawn: tuple[str, ...]) -> Path:
    """A copy of a complete study directory as a stop before its end leaves it: the files
    ``drawn`` at the end gone, the directory marked interrupted."""
    copy = Path(shutil.copytree(directory, to))
    for name in drawn:
        (copy / name).unlink()
    marker = json.loads((copy / "rodfem.json").read_text())
    (copy / "rodfem.json").write_text(json.dumps({**marker, "status": "interrupted"}))
    return copy


def test_a_resumed_study_draws_its_figure_in_the_format_asked(made, capsys):
    """``rodfem resume --format``: a fit's and a sensitivity study's figure in that format, the
    results those of the study as it was first written; ``rodfem plot`` of the study names the
    figure by the suffix it has; a run resumed with --format is refused, unchanged."""
    root, _ = made
    fit = _stopped_copy(root / "fit-png", root / "resumed-fit", ("fit.json", "fit.png"))
    assert main(["resume", str(fit), "--format", "svg", "--quiet"]) == 0
    assert (fit / "fit.json").read_bytes() == (root / "fit-png" / "fit.json").read_bytes()
    assert_not_blank(fit / "fit.svg") and not (fit / "fit.png").exists()
    sensitivity = _stopped_copy(root / "sensitivity-png", root / "resumed-sensitivity",
                                ("sensitivity.csv", "sensitivity.png"))
    assert main(["resume", str(sensitivity), "--format", "pdf", "--quiet"]) == 0
    assert (sensitivity / "sensitivity.csv").read_bytes() == \
        (root / "sensitivity-png" / "sensitivity.csv").read_bytes()
    assert_not_blank(sensitivity / "sensitivity.pdf")
    assert not (sensitivity / "sensitivity.png").exists()
    capsys.readouterr()
    assert main(["plot", str(fit)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{fit} is a fit study, drawn in {fit / 'fit.svg'};" in err
    files = lambda d: {p.name: p.read_bytes() for p in d.iterdir()  # noqa: E731
                       if p.is_file() and p.name != "rodfem.lock"}  # the lock: taken, let go
    before = files(root / "stiff")
    assert main(["resume", str(root / "stiff"), "--format", "pdf"]) == 2
    err = capsys.readouterr().err
    assert err == (f"rodfem: error: --format: a resumed run draws no figure (a fit or a "
                   f"sensitivity study does); 'rodfem plot {root / 'stiff'} --format pdf' "
                   "draws its figures\n"), err
    assert files(root / "stiff") == before


def test_a_study_resumed_without_format_keeps_the_one_it_was_started_with(made):
    """A fit started with --format svg and a sensitivity study with --format pdf, stopped and
    resumed with no --format: the figure is the one the unstopped study drew, byte for byte
    (the format is in study.json and sensitivity.json), and no figure of another format."""
    root, _ = made
    fit = _stopped_copy(root / "fit-svg", root / "kept-fit", ("fit.json", "fit.svg"))
    assert main(["resume", str(fit), "--quiet"]) == 0
    assert (fit / "fit.svg").read_bytes() == (root / "fit-svg" / "fit.svg").read_bytes()
    assert not (fit / "fit.png").exists() and not (fit / "fit.pdf").exists()
    sensitivity = _stopped_copy(root / "sensitivity-pdf", root / "kept-sensitivity",
                                ("sensitivity.csv", "sensitivity.pdf"))
    assert main(["resume", str(sensitivity), "--quiet"]) == 0
    assert (sensitivity / "sensitivity.pdf").read_bytes() == \
        (root / "sensitivity-pdf" / "sensitivity.pdf").read_bytes()
    assert not (sensitivity / "sensitivity.png").exists()


def test_the_paper_draws_its_still_figures_in_the_format_asked(made):
    """``rodfem paper --format pdf``: each experiment's still figures (queued as the paper
    queues them, drawn here) are PDF, its animation GIF; the parser takes the option."""
    from rodfem.cli import parser
    from rodfem.post.pool import Drawer
    from rodfem.studies.verification import paper

    root, _ = made
    assert parser().parse_args(["paper", "--format", "pdf"]).format == "pdf"
    run = Path(shutil.copytree(root / "stiff", root / "paper-stiff"))
    with Drawer(0) as drawer:
        futures = paper._figures(drawer, [run], None, "pdf")
        drawer.work()
    written = paper._drawn(futures)
    assert {p.suffix for p in written} == {".pdf", ".gif"}, written
    assert {p.name for p in written if p.suffix == ".pdf"} >= {"contact.pdf", "energy.pdf"}
    for path in written:
        if path.suffix == ".pdf":
            assert_not_blank(path)


def test_a_text_that_cannot_fit_is_given_up_once_it_is_smallest(monkeypatch):
    """Mathtext too wide for its canvas even at the smallest size (it is never cut): fitting
    stops as soon as a draw changes nothing, not after a fixed number of draws."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1.5, 1.5), layout="constrained")
    ax = fig.add_subplot()
    ax.set_title("$" + r"\hat{E}_{\max} + " * 12 + "1$")
    size, draws = ax.title.get_fontsize(), []
    measured = figures.outside
    monkeypatch.setattr(figures, "outside", lambda f: draws.append(1) or measured(f))
    assert figures.fit_texts(fig) is False
    assert ax.title.get_fontsize() == figures.SMALLEST
    shrinks = math.ceil(math.log(figures.SMALLEST / size) / math.log(0.88))
    assert len(draws) <= shrinks + 2
