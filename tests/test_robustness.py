"""What users get wrong and what machines do wrong: overflowing data, extreme TOML, edited run
files, a full disk, a run too large for the machine, and a paper reproduction whose runs fail.
Every case is one line on stderr, its own exit code, and no half-written file."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import history_rows, serial_only
from rodfem.output.directories import state

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}


def rodfem(*args, cwd=None):
    return subprocess.run([RODFEM, *map(str, args)], capture_output=True, text=True, env=ENV,
                          timeout=600, cwd=cwd)


def one_line(done, code: int, *words: str) -> str:
    err = done.stderr.strip()
    assert done.returncode == code, done.stderr
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, err
    return err


@serial_only
@pytest.mark.parametrize("method", ["direct", "picard", "newton"])
def test_values_that_overflow_stop_every_method_at_the_first_bad_step(tmp_path, method):
    """A momentum source within the bounds at the first and the last step, but of 1e271 at
    t = 1: U follows it, and its energy (a square) overflows."""
    out = tmp_path / "run"
    done = rodfem("run", "paper1", "--out", out, "--set", f"solver.method={method}",
                  "--set", "source.momentum=1e11*exp(600*sin(pi*t/2)**2)", "--set", "time.end=2",
                  "--set", "mesh.cells=20")
    # Picard may stop first, its increment no longer below tol at such magnitudes
    err = one_line(done, 3, *(["not finite"] if method != "picard" else []))
    history = history_rows(out)
    assert np.isfinite(history).all() and len(history) >= 1
    bad_step = len(history)  # steps 0 .. bad_step - 1 are kept
    assert f"step {bad_step} " in err and f"Steps 0..{bad_step - 1} are in" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and summary["steps"] == bad_step - 1


@serial_only
@pytest.mark.parametrize("overrides, words", [
    (["initial.u0=x*1e300"], ["initial.u0", "x*1e300", "within"]),
    (["source.momentum=-1e308"], ["source.momentum", "within"]),
    (["model.zeta=1" + "0" * 4400], ["--set", "TOML cannot hold"]),
])
def test_data_that_would_overflow_are_refused_before_anything_is_written(tmp_path, overrides,
                                                                          words):
    out = tmp_path / "run"
    args = [a for o in overrides for a in ("--set", o)]
    one_line(rodfem("run", "paper1", "--out", out, *args), 2, *words)
    assert not out.exists()


@serial_only
def test_extreme_scene_files_are_one_line(tmp_path):
    cases = {
        "digits.toml": "[model]\nzeta = " + "9" * 4301 + "\n",
        "deep.toml": "[model]\nzeta = " + "[" * 1000 + "]" * 1000 + "\n",
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        one_line(rodfem("run", tmp_path / name, "--out", tmp_path / "x"), 2, "scene")
    one_line(rodfem("run", "s" * 300 + ".toml", "--out", tmp_path / "x"), 2, "cannot be read")
    assert not (tmp_path / "x").exists()


@serial_only
@pytest.mark.parametrize("edit, words", [
    (("gap = 0.1", 'gap = "abc"'), ["scene.toml", "obstacle.gap"]),
    (("zeta = 0.2", "zeta = [1]"), ["scene.toml", "model.zeta"]),
])
def test_plot_on_edited_run_files_is_one_line(tmp_path, edit, words):
    out = tmp_path / "run"
    assert rodfem("run", "paper1", "--out", out, "--set", "time.end=0.1").returncode == 0
    scene = out / "scene.toml"
    assert edit[0] in scene.read_text()
    scene.write_text(scene.read_text().replace(*edit))
    one_line(rodfem("plot", out), 2, *words)
    assert not (out / "figures").exists()


@serial_only
def test_plot_on_a_reshaped_mesh_dataset_is_one_line(tmp_path):
    import h5py

    out = tmp_path / "run"
    assert rodfem("run", "paper1", "--out", out, "--set", "time.end=0.1").returncode == 0
    with h5py.File(out / "fields" / "mesh.h5", "r+") as f:
        geometry = f["geometry"][()]
        del f["geometry"]
        f["geometry"] = geometry[:-5]
    one_line(rodfem("plot", out), 2, "fields")


@serial_only
def test_a_run_larger_than_the_disk_is_refused_unless_asked(tmp_path):
    out = tmp_path / "run"
    done = rodfem("run", "paper1", "--out", out, "--set", "time.dt=1e-6", "--set",
                  "time.end=100", "--set", "output.every=1", "--set", "mesh.cells=100000")
    one_line(done, 2, "would write about", "--no-size-check")
    assert not out.exists()


@serial_only
def test_a_full_disk_is_one_line_and_exit_4_and_the_run_resumes(tmp_path, small_disk):
    out = small_disk / "run"
    scene = ["paper1", "--set", "mesh.cells=50", "--set", "time.end=20",
             "--set", "output.checkpoint=0"]
    done = rodfem("run", *scene, "--out", out, "--no-size-check")
    one_line(done, 4, "No space left on device", str(small_disk))
    assert len(history_rows(out)) >= 1  # whole rows, the file readable
    assert state(out) in ("failed", "gone")
    # Room again: the run continues to what it would have been.
    subprocess.run(["mount", "-o", "remount,size=64m", str(small_disk)], check=True)
    assert rodfem("resume", out, "--quiet").returncode == 0
    reference = tmp_path / "reference"
    assert rodfem("run", *scene, "--out", reference, "--quiet").returncode == 0
    assert history_rows(out).tobytes() == history_rows(reference).tobytes()


@serial_only
def test_plot_on_a_full_disk_is_one_line_and_leaves_no_half_image(tmp_path, small_disk):
    out = tmp_path / "run"
    assert rodfem("run", "paper1", "--out", out, "--set", "time.end=0.5").returncode == 0
    (small_disk / "filler").write_bytes(b"\0" * (1024 * 1024 - 64 * 1024))
    done = rodfem("plot", out, "--out", small_disk / "figures")
    one_line(done, 4, "No space left on device")
    for image in (small_disk / "figures").glob("*"):
        assert not image.name.startswith(".")
        from PIL import Image

        Image.open(image).verify()  # whole


@serial_only
def test_paper_says_which_runs_failed_and_exits_3(tmp_path):
    out = tmp_path / "paper"
    done = rodfem("paper", "--out", out, "--set", "time.end=0.2", "--set",
                  "solver.max_iterations=1")
    assert done.returncode == 3, done.stderr
    assert "failed" in done.stderr and "Traceback" not in done.stderr
    index = (out / "index.md").read_text()
    assert "Not reproduced" in index and "paper1" in index
    assert state(out) == "failed"


@serial_only
def test_a_one_step_paper_reproduction_completes(tmp_path):
    done = rodfem("paper", "--out", tmp_path / "paper", "--set", "time.end=0.001")
    assert done.returncode == 0, done.stderr
    assert "fewer than 2 steps" in (tmp_path / "paper" / "index.md").read_text()


@serial_only
@pytest.mark.parametrize("end, sign", [(100, "paper1/rodfem.json"),
                                       (2, "paper5/summary.json")], ids=["runs", "figures"])
def test_paper_stops_on_a_signal_like_run(tmp_path, end, sign):
    """SIGTERM while the experiments run (as soon as the first has begun), or while their
    figures are drawn (as soon as the last run has ended): exit 143 in one line, no index."""
    import signal
    import time

    out = tmp_path / "paper"
    process = subprocess.Popen([RODFEM, "paper", "--out", str(out), "--set", f"time.end={end}"],
                               stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 120
    while not (out / sign).exists():
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.01)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=300)
    assert process.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err and "interrupted by SIGTERM" in err
    assert state(out) in ("interrupted", "failed")
    assert not (out / "index.md").exists()
