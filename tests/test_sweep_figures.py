"""What the sweep figures and the overlays say, read from their matplotlib objects: axes named by
symbols and units, log axes where the design or the values call for them (never over zero),
the informative measures by default and --measures to choose, a declared measure's column drawn,
a sweep's scenes overlaid (--overlay), and legends of runs naming the law where it differs.
Bad options: exit 2, one line, nothing written."""

import csv
import json

import numpy as np
import pytest
from mpi4py import MPI

import rodfem.post.curves as curves
import rodfem.post.sweep as sweep_figures
from conftest import assert_refused, serial_only
from rodfem.output import names
from rodfem.output.measures import NAMES
from rodfem.output.readers import HISTORY_COLUMNS, History
from rodfem.output.results import HISTORIES
from rodfem.post import choice, scenes
from rodfem.post.runs import PlotError, Run, legend_labels
from rodfem.post.sweep import plot_sweep
from rodfem.studies.sweep.run import run_sweep

pytestmark = serial_only  # each sweep runs on this process alone (MPI.COMM_SELF)

BASE = 'scene = "paper1"\n[set]\n"time.end" = 0.3\n"mesh.cells" = 20\n"time.dt" = 2e-4\n'
LOG = '[grid]\n"obstacle.epsilon" = {logspace = [1e-4, 1e-3, 3]}\n'
LINEAR = '[grid]\n"model.zeta" = [0.1, 0.2, 0.5]\n'
TWO = '[grid]\n"model.zeta" = [0.2, 1.0]\n"obstacle.epsilon" = {logspace = [1e-4, 1e-1, 4]}\n'
SAMPLE = ('[sample]\nmethod = "random"\ncount = 4\nseed = 1\n[sample.ranges]\n'
          '"obstacle.epsilon" = {log = [1e-4, 1e-3]}\n"model.zeta" = [0.2, 1.0]\n')


def sweep(tmp_path, axes: str, name: str = "sweep", histories: bool = False):
    spec = tmp_path / f"{name}.toml"
    spec.write_text(BASE + axes, encoding="utf-8")
    out = tmp_path / name
    run_sweep(spec, out=out, comm=MPI.COMM_SELF, histories=histories)
    return out


@pytest.fixture
def drawn(monkeypatch):
    """The figures drawn, by file name, as matplotlib figures (saved as ever)."""
    figures = {}
    for module in (sweep_figures, curves):
        save = module._save

        def keep(fig, path, save=save):
            figures[path.name] = fig
            return save(fig, path)

        monkeypatch.setattr(module, "_save", keep)
    return figures


def test_logarithmic():
    """Log by design or over two decades; never with zero or a negative value."""
    assert choice.logarithmic(np.array([1.0, 100.0]))
    assert not choice.logarithmic(np.array([1.0, 99.0]))
    assert choice.logarithmic(np.array([1.0, 2.0]), by_design=True)
    assert not choice.logarithmic(np.array([0.0, 1.0, 1000.0]), by_design=True)
    assert not choice.logarithmic(np.array([-1.0, 1.0, 1000.0]))
    assert choice.logarithmic(np.array([np.nan, 1e-3, 1.0]))
    assert not choice.logarithmic(np.array([np.nan]), by_design=True)


def test_labels_of_keys_and_measures():
    assert names.key_label("model.zeta") == r"$\zeta$ (model.zeta)"
    assert names.key_label("obstacle.gap") == "$g$ (obstacle.gap) [$L$]"
    assert names.measure_label("sigma_1_final") == r"final contact stress $\sigma(1)$ [$E$]"
    assert names.measure_label("contact_fraction") == "fraction of the steps in contact"
    declared = {"peak": {"column": "contact_force", "reduce": "max"},
                "touch": {"column": "contact_force", "reduce": "time_positive"},
                "late": {"column": "u@0.25", "reduce": "integral", "window": [1, 2]}}
    assert names.measure_label("peak", declared) == "peak: max $p$ [$E$]"
    assert names.measure_label("touch", declared) == "touch: time with $p$ > 0 [$t_0$]"
    assert names.measure_label("late", declared) == \
        r"late: $\int$ $u(0.25)$ $dt$ on $[1, 2]$ [$L t_0$]"
    assert names.measure_title("peak", declared) == "peak: max $p$"
    assert names.measure_label("other_thing") == "other thing"


def test_log_design_axis_labels_and_default_measures(tmp_path, drawn):
    """ε over one decade, log-spaced: a log x axis by design; its symbol on the axis; the
    measures' meanings and units; the timing, the iterations and the constant t_final left out,
    and said so in one line."""
    out = sweep(tmp_path, LOG)
    notes = []
    written = plot_sweep(out, note=notes.append)
    assert len(notes) == 1 and "\n" not in notes[0]
    assert "loop_seconds" in notes[0] and "iterations_max" in notes[0] and "t_final" in notes[0]
    assert {"sweep_loop_seconds.png", "sweep_iterations_max.png", "sweep_t_final.png"} \
        .isdisjoint(p.name for p in written)
    ax = drawn["sweep_max_penetration.png"].axes[0]
    assert ax.get_xscale() == "log"
    assert ax.get_xlabel() == r"$\varepsilon$ (obstacle.epsilon)"
    assert ax.get_ylabel() == "max penetration $[u(1) - g]_+$ [$L$]"
    assert ax.get_title() == r"max penetration $[u(1) - g]_+$ against $\varepsilon$"
    for path in written:
        y = drawn[path.name].axes[0].lines[0].get_ydata()
        assert drawn[path.name].axes[0].get_yscale() == \
            ("log" if y.min() > 0 and y.max() / y.min() >= 100 else "linear"), path.name
    # --measures draws what is asked, in the table's order, and nothing else
    figs = tmp_path / "figs"
    asked = plot_sweep(out, figs, measures=["loop_seconds", "u_1_final"], note=notes.append)
    assert [p.name for p in asked] == ["sweep_u_1_final.png", "sweep_loop_seconds.png"]
    assert sorted(p.name for p in figs.iterdir()) == sorted(p.name for p in asked)
    assert drawn["sweep_loop_seconds.png"].axes[0].get_ylabel() == \
        r"time loop's wall time [$\mathrm{s}$]"
    assert len(notes) == 1


def test_linear_design_and_values_over_decades(tmp_path, drawn):
    out = sweep(tmp_path, LINEAR)
    plot_sweep(out, measures=["u_1_final"])
    assert drawn["sweep_u_1_final.png"].axes[0].get_xscale() == "linear"
    # the same values over two decades: a log axis, not by design
    layout, columns = sweep_figures.load_sweep(out)
    columns["model.zeta"] = np.array([0.01, 0.1, 1.0])
    fig, ax = sweep_figures._figure("t")
    sweep_figures._lines(ax, *sweep_figures._positions(columns["model.zeta"]), "model.zeta",
                         False, np.array([0.0, 1.0, 2.0]), np.ones(3, dtype=bool),
                         [(None, np.ones(3, dtype=bool))])
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"  # y holds a zero


def test_map_and_lines_over_two_grid_axes(tmp_path, drawn):
    out = sweep(tmp_path, TWO)
    plot_sweep(out, measures=["max_penetration"])
    ax = drawn["sweep_max_penetration.png"].axes[0]
    assert ax.get_xlabel() == r"$\zeta$ (model.zeta)"
    assert ax.get_ylabel() == r"$\varepsilon$ (obstacle.epsilon)"
    bar = drawn["sweep_max_penetration.png"].axes[1]
    assert bar.get_ylabel() == "max penetration $[u(1) - g]_+$ [$L$]"
    lines = drawn["sweep_max_penetration_lines.png"].axes[0]
    # ε = 1e-4 at Δt = 2e-4: 50 steps per √ε, coarse for the paper's scheme (ringed)
    assert [t.get_text() for t in lines.get_legend().get_texts()] == \
        [rf"$\varepsilon$ = {v}" for v in ("0.0001", "0.001", "0.01", "0.1")] \
        + ["step coarse for the contact"]
    y = np.concatenate([line.get_ydata() for line in lines.lines[:-1]])
    assert y.size == 8 and y.min() > 0
    scale = "log" if y.max() / y.min() >= 100 else "linear"
    assert lines.get_yscale() == scale and bar.get_yscale() == scale
    plot_sweep(out, measures=["sigma_1_final"])
    assert drawn["sweep_sigma_1_final.png"].axes[1].get_yscale() == "linear"  # σ ≤ 0: never log
    # colours over decades: a log colour bar
    from matplotlib.colors import LogNorm

    assert isinstance(sweep_figures._norm(np.array([1e-3, np.nan, 1.0])), LogNorm)
    assert not isinstance(sweep_figures._norm(np.array([0.0, 1e-3, 1.0])), LogNorm)


def test_log_sample_range(tmp_path, drawn):
    out = sweep(tmp_path, SAMPLE)
    plot_sweep(out, measures=["u_1_final"])
    ax = drawn["sweep_u_1_final.png"].axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"
    assert ax.get_ylabel() == r"$\zeta$ (model.zeta)"


def test_declared_measure_columns_are_drawn(tmp_path, drawn):
    """A column between the built-in measures and error (a declared measure) is a measure;
    its label comes from the sweep's [measures]."""
    out = sweep(tmp_path, LOG)
    path = out / "results.csv"
    with open(path, encoding="utf-8", newline="") as file:
        rows = list(csv.reader(file))
    rows[0].insert(-1, "peak_force")
    for i, row in enumerate(rows[1:]):
        row.insert(-1, repr(10.0 ** i))
    with open(path, "w", encoding="utf-8", newline="") as file:
        csv.writer(file, lineterminator="\n").writerows(rows)
    meta = json.loads((out / "sweep.json").read_text(encoding="utf-8"))
    meta["sweep"]["measures"] = {"peak_force": {"column": "contact_force", "reduce": "max"}}
    (out / "sweep.json").write_text(json.dumps(meta), encoding="utf-8")
    written = plot_sweep(out)
    assert written[-1].name == "sweep_peak_force.png"
    ax = drawn["sweep_peak_force.png"].axes[0]
    assert ax.get_ylabel() == "peak_force: max $p$ [$E$]"
    assert ax.get_yscale() == "log"  # 1, 10, 100
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), [1.0, 10.0, 100.0])


def test_overlay_of_one_axis_is_coloured_by_its_values(tmp_path, drawn):
    out = sweep(tmp_path, LOG, histories=True)
    written = plot_sweep(out, overlay=True)
    assert [p.name for p in written] == list(scenes.FIGURES)
    contact = drawn["sweep_scenes_contact.png"]
    curves_drawn = [line for line in contact.axes[0].lines if line.get_linestyle() == "-"]
    assert len(curves_drawn) == 3
    bar = [ax for ax in contact.axes if ax.get_ylabel() == r"$\varepsilon$ (obstacle.epsilon)"]
    assert len(bar) == 1 and bar[0].get_yscale() == "log"  # log-spaced ε, a log colour bar
    energy = drawn["sweep_scenes_energy.png"]
    assert len(energy.axes[0].lines) == 3
    # with --measures, their figures too; in a window
    both = plot_sweep(out, tmp_path / "figs", measures=["u_1_final"], overlay=True,
                      window=(0.1, 0.2))
    assert [p.name for p in both] == ["sweep_u_1_final.png", *scenes.FIGURES]
    assert drawn["sweep_scenes_energy.png"].axes[0].get_xlim() == (0.1, 0.2)


def test_overlay_of_two_axes_colours_one_and_dashes_the_other(tmp_path, drawn):
    """ζ (two values) and ε (four): coloured by ζ, a line style per ε named in the legend."""
    out = sweep(tmp_path, TWO, histories=True)
    plot_sweep(out, overlay=True)
    contact = drawn["sweep_scenes_contact.png"]
    legend = [ax.get_legend() for ax in contact.axes if ax.get_legend() is not None][0]
    assert [t.get_text() for t in legend.get_texts()] == \
        [rf"$\varepsilon = {v}$" for v in ("0.0001", "0.001", "0.01", "0.1")] + ["gap $g = 0.1$"]
    assert [ax.get_ylabel() for ax in contact.axes][-1] == r"$\zeta$ (model.zeta)"
    styles = [line.get_linestyle() for line in contact.axes[0].lines[:8]]
    assert styles == ["-", ":", "-.", "--"] * 2  # the fourth a pattern of its own ("--")
    assert contact.axes[0].lines[8].get_linestyle() == "--"  # the gap


def test_overlay_labels_scenes_when_styles_run_out(tmp_path):
    """More values than line styles, or three axes: a legend entry per scene."""
    runs = [fake_run(tmp_path, f"scene {i}", **{"model.zeta": 0.1 * (i % 5 + 1),
                                              "obstacle.epsilon": 10.0 ** -(i // 5)})
            for i in range(25)]
    assert scenes._encoding(runs, ("model.zeta", "obstacle.epsilon")) == (None, None)
    assert legend_labels(runs)[6] == r"scene 6: $\zeta = 0.2$, $\varepsilon = 0.1$"
    three = [fake_run(tmp_path, f"scene {i}", **{"model.zeta": 0.1 * (i + 1),
                                               "obstacle.epsilon": 0.1, "model.k": 1.0})
             for i in range(2)]
    assert scenes._encoding(three, ("model.zeta", "obstacle.epsilon", "model.k")) == \
        (None, None)
    colour, dashes = scenes._encoding(runs[:10], ("model.zeta", "obstacle.epsilon"))
    assert colour == "model.zeta"  # ε has two values there
    assert dashes.legend == [("-", r"$\varepsilon = 1$"), (":", r"$\varepsilon = 0.1$")]
    assert dashes.styles == ["-"] * 5 + [":"] * 5
    assert scenes._encoding(runs[:1], ("model.zeta",)) == (None, None)


def test_overlay_needs_histories(tmp_path, capsys):
    out = sweep(tmp_path, LOG)
    with pytest.raises(PlotError, match="--histories"):
        plot_sweep(out, overlay=True)
    assert not (out / "figures").exists()
    assert_refused(["plot", str(out), "--overlay", "--out", str(tmp_path / "f")],
                   tmp_path / "f", "kept no histories (run the sweep with --histories)", capsys)


def test_kept_histories_read_a_scenes_own_columns_or_the_files(tmp_path):
    """One reader of histories.h5 for the overlays and SweepResult.history: a scene's columns
    are its dataset's, or the file's where the dataset has none."""
    import h5py

    from rodfem.output.results import kept_histories

    rows = np.arange(6.0).reshape(2, 3)
    with h5py.File(tmp_path / "h.h5", "w") as file:
        file.attrs["columns"] = "t,u_1,u_half"
        file.create_group("scenes").create_dataset("0", data=rows)
        file["scenes"].create_dataset("2", data=rows[:, :2]).attrs["columns"] = "t,u_1"
    kept = kept_histories(tmp_path / "h.h5")
    assert sorted(kept) == [0, 2]
    np.testing.assert_array_equal(kept[0][0], rows)
    assert kept[0][1] == ("t", "u_1", "u_half") and kept[2][1] == ("t", "u_1")
    assert list(kept_histories(tmp_path / "h.h5", [2, 5])) == [2]


@pytest.mark.parametrize("options, message", [
    (["--measures", "u_1_finall"], "--measures: unknown measure 'u_1_finall'; the measures are "
                                   + ", ".join(NAMES)),
    (["--measures", "u_1_final,"], "without empty items"),
    (["--measures", "u_1_final", "--only", "u_1_final"], "give one"),
    (["--window", "0,1"], "--window applies to runs"),
])
def test_bad_sweep_options(tmp_path, options, message, capsys):
    out = sweep(tmp_path, LINEAR)
    assert_refused(["plot", str(out), "--out", str(tmp_path / "f"), *options], tmp_path / "f",
                   message, capsys)
    assert not (out / "figures").exists()


def test_the_command_notes_what_it_left_out(tmp_path, capsys):
    from rodfem.cli import main

    out = sweep(tmp_path, LINEAR)
    capsys.readouterr()
    assert main(["plot", str(out)]) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if "not drawn" in line]
    assert len(notes) == 1 and notes[0].startswith("rodfem: note: not drawn: ")
    assert "sweep_loop_seconds.png" not in captured.out
    assert "sweep_u_1_final.png" in captured.out


def fake_run(tmp_path, name: str, **scene) -> Run:
    """A run of a few rows for the overlays' labels (no directory is read)."""
    t = np.linspace(0.0, 1.0, 5)
    rows = np.zeros((t.size, len(HISTORY_COLUMNS)))
    rows[:, 0], rows[:, 1], rows[:, 5] = t, 0.2 * t, 1.0 - t / 2
    base = {"model.zeta": 0.2, "obstacle.epsilon": 0.01, "model.k": 1.0, "obstacle.gap": 0.1,
            "obstacle.kind": "elastic", "obstacle.law": "linear",
            "heat_exchange.law": "constant", "solver.method": "direct", "time.scheme": "paper",
            "output.every": 50}
    return Run(tmp_path / name, name, History(rows), {**base, **scene}, None)


def test_run_legends_name_the_law(tmp_path, drawn):
    """Runs differing only in the law: their legends say which; keys a run has alone (the power
    law's exponent) in its label only; outputs never."""
    one = fake_run(tmp_path, "linear", **{"output.every": 10})
    two = fake_run(tmp_path, "power", **{"obstacle.law": "power", "obstacle.exponent": 2.0})
    assert legend_labels([one, two]) == ["linear: contact law linear",
                                         "power: contact law power, $m = 2$"]
    three = fake_run(tmp_path, "newton", **{"solver.method": "newton", "model.zeta": 1.0,
                                            "heat_exchange.law": "pressure"})
    assert legend_labels([one, three]) == [
        r"linear: $\zeta = 0.2$, exchange law constant, method direct",
        r"newton: $\zeta = 1$, exchange law pressure, method newton"]
    assert legend_labels([one, three], math=False)[1] == \
        "newton: ζ = 1, exchange law pressure, method newton"
    rigid = fake_run(tmp_path, "rigid", **{"obstacle.kind": "rigid",
                                            "time.scheme": "crank-nicolson"})
    assert legend_labels([one, rigid])[1] == \
        "rigid: rigid obstacle, time scheme crank-nicolson"
    path = curves.contact_figure([one, two], legend_labels([one, two]), tmp_path / "c.png")
    legend = [ax.get_legend() for ax in drawn["c.png"].axes if ax.get_legend()][0]
    assert [t.get_text() for t in legend.get_texts()][:2] == legend_labels([one, two])
    panels = drawn["c.png"].axes[:4]
    assert [ax.get_ylabel() for ax in panels] == ["$u(1, t)$ [$L$]", "$u(0.5, t)$ [$L$]",
                                                  "$u_t(1, t)$ [$L/t_0$]",
                                                  r"$\sigma(1, t)$ [$E$]"]
    assert {ax.get_xlabel() for ax in panels} == {"$t$ [$t_0$]"}
    assert path.is_file()


def test_run_legends_tell_many_scenes_apart(tmp_path):
    """Scenes that differ in many keys: at most four values each, chosen so that no two labels
    are the same (the laws alone would not tell the paper's experiments apart)."""
    from rodfem.post.runs import LEGEND_KEYS, _flatten
    from rodfem.scene import load

    scenes = ["paper1", "paper2", "paper3", "paper4", "paper5", "impact", "barber"]
    runs = [Run(tmp_path, name, None, _flatten(load(name).data()), None) for name in scenes]
    labels = legend_labels(runs)
    assert len(set(label.split(": ", 1)[1] for label in labels)) == len(runs), labels
    assert max(label.count(", ") + 1 for label in labels) <= LEGEND_KEYS
    assert labels[0] == r"paper1: $\zeta = 0.2$, $k = 1$, $\varepsilon = 0.01$, elastic obstacle"
    assert labels[5] == r"impact: $\zeta = 0$, $k = 0$, rigid obstacle"


def test_overlay_of_a_stopped_sweep_says_why(tmp_path):
    """A sweep run with --histories writes histories.h5 when it is complete: before, the overlay
    says so (and how to finish it), nothing written."""
    out = sweep(tmp_path, LOG, histories=True)
    (out / HISTORIES).unlink()
    with pytest.raises(PlotError, match="keeps them when it is complete.*rodfem resume"):
        plot_sweep(out, overlay=True)
    assert not (out / "figures").exists()


@pytest.mark.parametrize("options", [["--measures", "u_1_final"], ["--overlay"]])
def test_sweep_options_are_refused_for_runs(tmp_path, options, capsys):
    run = tmp_path / "run"
    run.mkdir()
    assert_refused(["plot", str(run), "--out", str(tmp_path / "f"), *options], tmp_path / "f",
                   f"{options[0]} applies to a sweep directory", capsys)


def test_a_sweep_whose_measures_are_all_the_same(tmp_path, capsys):
    """One scene: no measure tells scenes apart, nothing to draw unless asked for."""
    out = sweep(tmp_path, '[grid]\n"model.zeta" = [0.2]\n')
    assert_refused(["plot", str(out)], out / "figures", "no measure differs between the "
                   "sweep's scenes; --measures NAME,... draws any of t_final, ", capsys)
    assert [p.name for p in plot_sweep(out, measures=["u_1_final"])] == ["sweep_u_1_final.png"]


def test_overlay_of_laws_and_switches(tmp_path, drawn):
    """Swept choices (the contact law, adaptive steps): no colour bar, each scene named in words."""
    out = sweep(tmp_path, '[grid]\n"obstacle.law" = ["linear", "power"]\n'
                          '"time.adaptive" = [false, true]\n', histories=True)
    plot_sweep(out, overlay=True)
    energy = drawn["sweep_scenes_energy.png"]
    legend = [ax.get_legend() for ax in energy.axes if ax.get_legend() is not None][0]
    assert [t.get_text() for t in legend.get_texts()] == [
        "scene 0: contact law linear, fixed steps", "scene 1: contact law linear, adaptive steps",
        "scene 2: contact law power, fixed steps", "scene 3: contact law power, adaptive steps"]
    assert len(energy.axes) == 2  # the curves and the legend's strip: no colour bar


def test_a_measure_that_differs_only_by_a_failed_scene_is_not_drawn():
    """The figures draw the complete scenes: a failed run's shorter t_final does not make
    t_final informative."""
    columns = {"index": np.array([0, 1, 2]), "model.zeta": np.array([0.1, 0.2, 0.5]),
               "status": np.array(["failed", "complete", "complete"]),
               "t_final": np.array([0.186, 0.3, 0.3]), "u_1_final": np.array([0.1, 0.2, 0.3]),
               "error": np.array(["did not converge", "", ""])}
    drawn, skipped = choice.choose(columns, None)
    assert drawn == ["u_1_final"]
    assert "t_final (the same in every scene)" in skipped


def test_coarse_scenes_and_missed_accuracy_are_marked_with_a_legend(tmp_path, drawn):
    """ε = 1e-4 … 1e-3 at Δt = 2e-4 (50 … 158 steps per √ε): the scenes results.csv flags
    coarse are ringed, under a legend entry; an accuracy_met column, where the table has one,
    boxes its zeros; a map outlines the cells of both."""
    out = sweep(tmp_path, LOG)
    layout, columns = sweep_figures.load_sweep(out)
    coarse = columns["coarse"] == 1
    assert coarse.tolist() == [True, True, False]  # S = 50, 89 < 100 ≤ 158
    plot_sweep(out, measures=["max_penetration"])
    ax = drawn["sweep_max_penetration.png"].axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["step coarse for the contact"]
    ring = ax.lines[-1]
    np.testing.assert_array_equal(ring.get_xdata(), columns["obstacle.epsilon"][coarse])
    np.testing.assert_array_equal(ring.get_ydata(), columns["max_penetration"][coarse])
    assert ring.get_markerfacecolor() == "none"
    # without the column, nothing more; with it, its zeros boxed
    columns["accuracy_met"] = np.array([1, 0, 0])
    sweep_figures._measure(tmp_path, layout, columns, "max_penetration")
    ax = drawn["sweep_max_penetration.png"].axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == \
        ["step coarse for the contact", "accuracy target not met"]
    np.testing.assert_array_equal(ax.lines[-1].get_xdata(), columns["obstacle.epsilon"][1:])
    # no coarse scene: no legend at all
    columns["coarse"][:] = 0
    del columns["accuracy_met"]
    sweep_figures._measure(tmp_path, layout, columns, "max_penetration")
    assert drawn["sweep_max_penetration.png"].axes[0].get_legend() is None
    # a map: the cells outlined
    two = sweep(tmp_path, TWO, name="two")
    layout, columns = sweep_figures.load_sweep(two)
    columns["accuracy_met"] = (columns["obstacle.epsilon"] > 0.05).astype(int)
    sweep_figures._measure(tmp_path, layout, columns, "max_penetration")
    ax = drawn["sweep_max_penetration.png"].axes[0]
    outlined = [p for p in ax.patches if not p.get_fill()]
    assert len(outlined) == np.sum(columns["coarse"] == 1) + np.sum(columns["accuracy_met"] == 0)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == \
        ["step coarse for the contact", "accuracy target not met"]


def test_measures_held_to_a_target_are_drawn_with_their_error_bars(tmp_path, drawn):
    from matplotlib.container import ErrorbarContainer

    spec = tmp_path / "targets.toml"
    spec.write_text('scene = "manufactured"\n[set]\n"mesh.cells" = 8\n"time.dt" = 0.05\n'
                    '"time.scheme" = "crank-nicolson"\n"accuracy.target" = 0.001\n[grid]\n'
                    '"model.zeta" = [0.1, 0.3]\n[measures]\n'
                    'u_end = { column = "u_1", reduce = "final" }\n', encoding="utf-8")
    out = tmp_path / "targets"
    run_sweep(spec, out=out, comm=MPI.COMM_SELF)
    plot_sweep(out, measures=["u_end"])
    ax = drawn["sweep_u_end.png"].axes[0]
    bars = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
    assert len(bars) == 1 and ax.get_ylabel().endswith("bars: its estimated error")
    with open(out / "results.csv", encoding="utf-8", newline="") as file:
        rows = list(csv.DictReader(file))
    half = [abs(s[1][1] - s[0][1]) / 2 for s in bars[0].lines[2][0].get_segments()]
    np.testing.assert_allclose(half, [float(r["u_end_error"]) for r in rows], rtol=1e-12)
    assert all(r["accuracy_met"] == "1" for r in rows)
