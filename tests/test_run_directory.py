"""Run directories: the marker, --force that replaces only what rodfem wrote, and the lock that
keeps two commands out of one directory (decoys of a user's files, the current directory, links,
mount points, a held lock, a stale one, two runs at once)."""

import fcntl
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import COMM, history_rows, serial_only
from rodfem.cli import main
from rodfem.output.directories import LOCK, MARKER
from rodfem.output.writers import read_marker

RODFEM = str(Path(sys.executable).with_name("rodfem"))
SHORT = ["--quiet", "--set", "time.end=0.01"]


def run(out: Path, *extra: str, capsys=None) -> tuple[int, str]:
    code = main(["run", "paper1", "--out", str(out), *SHORT, *extra])
    err = capsys.readouterr().err if capsys is not None else ""
    return code, COMM.bcast(err if COMM.rank == 0 else None, root=0)


def test_a_run_is_marked(shared_dir):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    marker = json.loads((out / MARKER).read_text())
    assert marker["command"] == "run" and marker["status"] == "complete"
    assert marker["pid"] == os.getpid() if COMM.size == 1 else marker["pid"] > 0
    assert {"rodfem", "host", "started", "finished", "files"} <= set(marker)
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [MARKER, LOCK, *marker["files"]])  # no temporary file left behind


def decoy(out: Path, make) -> None:
    if COMM.rank == 0:
        out.mkdir()
        make(out)
    COMM.barrier()


@pytest.mark.parametrize("what", ["index.md", "summary.json", "figures/x.png"])
def test_force_keeps_a_users_files_with_rodfems_names(shared_dir, capsys, what):
    """The old check went by names: a user's index.md, summary.json or figures/x.png was taken
    for rodfem's and deleted. Without a marker nothing is rodfem's."""
    out = shared_dir / "mine"

    def make(out):
        (out / what).parent.mkdir(exist_ok=True)
        (out / what).write_text("notes\n")

    decoy(out, make)
    code, err = run(out, "--force", capsys=capsys)
    assert code == 2 and "not a rodfem output directory (it has no rodfem.json)" in err
    assert (out / what).read_text() == "notes\n"
    assert not (out / MARKER).exists() and not (out / LOCK).exists()


def test_force_keeps_a_file_added_to_a_run(shared_dir, capsys):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    if COMM.rank == 0:
        (out / "notes.txt").write_text("mine\n")
    COMM.barrier()
    code, err = run(out, "--force", capsys=capsys)
    assert code == 2 and "(it holds notes.txt)" in err
    assert (out / "notes.txt").read_text() == "mine\n" and (out / "history.h5").exists()


def test_force_refuses_links(shared_dir, capsys):
    out, elsewhere = shared_dir / "run", shared_dir / "elsewhere"
    assert run(out)[0] == 0
    if COMM.rank == 0:
        elsewhere.mkdir()
        (elsewhere / "data").write_text("mine\n")
        (out / "figures").symlink_to(elsewhere)
    COMM.barrier()
    code, err = run(out, "--force", capsys=capsys)
    assert code == 2 and "a link" in err
    assert (elsewhere / "data").read_text() == "mine\n"


def test_force_replaces_a_run_and_its_figures(shared_dir):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    if COMM.rank == 0:
        (out / "figures").mkdir()
        (out / "figures" / "contact.png").write_bytes(b"png")
    COMM.barrier()
    assert run(out, "--force", "--set", "time.end=0.02")[0] == 0
    assert not (out / "figures").exists()
    assert len(history_rows(out)) == 21


def test_force_keeps_an_image_rodfem_did_not_draw(shared_dir, capsys):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    if COMM.rank == 0:
        (out / "figures").mkdir()
        (out / "figures" / "contact.png").write_bytes(b"png")
        (out / "figures" / "mine.png").write_bytes(b"mine")
    COMM.barrier()
    code, err = run(out, "--force", capsys=capsys)
    assert code == 2 and "it holds figures" in err
    assert (out / "figures" / "mine.png").read_bytes() == b"mine"


@serial_only
@pytest.mark.parametrize("where", [".", "figures"])
def test_force_never_replaces_the_current_directory_or_its_parent(shared_dir, where):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    (out / "figures").mkdir()
    done = subprocess.run([RODFEM, "run", "paper1", "--out", str(out), "--force", *SHORT],
                          cwd=out / where, capture_output=True, text=True)
    assert done.returncode == 2, done.stderr
    assert "is the current directory or holds it" in done.stderr
    assert (out / "history.h5").exists()


@serial_only
def test_a_held_directory_is_refused_naming_its_holder(shared_dir, capsys):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    assert (out / LOCK).read_bytes() == b""  # a finished command's name is wiped
    holder = subprocess.Popen([RODFEM, "run", "paper1", "--out", str(out), "--force", "--quiet",
                               "--set", "time.end=1e5", "--no-size-check"])
    try:
        # its own marker: the old one stays while --force empties the directory, then none is
        # there (the run refused then is "not a rodfem output directory")
        deadline = time.monotonic() + 120
        while (read_marker(out) or {}).get("pid") != holder.pid:
            assert time.monotonic() < deadline and holder.poll() is None
            time.sleep(0.05)
        code, err = run(out, "--force", capsys=capsys)
    finally:
        holder.kill()
        holder.wait()
    assert code == 2 and f"is in use by rodfem run (pid {holder.pid} on" in err, err
    assert err.count("\n") == 1
    assert run(out, "--force")[0] == 0  # killed: its lock is free, and replaced


HOLD = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR)
fcntl.flock(fd, fcntl.LOCK_EX)
print("held", flush=True)
time.sleep(60)
"""


@serial_only
def test_the_lock_of_a_killed_process_is_taken_over(shared_dir):
    out = shared_dir / "run"
    assert run(out)[0] == 0
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out / LOCK)],
                              stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    assert run(out, "--force")[0] == 2  # held
    holder.kill()  # SIGKILL: no clean-up of any kind
    holder.wait()
    assert run(out, "--force")[0] == 0


@serial_only
def test_force_does_not_cross_a_mount_point(shared_dir):
    """A bind mount over a run's figures/ (which --force would otherwise empty) is refused, and
    the mounted directory keeps its files. In a private mount namespace (unshare), as root."""
    if shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip("needs root and unshare(1) to bind-mount in a private namespace")
    out, other = shared_dir / "run", shared_dir / "other"
    assert run(out)[0] == 0
    (out / "figures").mkdir()
    other.mkdir()
    (other / "kept.png").write_bytes(b"mine")
    script = (f'mount --bind "{other}" "{out / "figures"}" && exec "{RODFEM}" run paper1 '
              f'--out "{out}" --force --quiet --set time.end=0.01')
    done = subprocess.run(["unshare", "--mount", "--propagation", "private", "sh", "-c", script],
                          capture_output=True, text=True)
    if done.returncode != 2 and "rodfem" not in done.stderr:  # unshare or mount refused here
        pytest.skip(f"bind mount refused here: {done.stderr.strip()}")
    assert done.returncode == 2, done.stderr
    assert "figures is a mount point" in done.stderr
    assert (other / "kept.png").read_bytes() == b"mine"


@serial_only
def test_two_runs_at_once_never_mix(shared_dir):
    """Several --force runs on one directory at once: each either runs whole or is refused with
    exit 2; the directory ends as one run's files, whole."""
    out = shared_dir / "run"
    assert run(out)[0] == 0
    runs = [subprocess.Popen([RODFEM, "run", "paper1", "--out", str(out), "--force", "--quiet",
                              "--set", f"time.end={0.5 + 0.1 * i}", "--set", "output.every=10"],
                             stderr=subprocess.PIPE, text=True) for i in range(4)]
    codes, errors = [], []
    for process in runs:
        _, err = process.communicate(timeout=300)
        codes.append(process.returncode)
        errors.append(err)
    assert set(codes) <= {0, 2} and 0 in codes, errors
    # the holder is named from its lock file, even while its marker is being replaced
    assert all("in use by rodfem run (pid" in e or "in use by another rodfem command" in e
               or "no rodfem.json" in e
               for c, e in zip(codes, errors, strict=True) if c == 2), errors
    marker = json.loads((out / MARKER).read_text())
    summary = json.loads((out / "summary.json").read_text())
    assert marker["status"] == summary["status"] == "complete"
    assert len(history_rows(out)) == summary["steps"] + 1
    scene = (out / "scene.toml").read_text()
    assert f"end = {summary['steps'] * 0.001!r}" in scene or summary["steps"] in (500, 600, 700,
                                                                                   800)
    time.sleep(0)


def test_force_takes_a_directory_left_between_its_creation_and_its_marker(tmp_path):
    """A command stopped right after creating its directory leaves only the lock (and perhaps the
    marker's temporary file): --force may use it; a decoy beside them stops it."""
    from mpi4py.MPI import COMM_SELF

    from rodfem.output.directories import OutputError, finish, prepare_directory

    out = tmp_path / "run"
    out.mkdir()
    (out / LOCK).write_text("")
    (out / f".{MARKER}.1234").write_text("{")
    prepare_directory(out, True, COMM_SELF)
    finish(out, "complete", COMM_SELF)
    assert sorted(p.name for p in out.iterdir()) == sorted([LOCK, MARKER])
    decoy = tmp_path / "decoy"
    decoy.mkdir()
    (decoy / LOCK).write_text("")
    (decoy / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="no rodfem.json"):
        prepare_directory(decoy, True, COMM_SELF)
    assert (decoy / "notes.txt").read_text() == "mine"


def test_force_keeps_data_files_rodfem_does_not_write(tmp_path):
    from mpi4py.MPI import COMM_SELF

    from rodfem.output.directories import OutputError, finish, prepare_directory

    out = tmp_path / "run"
    prepare_directory(out, False, COMM_SELF)
    (out / "fields").mkdir()
    (out / "fields" / "steps-000000.h5").write_bytes(b"")
    finish(out, "complete", COMM_SELF)
    (out / "fields" / "mine.h5").write_bytes(b"mine")
    with pytest.raises(OutputError, match="it holds fields"):
        prepare_directory(out, True, COMM_SELF)
    assert (out / "fields" / "mine.h5").read_bytes() == b"mine"


def test_a_mistake_in_the_arguments_is_one_line(capsys):
    for argv in (["run"], ["run", "paper1", "--bogus"], ["plot"], ["nonsense"]):
        with pytest.raises(SystemExit) as stop:
            main(argv)
        assert stop.value.code == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "error" in err and "--help" in err, err


@serial_only
def test_a_removed_lock_is_taken_again_and_a_taken_one_stops_the_writer(shared_dir):
    """At each checkpoint the writer holds its lock still: removed, it is made and taken again;
    taken meanwhile by another process, the writer stops holding the directory and leaves its
    marker to the other."""
    from rodfem.output.directories import finish, keep_lock, prepare_directory

    out = shared_dir / "run"
    prepare_directory(out, False, COMM)
    (out / LOCK).unlink()
    keep_lock(out)
    fd = os.open(out / LOCK, os.O_RDONLY)
    try:
        with pytest.raises(BlockingIOError):
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # held again
    finally:
        os.close(fd)
    (out / LOCK).unlink()
    (out / LOCK).touch()
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out / LOCK)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(OSError, match="rodfem.lock"):
            keep_lock(out)
        marker = (out / MARKER).read_bytes()
        finish(out, "complete", COMM)
        assert (out / MARKER).read_bytes() == marker  # not this process's to write any more
    finally:
        holder.kill()
        holder.wait()
