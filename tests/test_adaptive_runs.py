"""Adaptive runs as a user runs them: stopped at any instant (Ctrl-C, SIGTERM, SIGKILL; serially
and under mpirun) and resumed to the uninterrupted run bit for bit, extended, left alone when
complete, and refused in one line from a checkpoint whose controller was edited."""

import json
import random
import shutil
import signal

import numpy as np
import pytest
from test_edits import read_npz, snapshot, write_npz
from test_resume import assert_fields_whole, assert_same_run, rodfem, stop_and_resume

from conftest import representative, serial_only
from rodfem.output.checkpoint import digest
from rodfem.output.directories import state
from rodfem.output.readers import read_history

ADAPTIVE = ["--set", "time.adaptive=true", "--set", "output.checkpoint=0.2"]
# About a second of loop (5,600 steps; 14,000) after about a second of start-up.
SCENES = {
    "paper1": ["paper1", "--set", "mesh.cells=100", "--set", "time.end=120",
               "--set", "output.every=500", *ADAPTIVE],
    "impact": ["impact", "--set", "mesh.cells=100", "--set", "time.dt=1e-2",
               "--set", "time.end=30", "--set", "output.every=50", *ADAPTIVE],
}
NAMES = ("t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations", "dt", "event")


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """The uninterrupted runs, made as they are first asked for: (scene, ranks) → directory."""
    root, runs = tmp_path_factory.mktemp("adaptive"), {}

    def run(scene: str, ranks: int):
        if (scene, ranks) not in runs:
            out = root / f"{scene}-n{ranks}"
            rodfem("run", *SCENES[scene], "--out", out, "--quiet", ranks=ranks, check=0)
            runs[scene, ranks] = out
        return runs[scene, ranks]

    return run


def assert_whole(out):
    """A stopped adaptive run's history has whole rows: times that are the sums of its steps."""
    history = read_history(out / "history.h5", empty=True)
    assert history.names == NAMES
    if history.rows.size:
        t, dt = history["t"], history["dt"]
        assert t[0] == 0.0 and dt[0] == 0.0
        np.testing.assert_array_equal(t[1:], t[:-1] + dt[1:])
    assert_fields_whole(out)


def assert_same(out, reference):
    """The uninterrupted run's history and fields, and its counts of steps, rejected steps,
    contact events and contact."""
    assert_same_run(out, reference)
    summary = json.loads((out / "summary.json").read_text())
    expected = json.loads((reference / "summary.json").read_text())
    for key in ("adaptive", "contact"):
        assert summary[key] == expected[key], key


CASES = [("paper1", signal.SIGINT, 1), ("paper1", signal.SIGKILL, 1),
         ("paper1", signal.SIGTERM, 1), ("impact", signal.SIGKILL, 1),
         ("impact", signal.SIGINT, 1), ("impact", signal.SIGTERM, 1),
         ("paper1", signal.SIGKILL, 2), ("impact", signal.SIGUSR1, 2)]
# every signal, both scenes and both rank counts once by default; all of CASES in the full profile
QUICK_CASES = [("paper1", signal.SIGINT, 1), ("paper1", signal.SIGKILL, 1),
               ("impact", signal.SIGKILL, 1), ("impact", signal.SIGTERM, 1),
               ("impact", signal.SIGUSR1, 2)]


@serial_only
@pytest.mark.parametrize("scene, sent, ranks", representative(CASES, QUICK_CASES),
                         ids=[f"{s}-{signal.Signals(k).name}-n{r}" for s, k, r in CASES])
def test_a_stopped_adaptive_run_resumes_to_the_same_run(tmp_path, references, scene, sent,
                                                         ranks):
    """The controller's state (the time, the next step, the last error, the last states) is in
    the checkpoint; the methods of other step sizes are made again by the resumed run. Stopped
    at a random instant after its first checkpoint: in the loop, mostly."""
    delay = random.Random(f"{scene}{sent}{ranks}{tmp_path.name}").uniform(0.0, 0.8)
    stop_and_resume(tmp_path / "run", SCENES[scene], sent, ranks, delay,
                    references(scene, ranks), assert_whole, assert_same, "checkpoint.npz")


SHORT = ["paper1", "--set", "mesh.cells=40", "--set", "output.every=7", *ADAPTIVE]


@serial_only
def test_an_adaptive_run_is_left_alone_when_complete_and_extends_to_a_later_end(tmp_path):
    short, long = tmp_path / "short", tmp_path / "long"
    rodfem("run", *SHORT, "--set", "time.end=5", "--out", short, "--quiet", check=0)
    before = snapshot(short)
    done = rodfem("resume", short)
    assert done.returncode == 0 and "is a complete run (t = 5)" in done.stdout, done.stderr
    assert done.stderr == "" and snapshot(short) == before
    done = rodfem("resume", short, "--set", "time.end=1")
    assert done.returncode == 2 and "before the checkpoint's t = 5" in done.stderr
    assert snapshot(short) == before
    rodfem("resume", short, "--set", "time.end=10", "--quiet", check=0)
    rodfem("run", *SHORT, "--set", "time.end=10", "--out", long, "--quiet", check=0)
    # The run to 5 took a last step to t = 5 exactly, which the run to 10 did not: the
    # extended run is an adaptive run to 10 with a step ending at 5, the same before it.
    a, b = read_history(short / "history.h5"), read_history(long / "history.h5")
    first = int(np.searchsorted(b["t"], 5.0))
    assert a.rows[:first].tobytes() == b.rows[:first].tobytes()
    assert a["t"][first] == 5.0 and a["t"][-1] == b["t"][-1] == 10.0
    summary = json.loads((short / "summary.json").read_text())
    assert summary["adaptive"]["steps"] == len(a.rows) - 1 == summary["steps"]
    assert summary["adaptive"]["events"] == int(a["event"].sum())
    assert summary["resumed"] and summary["status"] == "complete"
    # what the extended run reaches is the uninterrupted run's within the tolerance's reach
    assert abs(a["u_1"][-1] - b["u_1"][-1]) < 1e-2 * np.abs(b["u_1"]).max()


def edited(arrays, meta, change, digested=True):
    """The checkpoint's arrays and metadata after ``change``, its digest made again (as though
    rodfem had written it) or left as it was."""
    arrays = {k: v for k, v in arrays.items() if k != "meta"}
    meta = json.loads(json.dumps(meta))
    change(arrays, meta)
    if digested:
        meta["digest"] = digest(arrays, meta)
    return arrays, meta


def _set(name, value):
    def change(arrays, meta):
        arrays[name] = value(arrays[name].copy())
    return change


def _item(name, index, value):
    def change(arrays, meta):
        arrays[name] = arrays[name].copy()
        arrays[name][index] = value
    return change


def _drop(*names):
    def change(arrays, meta):
        for name in names:
            arrays.pop(name, None) if name in arrays else meta.pop(name, None)
    return change


CONTROLLER_EDITS = {
    "controller cut": _set("controller", lambda a: a[:-1]),
    "controller as float32": _set("controller", lambda a: a.astype(np.float32)),
    "past reshaped": _set("past", lambda a: a.reshape(-1)),
    "past_t with a nan": _item("past_t", 0, np.nan),
    "past_t four long": _set("past_t", lambda a: np.arange(4.0)),
    "past_t not ending at t": _item("past_t", -1, 0.75),
    "time negative": _item("controller", 0, -1.0),
    "next step zero": _item("controller", 1, 0.0),
    "error nan": _item("controller", 2, np.nan),
    "a size infinite": _item("controller", 5, np.inf),
    "past missing": _drop("past"),
    "past emptied": lambda arrays, meta: arrays.update(past=arrays["past"][:0],
                                                       past_t=arrays["past_t"][:0]),
    "controller gone": _drop("controller", "past_t", "past", "adaptive"),
    "counts missing": _drop("adaptive"),
    "counts negative": lambda arrays, meta: meta.update(adaptive={"rejected": -1,
                                                                  "events": 0}),
}


@serial_only
@pytest.mark.parametrize("edit", list(CONTROLLER_EDITS))
@pytest.mark.parametrize("digested", [True, False], ids=["digest made again", ""])
def test_an_edited_controller_is_refused_in_one_line(tmp_path_factory, tmp_path, edit, digested):
    base = tmp_path_factory.getbasetemp() / "controller-edits"
    if not base.exists():
        rodfem("run", *SHORT, "--set", "time.end=1", "--out", base, "--quiet", check=0)
    out = tmp_path / "run"
    shutil.copytree(base, out)
    arrays, meta = read_npz(out / "checkpoint.npz")
    assert "controller" in arrays and set(meta["adaptive"]) == {"rejected", "events"}
    write_npz(out / "checkpoint.npz", *edited(arrays, meta, CONTROLLER_EDITS[edit], digested))
    before = snapshot(out)
    done = rodfem("resume", out, "--set", "time.end=2")
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("rodfem: error: ") and done.stderr.count("\n") == 1, \
        done.stderr
    assert str(out / "checkpoint.npz") in done.stderr
    assert snapshot(out) == before


@serial_only
def test_an_unedited_controller_is_used(tmp_path):
    """The edits' baseline: the same checkpoint, written back with its digest made again and
    nothing changed, resumes."""
    out = tmp_path / "run"
    rodfem("run", *SHORT, "--set", "time.end=1", "--out", out, "--quiet", check=0)
    arrays, meta = read_npz(out / "checkpoint.npz")
    write_npz(out / "checkpoint.npz", *edited(arrays, meta, lambda a, m: None))
    rodfem("resume", out, "--set", "time.end=2", "--quiet", check=0)


# Every method and loop, each scheme, both obstacles: stopped after a given step (in-process),
# resumed from the checkpoint written there.
STOPPED = {
    "picard-cn": ["paper1", "--set", "time.scheme=crank-nicolson", "--set", "time.end=4"],
    "newton": ["paper5", "--set", "solver.method=newton", "--set", "time.end=4"],
    "direct-rigid": ["paper1", "--set", "solver.method=direct", "--set", "obstacle.kind=rigid",
                     "--set", "discretisation.mass=redistributed", "--set", "time.end=2"],
    "impact": ["impact", "--set", "mesh.cells=100", "--set", "time.dt=1e-2",
               "--set", "time.end=4"],
}


@serial_only
@pytest.mark.parametrize("scene", list(STOPPED))
def test_an_adaptive_run_stopped_after_any_step_resumes_to_the_same_run(tmp_path, monkeypatch,
                                                                       scene):
    """Stopped at the end of steps chosen through the run (at a contact event, and where the
    estimate starts again after it, among them), each time resumed from the checkpoint written
    there: the uninterrupted run, bit for bit."""
    from test_edits import rodfem as in_process

    from rodfem.output import interrupts
    from rodfem.solver.adaptive.compiled import CompiledSteps
    from rodfem.solver.adaptive.stepper import AdaptiveStepper

    args = [*STOPPED[scene], *ADAPTIVE, "--set", "output.every=20"]
    reference, out = tmp_path / "reference", tmp_path / "run"
    assert in_process("run", *args, "--out", reference, "--quiet").returncode == 0
    h = read_history(reference / "history.h5")
    events = np.flatnonzero(h["event"])
    assert events.size >= 2
    rows = {len(h.rows) // 5, int(events[0]), int(events[0]) + 2, int(events[-1]) + 3,
            len(h.rows) // 2}
    stops = {float(h["t"][k]) for k in rows}
    step, advance, reached = AdaptiveStepper.step, CompiledSteps.advance, []

    def stepping(self):
        step(self)
        reached.append(self.t)

    def advancing(self, max_steps, interval, frame):  # one compiled step a call
        code = advance(self, 1, interval, frame)
        reached.append(self.stepper.t if self.written else None)  # None: no step taken
        return code

    def requested(comm, n, every, also=False):  # after each step of the stepper or loop
        return reached[-1] in stops or also

    stopped = 0
    with monkeypatch.context() as patch:
        patch.setattr(AdaptiveStepper, "step", stepping)
        patch.setattr(CompiledSteps, "advance", advancing)
        patch.setattr(interrupts, "requested", requested)
        done = in_process("run", *args, "--out", out, "--quiet")
        while state(out) == "interrupted" and stopped < 2 * len(stops):
            stopped += 1
            done = in_process("resume", out, "--quiet")
    assert done.returncode == 0 and stopped >= 4, (stopped, done.stderr)
    assert json.loads((out / "summary.json").read_text())["resumed"]
    assert_same(out, reference)


KILLER = """
import os, signal, sys
from rodfem.cli import main
from rodfem.solver.adaptive.compiled import CompiledSteps
from rodfem.solver.adaptive.stepper import AdaptiveStepper

step, advance, end = AdaptiveStepper.step, CompiledSteps.advance, float(sys.argv[1])

def stepping(self):  # SIGKILL once the run reaches the time argv[1]
    step(self)
    if self.t >= end:
        os.kill(os.getpid(), signal.SIGKILL)

def advancing(self, max_steps, interval, frame):  # the same, one compiled step a call
    code = advance(self, 1, interval, frame)
    if self.stepper.t >= end:
        os.kill(os.getpid(), signal.SIGKILL)
    return code

AdaptiveStepper.step, CompiledSteps.advance = stepping, advancing
sys.exit(main(sys.argv[2:]))
"""


@serial_only
@pytest.mark.parametrize("scene", representative(list(STOPPED), ["impact"]))
def test_an_adaptive_run_killed_again_and_again_resumes_to_the_same_run(tmp_path, scene):
    """SIGKILL at chosen times (after a contact event among them), each time resumed from the
    last checkpoint (one at every field save, saved nearly every step: after the first of two
    halves too, where none may be written) and killed again further on: the uninterrupted run,
    bit for bit."""
    import subprocess
    import sys

    from test_edits import rodfem as in_process

    args = [*STOPPED[scene], *ADAPTIVE, "--set", "output.every=2", "--set",
            "output.checkpoint=0"]
    reference, out = tmp_path / "reference", tmp_path / "run"
    assert in_process("run", *args, "--out", reference, "--quiet").returncode == 0
    h = read_history(reference / "history.h5")
    events = np.flatnonzero(h["event"])
    kills = sorted({float(h["t"][k]) for k in (len(h.rows) // 4, int(events[0]) + 1,
                                                int(events[-1]) + 2)})
    command = ["run", *args, "--out", str(out), "--quiet"]
    for t in kills:
        killed = subprocess.run([sys.executable, "-c", KILLER, str(t), *command],
                                capture_output=True, text=True, timeout=600)
        assert killed.returncode == -signal.SIGKILL, killed.stderr
        assert state(out) == "gone"
        command = ["resume", str(out), "--quiet"]
    assert in_process(*command).returncode == 0
    assert json.loads((out / "summary.json").read_text())["resumed"]
    assert_same(out, reference)
