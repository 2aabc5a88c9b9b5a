"""Declared measures: each reduction equals its value recomputed here, straightforwardly, from the
rows of history.h5 (fixed and adaptive steps, with and without windows); the same whatever rows
the history keeps and however the rows come in blocks; bit for bit after a stop and a resume; a
sweep's columns are single runs' measures; the scene, results.csv and the API carry them."""

import json
import math
import signal

import numpy as np
import pytest

import rodfem
from conftest import COMM, history_rows, representative, serial_only
from rodfem.cli import main
from rodfem.output import results as table
from rodfem.output.measures import NAMES as BUILT_IN
from rodfem.output.measures import TIMINGS
from rodfem.output.readers import read_history
from rodfem.scene.measures import REDUCTIONS

EPS = np.finfo(float).eps
BASE = """
[mesh]
cells = 20
[obstacle]
gap = 0.02
[time]
dt = 0.01
end = 2.0
"""
ADAPTIVE = "adaptive = true\n"
# every reduction of three columns: u(1) over the run, u(0.3) in a window that no row bounds, the
# contact force in a window that ends after the run
WINDOWS = {"u_1": None, "u@0.3": (0.333, 1.777), "contact_force": (0.5, 99.0)}


def declared(windows=WINDOWS) -> str:
    lines = ["[measures]"]
    for k, (column, window) in enumerate(windows.items()):
        extra = f", window = [{window[0]!r}, {window[1]!r}]" if window else ""
        lines += [f'{reduce}_{k} = {{ column = "{column}", reduce = "{reduce}"{extra} }}'
                  for reduce in REDUCTIONS]
    return "\n".join(lines) + "\n"


def scene_file(directory, text, name="scene.toml"):
    path = directory / name
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    return path


def recomputed(t, f, reduce, window):
    """The measure of the piecewise-linear interpolant of the rows (t, f), from its definition."""
    t0, t1 = window or (0.0, math.inf)
    low, high = t0, min(t1, t[-1])
    if low > high:
        return math.nan
    inside = (t >= low) & (t <= high)
    ts = np.concatenate([[low], t[inside], [high]])
    fs = np.interp(ts, t, f)
    widths = np.diff(ts)
    if reduce == "max":
        return fs.max()
    if reduce == "min":
        return fs.min()
    if reduce == "max_abs":
        return np.abs(fs).max()
    if reduce == "time_of_max_abs":
        return ts[np.argmax(np.abs(fs))]
    if reduce == "final":
        return fs[-1]
    if reduce in ("integral", "mean"):
        integral = np.sum(widths * (fs[:-1] + fs[1:]) / 2)
        return integral if reduce == "integral" else integral / (high - low)
    positive = 0.0
    for width, a, b in zip(widths, fs[:-1], fs[1:], strict=True):
        if a > 0 and b > 0:
            positive += width
        elif a > 0:
            positive += width * a / (a - b)
        elif b > 0:
            positive += width * b / (b - a)
    return positive


def tolerance(t, f, reduce, window):
    """Round-off: a value interpolated at a window's end is good to a few ulps of the column;
    a sum of n terms to n ulps of the sum of their sizes."""
    size = np.max(np.abs(f))
    if reduce in ("max", "min", "max_abs", "final"):
        return 4 * EPS * size
    if reduce == "time_of_max_abs":
        return 4 * EPS * t[-1]
    sums = len(t) * EPS
    if reduce == "time_positive":
        return sums * t[-1]
    t0, t1 = window or (0.0, math.inf)
    scale = size * t[-1]
    return sums * scale / ((min(t1, t[-1]) - t0) if reduce == "mean" else 1.0)


@pytest.mark.parametrize("steps", ["fixed", "adaptive"])
def test_every_reduction_is_its_value_recomputed_from_the_history(steps, shared_dir, simulate):
    text = BASE + (ADAPTIVE if steps == "adaptive" else "") + declared()
    result, out = simulate(str(scene_file(shared_dir, text)))
    assert result.status == "complete"
    if COMM.rank != 0:
        return
    history = read_history(out / "history.h5")
    summary = json.loads((out / "summary.json").read_text())
    t = history["t"]
    assert len(t) == 201 if steps == "fixed" else len(t) > 100
    assert history["contact_force"].max() > 0  # the rod touches: time_positive is not 0
    assert list(summary["measures"])[:len(BUILT_IN)] == list(BUILT_IN)
    for k, (column, window) in enumerate(WINDOWS.items()):
        f = history[column]
        for reduce in REDUCTIONS:
            name = f"{reduce}_{k}"
            expected = recomputed(t, f, reduce, window)
            assert abs(summary["measures"][name] - expected) <= tolerance(t, f, reduce, window), \
                (name, summary["measures"][name], expected)
    # the same from the history read back (rodfem.load), and the built-ins as they were
    loaded = rodfem.load(out).measures
    assert loaded == {**summary["measures"], "loop_seconds": loaded["loop_seconds"]}
    assert summary["measures"]["u_1_final"] == history["u_1"][-1]


def test_measures_do_not_depend_on_the_rows_kept_or_their_blocks(shared_dir, simulate):
    """history_every = 3 keeps a third of the rows, and checkpoints at every field save cut the
    rows into other blocks: the declared measures are the same bit for bit."""
    path = str(scene_file(shared_dir, BASE + ADAPTIVE + declared()))
    whole, whole_out = simulate(path)
    thinned, out = simulate(path, "output.history_every=3", "output.every=7",
                            "output.checkpoint=0")
    names = [name for name in whole.summary["measures"] if name not in BUILT_IN]
    assert len(names) == 3 * len(REDUCTIONS)
    for name in names:
        a, b = whole.summary["measures"][name], thinned.summary["measures"][name]
        assert a == b or (math.isnan(a) and math.isnan(b)), name
    if COMM.rank == 0:
        assert len(history_rows(out)) < len(history_rows(whole_out))


def test_a_window_the_run_never_reached_is_nan_and_null(shared_dir, simulate):
    text = BASE + '[measures]\nlate = { column = "u_1", reduce = "max", window = [1.55, 2] }\n'
    # Picard's iteration, allowed 3 iterations a step, fails at the second step
    result, out = simulate(str(scene_file(shared_dir, text)), "solver.method=picard",
                           "solver.max_iterations=3")
    assert result.status == "failed" and result.summary["steps"] < 10
    assert math.isnan(result.summary["measures"]["late"])
    if COMM.rank == 0:
        assert json.loads((out / "summary.json").read_text())["measures"]["late"] is None
        assert math.isnan(rodfem.load(out).measures["late"])


def test_a_measures_column_is_recorded_and_the_scene_round_trips(shared_dir, simulate):
    text = BASE + '[measures]\nmid = { column = "theta@0.50", reduce = "mean" }\n' \
        'force = { column = "contact", reduce = "time_positive", window = [0, 1] }\n'
    _, out = simulate(str(scene_file(shared_dir, text)))
    if COMM.rank == 0:
        assert read_history(out / "history.h5").names[-2:] == ("theta@0.5", "contact")
        written = (out / "scene.toml").read_text()
        assert 'mid = { column = "theta@0.5", reduce = "mean" }' in written
        again = rodfem.scene.load(str(out / "scene.toml"))
        assert again.to_toml() == written and [m.name for m in again.measures] == ["mid", "force"]


@serial_only
@pytest.mark.parametrize("ranks", representative([1, 2], [1]))
def test_a_resumed_run_has_the_measures_of_a_whole_one(tmp_path, ranks):
    """Extended from t = 1 to 2 (a window across the resume), and stopped by a signal and
    resumed: the measures are an uninterrupted run's, bit for bit."""
    from test_resume import rodfem as command
    from test_resume import stop_and_resume

    path = tmp_path / "scene.toml"
    path.write_text(BASE + "[output]\nevery = 7\ncheckpoint = 0\n" + declared())
    short, whole = tmp_path / "short", tmp_path / "whole"
    command("run", path, "--set", "time.end=1", "--out", short, "--quiet", ranks=ranks, check=0)
    command("resume", short, "--set", "time.end=2", "--quiet", ranks=ranks, check=0)
    command("run", path, "--out", whole, "--quiet", ranks=ranks, check=0)
    assert_same_measures(short, whole)
    long = tmp_path / "long.toml"  # about a second of loop, a checkpoint every 0.2 s
    long.write_text(BASE.replace("cells = 20", "cells = 100").replace("end = 2.0", "end = 120")
                    .replace("dt = 0.01", "dt = 0.001")
                    + "[output]\nevery = 500\ncheckpoint = 0.2\n" + declared())
    reference = tmp_path / "reference"
    command("run", long, "--out", reference, "--quiet", ranks=ranks, check=0)
    # under mpirun SIGUSR1, as test_resume sends: Open MPI 5's mpirun may end the ranks' output
    # on SIGTERM before their line "rodfem: interrupted" reaches it (the run is whole either way)
    sent = signal.SIGTERM if ranks == 1 else signal.SIGUSR1
    stop_and_resume(tmp_path / "stopped", [str(long)], sent, ranks, 0.2 * ranks,
                    reference, same=assert_same_measures, after="checkpoint.npz",
                    whole=lambda out: read_history(out / "history.h5", empty=True))


def assert_same_measures(a, b):
    ma = json.loads((a / "summary.json").read_text())["measures"]
    mb = json.loads((b / "summary.json").read_text())["measures"]
    assert {k: v for k, v in ma.items() if k not in TIMINGS} == \
        {k: v for k, v in mb.items() if k not in TIMINGS}
    assert len(ma) == len(BUILT_IN) + 3 * len(REDUCTIONS)


SWEPT = ('touching = { column = "contact_force", reduce = "time_positive" }\n'
         'late = { column = "energy", reduce = "mean", window = [0.5, 1.5] }\n')


def test_a_sweeps_columns_are_single_runs_measures(shared_dir, simulate):
    """The base scene's measures and the sweep's, in results.csv after the built-in ones; each
    row the measures in summary.json of the single run of its scene."""
    own = BASE + '[measures]\npeak = { column = "contact_force", reduce = "max" }\n'
    scene_file(shared_dir, own, "base.toml")
    sweep = scene_file(shared_dir, 'scene = "base.toml"\n[grid]\n"obstacle.gap" = [0.02, 1.0]\n'
                       "[measures]\n" + SWEPT, "sweep.toml")
    out = shared_dir / "sweep"
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    axes, columns = table.read(out / "results.csv")
    names = ["index", "obstacle.gap", "status", *BUILT_IN, "peak", "touching", "late",
             *table.RUN, "error"]
    assert list(columns) == names
    assert table.measure_names(names) == (*BUILT_IN, "peak", "touching", "late")
    single = str(scene_file(shared_dir, own + SWEPT, "single.toml"))
    for i, gap in enumerate((0.02, 1.0)):
        _, run = simulate(single, f"obstacle.gap={gap}")
        if COMM.rank == 0:
            measures = json.loads((run / "summary.json").read_text())["measures"]
            for name in table.measure_names(names):
                if name not in TIMINGS:
                    assert columns[name][i] == measures[name], (name, gap)
    assert columns["touching"][0] > columns["touching"][1] > 0  # a wider gap, less contact
    assert rodfem.load_sweep(out).columns["late"].tolist() == columns["late"].tolist()


def test_results_csv_of_an_earlier_rodfem_still_reads():
    now = table.text(("model.k",), [table.line(0, {"model.k": 1.0}, ("model.k",), "complete",
                                               {"t_final": 1.0})])
    axes, columns = table.parse(now)
    assert axes == ("model.k",) and table.measure_names(list(columns)) == BUILT_IN
    assert [columns[name].tolist() for name in table.RUN] == [[0], [0], [0]]
    # before the run's columns: the measures, then error
    old = "index,model.k,status," + ",".join(BUILT_IN) + ",error\n0,1.0,complete" \
        + ",1.0" * len(BUILT_IN) + ",\n"
    axes, columns = table.parse(old)
    assert axes == ("model.k",) and table.measure_names(list(columns)) == BUILT_IN
    assert not set(table.RUN) & set(columns)
    new = table.text(("model.k",), [table.line(0, {"model.k": 1.0}, ("model.k",), "complete",
                                               {"peak": 2.5}, "", ("peak",))], ("peak",))
    _, columns = table.parse(new)
    assert columns["peak"].tolist() == [2.5]
    for header in ("index,status,t_final,error", "index,status," + ",".join(BUILT_IN)
                   + ",Peak,error", "index,status," + ",".join(BUILT_IN) + ",t_final,error"):
        with pytest.raises(table.ResultsError, match="header is not rodfem's"):
            table.parse(header + "\n")


@pytest.mark.parametrize("window", [None, (0.25, 0.75), (0.3, 5.0), (0.0, 0.5)])
def test_reductions_of_uneven_rows_in_any_blocks(window):
    """Rows at uneven times (some a window's end exactly), in blocks of any sizes: the same
    values bit for bit as in one block, each its value recomputed from the rows."""
    from rodfem.output.reductions import Reductions
    from rodfem.scene.measures import Declared

    rng = np.random.default_rng(7)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 2e-2, 120))])
    t[40] = 0.25  # a row at a window's end
    t = np.sort(t)
    f = np.sin(40 * t) + 0.1 * rng.standard_normal(t.size)
    declared = [Declared(f"m_{r}", "f", r, window) for r in REDUCTIONS]
    whole = Reductions(declared)
    whole.update(t, {"f": f})
    for _ in range(5):
        cuts = np.sort(rng.choice(np.arange(1, t.size), size=rng.integers(1, 20), replace=False))
        blocks = Reductions(declared)
        for rows in np.split(np.arange(t.size), cuts):
            # a resumed run's reductions: from the state a checkpoint keeps, through JSON
            blocks = Reductions(declared, json.loads(json.dumps(blocks.saved())))
            blocks.update(t[rows], {"f": f[rows]})
        assert blocks.values() == whole.values()
    for m in declared:
        value = whole.values()[m.name]
        assert abs(value - recomputed(t, f, m.reduce, window)) <= tolerance(t, f, m.reduce,
                                                                            window), m.name


def test_a_column_with_nan_gives_nan_in_any_blocks():
    """A NaN among the rows: every reduction over it is NaN (final, the last value, aside),
    however the rows come in blocks, never the extremes of the rows on one side of it."""
    from rodfem.output.reductions import Reductions
    from rodfem.scene.measures import Declared

    t = np.linspace(0.0, 1.0, 11)
    f = np.array([0.0, 1.0, 2.0, np.nan, 1.0, 0.0, -1.0, -3.0, 1.0, 0.5, 0.2])
    declared = [Declared(f"m_{r}", "f", r) for r in REDUCTIONS]
    for size in (11, 1, 3, 4):
        blocks = Reductions(declared)
        for start in range(0, t.size, size):
            blocks = Reductions(declared, json.loads(json.dumps(blocks.saved())))
            blocks.update(t[start:start + size], {"f": f[start:start + size]})
        values = blocks.values()
        assert values.pop("m_final") == 0.2
        assert all(math.isnan(v) for v in values.values()), (size, values)


def test_a_history_of_every_nth_step_has_the_final_values_of_the_last_step(shared_dir):
    """2000 steps, every 7th row kept (the last step's is not): t_final is T and the final
    values are the last step's, in the run's summary and read back, as a run
    keeping every row has them."""
    scene = {"time.end": 0.2, "time.dt": 1e-4, "mesh.cells": 10}
    whole = rodfem.simulate("paper1", scene)
    thinned = rodfem.simulate("paper1", {**scene, "output.history_every": 7},
                              out=shared_dir / "thinned")
    assert thinned.history["t"][-1] < 0.2 and thinned.measures["t_final"] == 0.2
    finals = [name for name in BUILT_IN if name.endswith("_final")]
    for name in finals:
        assert thinned.summary["measures"][name] == whole.summary["measures"][name], name
        assert thinned.measures[name] == whole.measures[name], name
        assert rodfem.load(shared_dir / "thinned").measures[name] == whole.measures[name], name


@serial_only
def test_a_killed_resumed_run_reads_its_measures_from_its_history(tmp_path):
    """A run resumed and then killed (its marker still says running, no process holds it) keeps
    the summary.json of its earlier stop: its measures are those of the history on the disk, not
    of that summary."""
    text = BASE + '[measures]\npeak = { column = "u_1", reduce = "max" }\n'
    scene = scene_file(tmp_path, text)
    early = rodfem.simulate(scene, {"time.end": 0.3}, out=tmp_path / "early")
    run = rodfem.simulate(scene, {"time.end": 0.6}, out=tmp_path / "run")
    (tmp_path / "run" / "summary.json").write_text(
        (tmp_path / "early" / "summary.json").read_text())
    marker = tmp_path / "run" / "rodfem.json"
    marker.write_text(json.dumps({**json.loads(marker.read_text()), "status": "running"}))
    killed = rodfem.load(tmp_path / "run")
    assert killed.status == "gone" and early.measures["t_final"] == 0.3
    assert killed.measures == {**run.measures, "loop_seconds": killed.measures["loop_seconds"]}
