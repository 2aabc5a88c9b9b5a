"""The progress bar: drawn on a terminal once a run has lasted its delay, silent otherwise; and an
interrupted run (Ctrl-C) keeps its results and says so."""

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import history_rows, serial_only
from rodfem.output.progress import Progress


def test_progress_draws_after_its_delay():
    stream = io.StringIO()
    bar = Progress(100, enabled=True, delay=0.0, stream=stream)
    bar.update(50)
    bar.close()
    text = stream.getvalue()
    assert "50.0%" in text and "step 50/100" in text and text.endswith("\n")


def test_progress_of_adaptive_steps_shows_the_time():
    """Adaptive steps: the fraction of the time, the time and the steps taken so far (their
    number is not known in advance)."""
    stream = io.StringIO()
    bar = Progress(120.0, enabled=True, delay=0.0, stream=stream, of_time=True)
    bar.update(30.0, 812)
    bar.close()
    text = stream.getvalue()
    assert "25.0%" in text and "t 30/120 (812 steps)" in text and "step " not in text


def test_progress_is_quiet_for_short_runs_and_off_terminals():
    for enabled, delay in ((True, 3600.0), (False, 0.0)):
        stream = io.StringIO()
        bar = Progress(100, enabled=enabled, delay=delay, stream=stream)
        bar.update(50)
        bar.close()
        assert stream.getvalue() == ""


@serial_only
@pytest.mark.parametrize("ranks, sent", [(1, signal.SIGINT), (2, signal.SIGUSR1)],
                         ids=["Ctrl-C", "mpirun -n 2, SIGUSR1"])
def test_interrupt_keeps_results(tmp_path, ranks, sent):
    """The run stops at the end of a step: every file whole, history and summary agreeing."""
    out = tmp_path / "run"
    rodfem = Path(sys.executable).with_name("rodfem")
    command = [str(rodfem), "run", "paper1", "--out", str(out), "--set", "time.end=400"]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 120
    while not (out / "fields.xdmf").exists():  # written once the set-up is done
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.1)
    time.sleep(1.0)  # in the loop
    process.send_signal(sent)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 128 + sent
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert 0 < summary["steps"] < 400_000
    assert len(history_rows(out)) == summary["steps"] + 1  # steps 0..N
    assert f"interrupted by {sent.name}; steps 0..{summary['steps']} are in" in err
