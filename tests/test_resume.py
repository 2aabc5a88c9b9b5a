"""Runs stopped at any instant (Ctrl-C, SIGTERM, SIGHUP, SIGKILL; in start-up or in the loop;
serially and under mpirun) leave whole files, and `rodfem resume` continues them to the history
and fields of an uninterrupted run, bit for bit. Also: extending a finished run, and what resume
refuses."""

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from xml.etree import ElementTree

import h5py
import numpy as np
import pytest
from test_edits import snapshot

from conftest import representative, serial_only
from rodfem.output.atomic import TEMPORARY
from rodfem.output.checkpoint import read_checkpoint
from rodfem.output.directories import state
from rodfem.output.readers import read_fields, read_history
from rodfem.output.writers import LOCK, MARKER

RODFEM = str(Path(sys.executable).with_name("rodfem"))
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "OMPI_ALLOW_RUN_AS_ROOT": "1",
       "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_rmaps_base_oversubscribe": "1"}
# About a second of loop after about a second of start-up; a checkpoint every 0.2 s.
SCENE = ["paper1", "--set", "mesh.cells=100", "--set", "time.end=120",
         "--set", "output.every=500", "--set", "output.checkpoint=0.2"]


def rodfem(*args, ranks=1, check=None):
    command = [RODFEM, *map(str, args)]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    done = subprocess.run(command, capture_output=True, text=True, env=ENV, timeout=600)
    if check is not None:
        assert done.returncode == check, done.stderr
    return done


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run, serially and on two ranks."""
    root = tmp_path_factory.mktemp("reference")
    runs = {}
    for ranks in (1, 2):
        out = root / f"n{ranks}"
        rodfem("run", *SCENE, "--out", out, "--quiet", ranks=ranks, check=0)
        runs[ranks] = out
    return runs


def assert_whole(out: Path) -> None:
    """Every file of a stopped run is whole: history.h5 has only whole rows, the fields up to
    the last checkpoint are readable, the marker and checkpoint parse."""
    history = read_history(out / "history.h5", empty=True)
    assert history.names == ("t", "u_1", "u_half", "ut_1", "sigma_1", "energy", "iterations")
    rows = history.rows
    assert rows.shape[1:] == (7,) or rows.size == 0
    if rows.size:
        np.testing.assert_array_equal(np.rint(rows[:, 0] / 1e-3), np.arange(len(rows)))
    assert_fields_whole(out)
    json.loads((out / "rodfem.json").read_text())


def assert_fields_whole(out: Path) -> None:
    """fields.xdmf is whole and lists readable steps: at least those its checkpoint counts. A
    segment is written before fields.xdmf lists it, so a run killed between the two leaves a
    segment that no file counts yet (the resumed run writes it again)."""
    counted = read_checkpoint(out)[1]["saves"] if (out / "checkpoint.npz").exists() else []
    if not (out / "fields.xdmf").exists():
        assert not counted
        return
    if ElementTree.parse(out / "fields.xdmf").getroot().find(".//Time") is None:
        assert not counted, "the checkpoint counts saves that fields.xdmf does not list"
        return
    saved = read_fields(out / "fields.xdmf").t
    assert {t for _, t, _, _ in counted} <= set(saved.tolist())


def assert_unmarked(out: Path, killed: bool) -> None:
    """What a run stopped before it marked its directory leaves. rodfem makes the directory,
    takes its lock (rodfem.lock), then writes its marker (write-then-rename) and scene.toml,
    the three with signals deferred: a signal leaves nothing, and a kill (``killed``) may leave
    the directory, empty or holding the lock and perhaps the marker's temporary file."""
    if not killed:
        assert not out.exists()
        return
    left = [p.name for p in out.iterdir()] if out.exists() else []
    assert all(name == LOCK or ((m := TEMPORARY.match(name)) is not None and m["name"] == MARKER)
               for name in left), left


def assert_same_run(out: Path, reference: Path) -> None:
    a, b = read_history(out / "history.h5"), read_history(reference / "history.h5")
    assert a.names == b.names and a.rows.tobytes() == b.rows.tobytes()
    a, b = read_fields(out / "fields.xdmf"), read_fields(reference / "fields.xdmf")
    assert a.names == b.names
    for name in ("t", "x", *a.names):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    summary = json.loads((out / "summary.json").read_text())
    expected = json.loads((reference / "summary.json").read_text())
    for key in ("status", "steps", "iterations_total", "iterations_max", "iterations_mean",
                "energy_non_increasing", "energy_max_increase"):
        assert summary[key] == expected[key], key


CASES = [(signal.SIGINT, 1), (signal.SIGTERM, 1), (signal.SIGHUP, 1), (signal.SIGKILL, 1),
         (signal.SIGTERM, 1), (signal.SIGKILL, 1), (signal.SIGUSR1, 2), (signal.SIGKILL, 2)]
# (the second SIGTERM and SIGKILL, at other instants, in the full profile)


@serial_only
@pytest.mark.parametrize("sent, ranks", representative(CASES, CASES[:4] + CASES[6:]),
                         ids=[f"{signal.Signals(s).name}-n{r}-{i}" for i, (s, r) in
                              enumerate(CASES)])
def test_stopped_anywhere_resumes_to_the_same_run(tmp_path, reference, sent, ranks):
    delay = random.Random(f"{sent}{ranks}{tmp_path.name}").uniform(0.3, 2.5 * ranks)
    stop_and_resume(tmp_path / "run", SCENE, sent, ranks, delay, reference[ranks])


def stop_and_resume(out: Path, scene: list, sent: int, ranks: int, delay: float,
                    reference: Path, whole=assert_whole, same=assert_same_run,
                    after: str | None = None) -> None:
    """``rodfem run`` of ``scene`` stopped by ``sent`` after ``delay`` seconds (counted from
    when the file ``after`` of the run appears, if given): its files whole (``whole``), its
    marker saying how it stopped, and ``rodfem resume`` continues it to the ``reference`` run
    (``same``)."""
    command = [RODFEM, "run", *scene, "--out", str(out), "--quiet"]
    if ranks > 1:
        command = ["mpirun", "-n", str(ranks), *command]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 120
    while after is not None and not (out / after).exists() and process.poll() is None:
        assert time.monotonic() < deadline, f"the run wrote no {after}"
        time.sleep(0.02)
    time.sleep(delay)
    if ranks > 1 and sent == signal.SIGKILL:  # a node lost: every rank killed at once
        subprocess.run(["pkill", "-KILL", "-f", f"rodfem run .*{out}"], check=False)
    else:
        process.send_signal(sent)
    _, err = process.communicate(timeout=300)
    # every rank gone, and its lock with it (on Debian 13 under mpirun the lock was once seen
    # still held just after the last rank had gone)
    deadline = time.monotonic() + 30
    while subprocess.run(["pgrep", "-f", f"rodfem run .*{out}"],
                         capture_output=True).returncode == 0 or (
            out.exists() and state(out) == "running"):
        assert time.monotonic() < deadline, "a rank, or the run's lock, outlived the kill"
        time.sleep(0.1)
    code = process.returncode
    print(f"\n{signal.Signals(sent).name} n{ranks} after {delay:.2f} s: exit {code}, "
          f"{state(out) if out.exists() else 'nothing written'}")
    if code == 0 or (out.exists() and state(out) == "complete"):
        same(out, reference)  # the run ended before the signal came
        return
    # Under mpirun a signal outside the time loop ("stopped during start-up", "stopped outside a
    # time loop") in one rank ends the others (MPI_Abort, or the launcher once it has exited),
    # which may end rank 0 as SIGKILL would: before it has written its scene, or before it has
    # marked its directory at all (once marked, the marker says interrupted all the same).
    aborted = ranks > 1 and sent != signal.SIGKILL and "; stopped " in err
    killed = sent == signal.SIGKILL or aborted
    if sent != signal.SIGKILL:
        lines = err.strip().splitlines()
        if ranks == 1:
            assert code == 128 + sent, err
        assert "Traceback" not in err
        ours = [line for line in lines if line.startswith("rodfem")]  # mpirun has its own
        assert ours and ours[-1].startswith("rodfem: interrupted"), err
    def taken_over_by_force():  # a directory that resume cannot continue: run again
        rodfem("run", *scene, "--out", out, "--quiet", "--force", ranks=ranks, check=0)
        same(out, reference)

    if not (out / MARKER).exists():  # stopped before the directory was marked
        assert_unmarked(out, killed)
        if out.exists() and any(out.iterdir()):
            taken_over_by_force()
        return
    if sent == signal.SIGKILL:
        assert state(out) == "gone"
    else:  # under mpirun too: a rank that ends the others records rank 0's stop first
        assert state(out) == "interrupted"

    if not (out / "scene.toml").exists():  # killed between the marker and the scene
        assert killed
        before = snapshot(out)
        refused = rodfem("resume", out, ranks=ranks)
        assert refused.returncode == 2 and "has no scene.toml" in refused.stderr, refused.stderr
        after = snapshot(out)  # the lock's holder is named while held, wiped after
        assert len(refused.stderr.strip().splitlines()) == 1
        assert {k: v for k, v in after.items() if k != LOCK} == {
            k: v for k, v in before.items() if k != LOCK}
        taken_over_by_force()
        return
    if (out / "history.h5").exists():
        whole(out)
    again = rodfem("resume", out, "--quiet", ranks=ranks)
    assert again.returncode == 0, again.stderr
    assert state(out) == "complete"
    same(out, reference)


@serial_only
def test_a_finished_run_extends_to_a_later_end(tmp_path):
    short, long = tmp_path / "short", tmp_path / "long"
    scene = ["paper1", "--set", "mesh.cells=40", "--set", "output.every=7"]
    rodfem("run", *scene, "--set", "time.end=0.5", "--out", short, "--quiet", check=0)
    before = snapshot(short)
    # nothing to do: exit 0 (a job script that always resumes after a requeue goes on), one line
    done = rodfem("resume", short)
    assert done.returncode == 0 and "is a complete run" in done.stdout, done.stderr
    assert done.stdout.count("\n") == 1 and done.stderr == ""
    assert snapshot(short) == before
    rodfem("resume", short, "--set", "time.end=1", "--quiet", check=0)
    rodfem("run", *scene, "--set", "time.end=1", "--out", long, "--quiet", check=0)
    assert_same_run(short, long)
    assert "end = 1" in (short / "scene.toml").read_text()


EXCHANGES = {"constant": [], "pressure": ["--set", "heat_exchange.law=pressure", "--set",
                                         "heat_exchange.k1=40", "--set", "obstacle.temperature=25"]}


@serial_only
@pytest.mark.parametrize("ranks, exchange", representative(
    [(1, "constant"), (2, "constant"), (1, "pressure")], [(2, "constant"), (1, "pressure")]))
def test_chosen_outputs_resume_to_the_same_run(tmp_path, ranks, exchange):
    """Probes, added quantities and chosen fields continue bit for bit, as the defaults do (a
    heat exchange that depends on the contact pressure too)."""
    short, long = tmp_path / "short", tmp_path / "long"
    scene = ["paper1", *EXCHANGES[exchange], "--set", "mesh.cells=40", "--set", "output.every=7",
             "--set", "output.probes=[0.3, 0.5, 1]", "--set", "output.checkpoint=0",
             "--set", 'output.history=["theta_1", "heat_flux_1", "contact_force", "contact"]',
             "--set", 'output.fields=["u", "velocity", "heat_flux"]']
    # stopped at t = 0.25, in contact (from t = 0.179 on)
    rodfem("run", *scene, "--set", "time.end=0.25", "--out", short, "--quiet", ranks=ranks,
           check=0)
    rodfem("resume", short, "--set", "time.end=0.5", "--quiet", ranks=ranks, check=0)
    rodfem("run", *scene, "--set", "time.end=0.5", "--out", long, "--quiet", ranks=ranks,
           check=0)
    assert_same_run(short, long)
    header = ",".join(read_history(short / "history.h5").names)
    assert header.endswith(",contact,u@0.3,theta@0.3,sigma@0.3,u@0.5,theta@0.5,sigma@0.5,"
                           "u@1,theta@1,sigma@1")
    assert read_fields(short / "fields.xdmf").names == ("u", "velocity", "heat_flux")


@serial_only
def test_resume_refuses_what_it_cannot_continue_exactly(tmp_path):
    out = tmp_path / "run"
    rodfem("run", "paper1", "--set", "mesh.cells=20", "--set", "time.end=0.2", "--out", out,
           "--quiet", check=0)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    marker = (out / "rodfem.json").read_bytes()
    cases = [
        (["--set", "model.zeta=1"], "only time.end can be changed"),
        (["--set", "time.end=0.1"], "is before the checkpoint"),
    ]
    for extra, message in cases:
        done = rodfem("resume", out, *extra)
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1
        assert (out / "rodfem.json").read_bytes() == marker  # a refusal changes nothing
    done = rodfem("resume", out, "--set", "time.end=0.4", ranks=2)
    assert done.returncode == 2 and "mpirun -n 1" in done.stderr, done.stderr
    (out / "scene.toml").write_text((out / "scene.toml").read_text().replace("zeta = 0.2",
                                                                             "zeta = 0.3"))
    done = rodfem("resume", out, "--set", "time.end=0.4")
    assert done.returncode == 2 and "was it edited" in done.stderr
    (out / "scene.toml").write_bytes(before["scene.toml"])
    history = out / "history.h5"
    with h5py.File(history, "a") as file:  # one number of one row changed by an ulp
        file["history"][100, 1] = np.nextafter(file["history"][100, 1], 1.0)
    done = rodfem("resume", out, "--set", "time.end=0.4")
    assert done.returncode == 2 and "no longer holds the rows" in done.stderr, done.stderr
    for damaged in (before["history.h5"][:-3000], b"junk" * 1000):
        history.write_bytes(damaged)
        done = rodfem("resume", out, "--set", "time.end=0.4")
        assert done.returncode == 2 and "cannot read" in done.stderr, done.stderr
        assert str(history) in done.stderr and len(done.stderr.strip().splitlines()) == 1
    history.write_bytes(before["history.h5"])
    for damaged in (b"not a checkpoint", before["checkpoint.npz"][:5000]):
        (out / "checkpoint.npz").write_bytes(damaged)
        done = rodfem("resume", out, "--set", "time.end=0.4")
        assert done.returncode == 2 and "not a readable checkpoint" in done.stderr, done.stderr
        assert len(done.stderr.strip().splitlines()) == 1
    for name in ("history.h5", "summary.json", "scene.toml"):
        assert (out / name).read_bytes() == before[name]
    assert state(out) == "complete"
    assert (out / "rodfem.json").read_bytes() == marker
    for target in (tmp_path / "missing", tmp_path):
        done = rodfem("resume", target)
        assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1


@serial_only
def test_plot_of_a_killed_run_says_the_process_is_gone(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen([RODFEM, "run", *SCENE, "--set", "time.end=1000", "--out",
                                str(out), "--quiet"], env=ENV)
    deadline = time.monotonic() + 120
    while not (out / "fields" / "steps-000001.h5").exists():  # two checkpoints written
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.05)
    process.kill()
    process.wait()
    assert state(out) == "gone"
    assert_whole(out)
    done = rodfem("plot", out)
    assert done.returncode == 0, done.stderr
    assert "the process is gone" in done.stderr and f"rodfem resume {out}" in done.stderr
    assert (out / "figures" / "contact.png").stat().st_size > 0


@serial_only
def test_a_run_killed_after_its_last_checkpoint_is_completed_by_resume(tmp_path, reference):
    """Killed between its final checkpoint and its marker: resume has no step left to take, and
    writes what the run did not (summary.json, the final marker)."""
    out = tmp_path / "run"
    shutil.copytree(reference[1], out)
    marker = json.loads((out / "rodfem.json").read_text())
    marker.update(status="running", pid=2**22 + 1)
    marker.pop("finished")
    (out / "rodfem.json").write_text(json.dumps(marker))
    (out / "summary.json").unlink()
    assert state(out) == "gone"
    rodfem("resume", out, "--quiet", check=0)
    assert state(out) == "complete"
    assert_same_run(out, reference[1])


@serial_only
def test_an_ignored_hangup_stays_ignored(tmp_path):
    """Started under nohup (SIGHUP ignored), a run goes on when its terminal closes."""
    out = tmp_path / "run"
    process = subprocess.Popen(
        [RODFEM, "run", "paper1", "--set", "time.end=20", "--out", str(out), "--quiet"], env=ENV,
        preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    time.sleep(2.0)
    process.send_signal(signal.SIGHUP)
    assert process.wait(timeout=120) == 0
    assert state(out) == "complete"


@serial_only
@pytest.mark.parametrize("damage", ["junk", "zeroed", "cut", "missing", "mesh", "other run's"])
def test_resume_refuses_a_segment_of_fields_that_is_not_the_checkpoint_s(tmp_path, damage):
    """Each segment and the mesh are checked by their SHA-256 before anything changes: a file
    replaced by junk, zeroed, cut, missing or another run's is refused in one line naming it, and
    every file stays as it was."""
    out, other = tmp_path / "run", tmp_path / "other"
    scene = ["paper1", "--set", "mesh.cells=20", "--set", "time.end=0.2",
             "--set", "output.every=10", "--set", "output.checkpoint=0"]
    rodfem("run", *scene, "--out", out, "--quiet", check=0)
    segment = out / "fields" / ("mesh.h5" if damage == "mesh" else "steps-000003.h5")
    data = segment.read_bytes()
    if damage == "junk":
        segment.write_bytes(b"junk" * (len(data) // 4))
    elif damage == "zeroed":
        segment.write_bytes(bytes(len(data)))
    elif damage == "cut":
        segment.write_bytes(data[:len(data) // 2])
    elif damage == "missing":
        segment.unlink()
    elif damage == "mesh":
        segment.write_bytes(data.replace(b"\x00\x00\x00\x00\x00\x00\xf0?", b"\x00" * 8, 1))
        assert segment.read_bytes() != data
    else:
        rodfem("run", *scene, "--set", "model.zeta=0.3", "--out", other, "--quiet", check=0)
        shutil.copyfile(other / "fields" / segment.name, segment)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    done = rodfem("resume", out, "--set", "time.end=0.3")
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("rodfem: error: ") and str(segment) in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert state(out) == "complete"


@serial_only
@pytest.mark.parametrize("ranks", [1, 2])
def test_a_history_of_every_nth_step_resumes_to_the_same_run(tmp_path, ranks):
    """output.history_every = 3: the rows of the steps 0, 3, 6, …, and a run stopped and
    resumed (at a step that is not a multiple of 3) holds what an uninterrupted one does."""
    short, long = tmp_path / "short", tmp_path / "long"
    scene = ["paper1", "--set", "mesh.cells=40", "--set", "output.every=7",
             "--set", "output.history_every=3", "--set", "output.probes=[0.5]"]
    # stopped at t = 0.25, in contact (from t = 0.179 on)
    rodfem("run", *scene, "--set", "time.end=0.25", "--out", short, "--quiet", ranks=ranks,
           check=0)
    rodfem("resume", short, "--set", "time.end=0.5", "--quiet", ranks=ranks, check=0)
    rodfem("run", *scene, "--set", "time.end=0.5", "--out", long, "--quiet", ranks=ranks,
           check=0)
    assert_same_run(short, long)
    rows = read_history(long / "history.h5")
    np.testing.assert_array_equal(np.rint(rows["t"] / 1e-3), np.arange(0, 501, 3))


@serial_only
def test_rows_written_after_the_checkpoint_are_cut_back(tmp_path):
    """A run killed after it wrote rows of history.h5 but before the checkpoint that counts
    them: resume keeps the checkpoint's rows only (checked by their digest) and continues to the
    uninterrupted run's history, bit for bit."""
    short, long = tmp_path / "short", tmp_path / "long"
    scene = ["paper1", "--set", "mesh.cells=40", "--set", "output.every=7"]
    rodfem("run", *scene, "--set", "time.end=0.5", "--out", short, "--quiet", check=0)
    with h5py.File(short / "history.h5", "a") as file:  # rows of steps the checkpoint lacks
        data = file["history"]
        data.resize(data.shape[0] + 5, axis=0)
        data[-5:] = 1.0e300
    rodfem("resume", short, "--set", "time.end=1", "--quiet", check=0)
    rodfem("run", *scene, "--set", "time.end=1", "--out", long, "--quiet", check=0)
    assert_same_run(short, long)


@serial_only
def test_an_extended_run_saves_its_fields_at_the_stride_of_its_new_end(tmp_path):
    """At the default output.every = 0 the stride follows the run's length: extended from 12,000
    steps (a frame every 100) to 30,000 (every 200), the frames off the new stride are left out,
    and the run is the uninterrupted one's, fields and history, bit for bit."""
    short, long = tmp_path / "short", tmp_path / "long"
    scene = ["paper1", "--set", "mesh.cells=20"]
    rodfem("run", *scene, "--set", "time.end=12", "--out", short, "--quiet", check=0)
    assert read_fields(short / "fields.xdmf").t.size == 12_000 // 100 + 1
    rodfem("resume", short, "--set", "time.end=30", "--quiet", check=0)
    rodfem("run", *scene, "--set", "time.end=30", "--out", long, "--quiet", check=0)
    assert_same_run(short, long)
    steps = np.rint(read_fields(short / "fields.xdmf").t / 1e-3).astype(int)
    np.testing.assert_array_equal(steps, np.arange(0, 30_001, 200))


@serial_only
@pytest.mark.parametrize("ranks", [1, 2])
def test_a_live_run_whose_lock_was_removed_is_not_taken(tmp_path, reference, ranks):
    """The lock of a running run removed: resume and run --force still see the live process
    (its marker names it) and refuse in one line; the run takes a new lock at its next
    checkpoint and ends as an uninterrupted run."""
    out = tmp_path / "run"
    # the reference's steps and a few more: the commands try while rank 0 is held still (below)
    end = 125
    command = [RODFEM, "run", *SCENE, "--set", f"time.end={end}", "--out", str(out), "--quiet"]
    process = subprocess.Popen(["mpirun", "-n", str(ranks), *command] if ranks > 1 else command,
                               env=ENV)
    deadline = time.monotonic() + 120
    while not (out / "rodfem.lock").exists() or not (out / "rodfem.lock").stat().st_size \
            or not (out / "rodfem.json").exists():  # held, then marked
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.02)
    (out / "rodfem.lock").unlink()
    # The run's rank 0 held still while the others try, so that it cannot end meanwhile (the
    # other ranks wait for it at their next exchange).
    writer = json.loads((out / "rodfem.json").read_text())["pid"]
    os.kill(writer, signal.SIGSTOP)
    try:
        for args in (["resume", out], ["resume", out, "--set", "time.end=200"],
                     ["run", *SCENE, "--out", out, "--force"]):
            done = rodfem(*args, ranks=ranks)
            lines = [line for line in done.stderr.splitlines() if line.startswith("rodfem")]
            assert done.returncode == 2 and len(lines) == 1, done.stderr
            assert "is in use by rodfem run (pid" in lines[0], done.stderr
        assert process.poll() is None  # refused while it ran
    finally:
        os.kill(writer, signal.SIGCONT)
    assert process.wait(timeout=300) == 0
    assert (out / "rodfem.lock").read_bytes() == b""  # taken again, and released
    assert state(out) == "complete"
    # the reference's rows first, then the rest, each step once: no other process wrote it
    rows = read_history(out / "history.h5").rows
    first = read_history(reference[ranks] / "history.h5").rows
    assert rows[:len(first)].tobytes() == first.tobytes()
    assert len(rows) == end * 1000 + 1
    np.testing.assert_array_equal(np.rint(rows[:, 0] / 1e-3), np.arange(end * 1000 + 1))


@serial_only
def test_a_marker_of_a_dead_process_whose_number_was_reused_is_not_live(tmp_path):
    """A killed run's process number given to a later process: that process started after the
    run marked its directory, so it is not the run, and resume goes on."""
    from rodfem.output.writers import live_writer

    marker = {"status": "running", "command": "run", "pid": os.getppid(),
              "host": __import__("socket").gethostname(), "started": "2000-01-01T00:00:00+0000"}
    assert live_writer(marker) is None
    marker["started"] = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    assert live_writer(marker).startswith(f"rodfem run (pid {os.getppid()} on")
    assert live_writer({**marker, "status": "complete"}) is None
    assert live_writer({**marker, "host": "elsewhere"}) is None
    assert live_writer({**marker, "pid": "1"}) is None


@serial_only
def test_a_marker_of_a_killed_process_not_yet_reaped_is_not_live():
    """A run killed under mpirun whose launcher died too is left a zombie where no init reaps
    it: it writes nothing any more, so its directory is free."""
    from rodfem.output.writers import live_writer

    child = subprocess.Popen(["sleep", "30"])
    try:
        marker = {"status": "running", "command": "run", "pid": child.pid,
                  "host": __import__("socket").gethostname(),
                  "started": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        assert live_writer(marker) is not None
        child.kill()
        deadline = time.monotonic() + 10
        while Path(f"/proc/{child.pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert live_writer(marker) is None  # not reaped yet: os.kill(pid, 0) still succeeds
    finally:
        child.kill()
        child.wait()


@serial_only
def test_resume_applies_the_size_check_of_run(small_disk):
    out = small_disk / "run"
    scene = ["paper1", "--set", "mesh.cells=20", "--set", "time.end=0.1"]
    rodfem("run", *scene, "--out", out, "--quiet", check=0)
    before = snapshot(out)
    done = rodfem("resume", out, "--set", "time.end=100")  # about 17 MB into 1 MiB
    assert done.returncode == 2 and "would write about" in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1 and "--no-size-check" in done.stderr
    assert snapshot(out) == before


@serial_only
def test_resume_on_a_full_disk_names_the_file_and_exits_4(tmp_path, small_disk):
    out = small_disk / "run"
    scene = ["paper1", "--set", "mesh.cells=20", "--set", "output.every=7"]
    rodfem("run", *scene, "--set", "time.end=0.1", "--out", out, "--quiet", check=0)
    before = snapshot(out)
    filler = small_disk / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT)
    try:
        with pytest.raises(OSError):  # the disk full
            while True:
                os.write(fd, b"\0" * 4096)
    finally:
        os.close(fd)
    done = rodfem("resume", out, "--set", "time.end=0.2", "--no-size-check")
    assert done.returncode == 4, done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert f"cannot write {out / 'scene.toml'}: No space left on device" in done.stderr
    assert snapshot(out) == before
    filler.unlink()  # room again: the same command continues it
    rodfem("resume", out, "--set", "time.end=0.2", "--quiet", check=0)
    reference = tmp_path / "reference"
    rodfem("run", *scene, "--set", "time.end=0.2", "--out", reference, "--quiet", check=0)
    assert_same_run(out, reference)


@serial_only
def test_a_signal_stops_one_simulate_call_and_not_the_next(monkeypatch):
    """Ctrl-C during rodfem.simulate stops that run (interrupted, at the end of a step); the
    next call runs whole, and the caller's handler is back."""
    import rodfem
    from rodfem.output.progress import Progress

    handler = signal.getsignal(signal.SIGINT)
    update = Progress.update

    def interrupting(self, n):
        os.kill(os.getpid(), signal.SIGINT)  # in the time loop: noted, not raised
        update(self, n)

    scene = {"mesh.cells": 20, "time.end": 0.2}
    with monkeypatch.context() as patch:
        patch.setattr(Progress, "update", interrupting)
        stopped = rodfem.simulate("paper1", scene)
    assert stopped.status == "interrupted" and len(stopped.history) < 201
    assert signal.getsignal(signal.SIGINT) is handler
    again = rodfem.simulate("paper1", scene)
    assert again.status == "complete" and len(again.history) == 201


@serial_only
def test_a_signal_stops_one_sweep_call_and_not_the_next(monkeypatch):
    """Ctrl-C during rodfem.sweep stops that sweep (interrupted); the next call runs whole."""
    import rodfem
    from rodfem.studies.sweep import dealing

    run_scene = dealing.run_scene

    def interrupting(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # in the sweep's loop: noted, not raised
        return run_scene(*args, **kwargs)

    spec = {"scene": "paper1", "set": {"mesh.cells": 20, "time.end": 0.05},
            "grid": {"model.k": [1, 2, 3]}}
    with monkeypatch.context() as patch:
        patch.setattr(dealing, "run_scene", interrupting)
        stopped = rodfem.sweep(spec)
    assert stopped.status == "interrupted" and len(stopped) < 3
    again = rodfem.sweep(spec)
    assert again.status == "complete" and len(again) == 3


@serial_only
def test_a_rank_that_ends_the_others_records_rank_0s_stop_first(tmp_path):
    """Under mpirun, rank 1 stopped in start-up ends every rank (MPI_Abort) while rank 0 is deaf
    to signals (a test hook holds it after it marked the directory, as compiled code would) and
    is then ended as a kill would end it: the marker reads interrupted, not gone, because rank 1
    recorded it first; resume continues the run to the uninterrupted one."""
    from rodfem.output.handover import PAUSE

    out, reference = tmp_path / "run", tmp_path / "reference"
    scene = ["paper1", "--set", "mesh.cells=20", "--set", "time.end=0.2"]
    process = subprocess.Popen(["mpirun", "-n", "2", RODFEM, "run", *scene, "--out", str(out),
                                "--quiet"], stderr=subprocess.PIPE, text=True,
                               env={**ENV, PAUSE: "120"})
    deadline = time.monotonic() + 120
    while (marker := read_marker_of(out)) is None:
        assert time.monotonic() < deadline and process.poll() is None
        time.sleep(0.02)
    ranks = subprocess.run(["pgrep", "-f", f"rodfem run .*{out}"], capture_output=True,
                           text=True).stdout.split()
    others = [int(p) for p in ranks if int(p) not in (marker["pid"], process.pid)]
    assert len(others) == 1, (ranks, marker["pid"], process.pid)
    os.kill(others[0], signal.SIGUSR1)
    while Path(f"/proc/{others[0]}").exists() and \
            Path(f"/proc/{others[0]}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
        assert time.monotonic() < deadline, "rank 1 did not end"
        time.sleep(0.02)
    os.kill(marker["pid"], signal.SIGKILL)  # rank 0 ended by the abort before it could write
    _, err = process.communicate(timeout=120)
    assert process.returncode != 0
    assert state(out) == "interrupted"
    assert "rodfem: interrupted by SIGUSR1; stopped outside a time loop" in err, err
    assert f"'rodfem resume {out}' continues it" in err, err
    rodfem("resume", out, "--quiet", ranks=2, check=0)
    rodfem("run", *scene, "--out", reference, "--quiet", ranks=2, check=0)
    assert_same_run(out, reference)


def read_marker_of(out: Path) -> dict | None:
    from rodfem.output.writers import read_marker

    return read_marker(out) if out.is_dir() else None
