"""Sweeps that never mix or lose data: values that need quoting in results.csv, NumPy values
from Python, a disk filled by the journal, --force beside a user's file or the sweep file, an
edited sweep.json or a journal of another sweep, and the progress of a long validation. Each
serially and, where the ranks share the work, under mpirun."""

import csv
import functools
import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rodfem
from conftest import COMM, representative, serial_only
from rodfem.cli import main
from rodfem.output import journal
from rodfem.output import results as table
from rodfem.output.measures import TIMINGS

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}
SMALL = '"mesh.cells" = 10\n"time.end" = 0.1\n"solver.method" = "direct"\n'
GRID = f'scene = "paper1"\n[set]\n{SMALL}[grid]\n"model.k" = [0.1, 1, 10]\n' \
       '"model.zeta" = [0.2, 1.0]\n'


def write(path: Path, text: str) -> Path:
    """``text`` into ``path`` once every rank has read what was there (rank 0 writes)."""
    COMM.barrier()
    if COMM.rank == 0:
        path.write_text(text)
    COMM.barrier()
    return path


def snapshot(path: Path) -> dict:
    """Every file under ``path`` and its bytes (rodfem.lock's too), read by every rank once
    every rank is done with the command before, and before any goes on."""
    COMM.barrier()
    files = {str(f.relative_to(path)): f.read_bytes() for f in sorted(path.rglob("*"))
             if f.is_file()}
    COMM.barrier()
    return files


def one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert err.count("\n") == 1 and err.startswith("rodfem: error: "), err
        assert "Traceback" not in err
        for word in words:
            assert word in err, err
    return err


def without_timings(path: Path) -> list[list[str]]:
    """The cells of a results.csv, its timings blanked."""
    rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"), newline="")))
    timed = [j for j, name in enumerate(rows[0]) if name in TIMINGS]
    return [[("" if j in timed and i else cell) for j, cell in enumerate(row)]
            for i, row in enumerate(rows)]


def same_rows(a: Path, b: Path) -> None:
    """Two results.csv, the same text but for the timings."""
    assert without_timings(a) == without_timings(b)


def test_a_value_with_a_newline_is_written_and_read_whole(shared_dir, capsys):
    """An expression ending in a newline is a value like another: the sweep completes, its
    row reads back the value as given, and resume says the sweep is complete."""
    sweep = write(shared_dir / "newline.toml", f'scene = "paper1"\n[set]\n{SMALL}[grid]\n'
                  '"initial.u1" = ["20*x*(x - 1)**2", "20*x*(x - 1)**2\\n",\n'
                  '                "20*x*(x - 1)**2\\r\\n"]\n')
    out = shared_dir / "out"
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    axes, columns = table.read(out / table.NAME)
    assert axes == ("initial.u1",)
    assert list(columns["initial.u1"]) == ["20*x*(x - 1)**2", "20*x*(x - 1)**2\n",
                                           "20*x*(x - 1)**2\r\n"]
    assert list(columns["status"]) == ["complete"] * 3
    assert columns["u_1_final"][0] == columns["u_1_final"][1] == columns["u_1_final"][2]
    capsys.readouterr()
    assert main(["resume", str(out)]) == 0
    assert "is a complete sweep; nothing was changed" in capsys.readouterr().out or COMM.rank


def test_numpy_values_are_taken_and_other_objects_refused_before_anything_is_written(
        shared_dir):
    spec = {"scene": "paper1",
            "set": {"mesh.cells": np.int64(10), "time.end": np.float64(0.1),
                    "solver.method": np.str_("direct")},
            "grid": {"model.k": np.array([1.0, 2.0]), "model.zeta": (np.float32(0.5), 1)}}
    out = shared_dir / "numpy"
    result = rodfem.sweep(spec, out=out)
    assert result.status == "complete" and len(result) == 4
    assert list(result["model.k"]) == [1.0, 1.0, 2.0, 2.0]
    written = json.loads((out / "sweep.json").read_text())
    assert written["sweep"]["grid"] == {"model.k": [1.0, 2.0], "model.zeta": [0.5, 1]}
    plain = rodfem.sweep({**spec, "grid": {"model.k": [1.0, 2.0], "model.zeta": [0.5, 1]}})
    np.testing.assert_array_equal(result["u_1_final"], plain["u_1_final"])
    for value in (object(), {1, 2}, np.datetime64("2020-01-01")):
        bad = shared_dir / f"refused-{type(value).__name__}"
        with pytest.raises(rodfem.SceneError, match="is not a value of a sweep"):
            rodfem.sweep({**spec, "grid": {"model.k": [1.0, value]}}, out=bad)
        assert not bad.exists()


def test_force_removes_only_what_the_sweep_wrote(shared_dir, capsys):
    sweep = write(shared_dir / "grid.toml", GRID)
    out = shared_dir / "plain"
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    marker = json.loads((out / "rodfem.json").read_text())
    assert "histories.h5" not in marker["files"] and "sweep.toml" in marker["files"]
    if COMM.rank == 0:
        (out / "histories.h5").write_bytes(b"the user's")
    COMM.barrier()
    before = snapshot(out)
    assert main(["sweep", str(sweep), "--out", str(out), "--force"]) == 2
    one_line_error(capsys, "holds histories.h5")
    assert snapshot(out) == before
    with_histories = shared_dir / "histories"
    assert main(["sweep", str(sweep), "--out", str(with_histories), "--histories",
                 "--quiet"]) == 0
    assert "histories.h5" in json.loads((with_histories / "rodfem.json").read_text())["files"]
    assert main(["sweep", str(sweep), "--out", str(with_histories), "--histories", "--force",
                 "--quiet"]) == 0


def test_force_keeps_the_sweep_file_inside_out_as_run_keeps_its_scene(shared_dir, capsys):
    first = write(shared_dir / "grid.toml", GRID)
    out = shared_dir / "inside"
    assert main(["sweep", str(first), "--out", str(out), "--quiet"]) == 0
    sweep = out / "sweep.toml"  # the copy the sweep wrote, now given as the sweep file
    before = snapshot(out)
    assert main(["sweep", str(sweep), "--out", str(out), "--force"]) == 2
    one_line_error(capsys, "is inside the output directory")
    assert snapshot(out) == before


def killed(out: Path, keep: int) -> int:
    """Make the complete sweep ``out`` (run with its journal kept) one killed after ``keep``
    records of each rank's journal (or all it has): as SIGKILL leaves it. Returns how many
    records are left."""
    left = 0
    if COMM.rank == 0:
        for part in sorted((out / journal.DIRECTORY).glob("part-*.bin")):
            ends = sorted(r.offset + 8 * r.rows * r.columns for r in journal._records(part, 0))
            part.write_bytes(part.read_bytes()[:ends[min(keep, len(ends)) - 1]])
            left += min(keep, len(ends))
        for name in (table.NAME, "summary.json"):
            (out / name).unlink()
        marker = json.loads((out / "rodfem.json").read_text())
        gone = subprocess.Popen(["true"])  # the pid of a process that has ended
        gone.wait()
        (out / "rodfem.json").write_text(json.dumps({**marker, "status": "running",
                                                     "pid": gone.pid}))
    return COMM.bcast(left, root=0)


@pytest.fixture
def stopped(shared_dir, monkeypatch):
    """A sweep killed after two scenes per rank, the complete one, and how many scenes the
    killed one holds."""
    sweep = write(shared_dir / "grid.toml", GRID)
    whole = shared_dir / "whole"
    assert main(["sweep", str(sweep), "--out", str(whole), "--quiet"]) == 0
    out = shared_dir / "stopped"
    with monkeypatch.context() as patch:
        patch.setattr(journal, "remove", lambda out: None)
        assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    return out, whole, killed(out, 2)


def test_a_killed_sweep_resumes_to_the_whole_table(stopped):
    out, whole, left = stopped
    assert main(["resume", str(out), "--quiet"]) == 0
    same_rows(out / table.NAME, whole / table.NAME)
    ran = json.loads((out / "summary.json").read_text())["ran_this_time"]
    assert ran == 6 - left


def test_an_edited_sweep_json_is_refused_and_nothing_changed(stopped, capsys):
    out, _, _ = stopped
    meta = json.loads((out / "sweep.json").read_text())
    edited = {**meta, "sweep": {**meta["sweep"], "set": {**meta["sweep"]["set"],
                                                         "time.end": 0.2}}}
    for changed in (edited, {**meta, "base": {**meta["base"], "time": {"end": 0.2}}}):
        write(out / "sweep.json", json.dumps(changed, indent=2))
        before = snapshot(out)
        assert main(["resume", str(out)]) == 2
        one_line_error(capsys, "sweep.json is not the sweep this directory was run with")
        assert snapshot(out) == before


def test_a_journal_of_another_sweep_is_refused_and_nothing_changed(stopped, shared_dir,
                                                                    capsys):
    out, _, _ = stopped
    other = write(shared_dir / "other.toml", GRID.replace("0.1, 1, 10", "0.1, 1, 11"))
    elsewhere = shared_dir / "elsewhere"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(journal, "remove", lambda out: None)
        assert main(["sweep", str(other), "--out", str(elsewhere), "--quiet"]) == 0
    if COMM.rank == 0:
        shutil.copy(elsewhere / journal.DIRECTORY / "part-0000-00000.bin",
                    out / journal.DIRECTORY / "part-0005-00000.bin")
    COMM.barrier()
    before = snapshot(out)
    assert main(["resume", str(out)]) == 2
    one_line_error(capsys, "holds a scene of another sweep")
    assert snapshot(out) == before


def test_an_edited_table_of_a_complete_sweep_is_refused(shared_dir, capsys):
    sweep = write(shared_dir / "grid.toml", GRID)
    out = shared_dir / "complete"
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    if COMM.rank == 0:
        path = out / table.NAME
        path.write_text(path.read_text().replace("complete", "failed", 1))
    COMM.barrier()
    before = snapshot(out)
    assert main(["resume", str(out)]) == 2
    one_line_error(capsys, "is not the table the sweep wrote")
    assert snapshot(out) == before


def test_a_long_validation_shows_its_progress(monkeypatch, capsys):
    from rodfem.studies.sweep import design
    from rodfem.studies.sweep import run as engine

    monkeypatch.setattr(engine, "Progress", functools.partial(engine.Progress, every=0.0))
    sweep = design.parse({"scene": "paper1", "grid": {"model.k": [1.0, 2.0, 3.0, 4.0]}}, "p")
    engine._validate_all(sweep, COMM, progress=True)
    err = capsys.readouterr().err
    if COMM.rank == 0:
        assert "sweep: checked 4/4 scenes" in err, err
    else:
        assert err == ""


# 400 scenes: the journal outgrows the disk's last 48 KiB between its 144th and 225th row
FULL = ('scene = "paper1"\n[set]\n' + SMALL + '[grid]\n"model.k" = {linspace = [0.1, 10, 20]}\n'
        '"model.zeta" = {linspace = [0.2, 1.0, 20]}\n')


@serial_only
@pytest.mark.parametrize("ranks", representative([1, 2], [1]))
def test_a_disk_filled_by_the_journal_is_named_and_the_sweep_marked_failed(small_disk, ranks):
    sweep = small_disk.parent / f"full-{ranks}.toml"
    sweep.write_text(FULL)
    (small_disk / "filler").write_bytes(bytes(1024 * 1024 - 48 * 1024))
    out = small_disk / "sweep"
    command = [RODFEM, "sweep", str(sweep), "--out", str(out)]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), "--oversubscribe", *command]
    env = {**ENV, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 4, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("rodfem")]
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert "journal/part-0000-0000" in lines[0] and "No space left on device" in lines[0]
    assert json.loads((out / "rodfem.json").read_text())["status"] == "failed"
    subprocess.run(["mount", "-o", "remount,size=64m", str(small_disk)], check=True)
    again = subprocess.run([RODFEM, "resume", str(out)], env=env, capture_output=True,
                           text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert json.loads((out / "rodfem.json").read_text())["status"] == "complete"
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []
    whole = small_disk / "whole"
    assert main(["sweep", str(sweep), "--out", str(whole), "--quiet"]) == 0
    same_rows(out / table.NAME, whole / table.NAME)
