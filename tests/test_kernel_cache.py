"""Compiled code is data too: a compiled loop is loaded only as its build recorded it.

1. A damaged library in the cache (empty, cut, bit-flipped, another version's, a directory, a
   FIFO, a symbolic link, its record missing or edited) is never loaded: it is built again, and the
   run's files are those of an intact cache bit for bit; where it cannot be built again the run
   refuses in one line (exit 3) and writes nothing. It never switches to the PETSc loop unasked.
2. A run records the loops that made its steps; ``rodfem resume`` with another loop is refused in
   one line (exit 2, nothing changed) unless ``--any-loop``.
3. Ranks that find a damaged library at once build it once, under the cache's lock, and load the
   same bytes.

The property over damaged files runs in-process, its rebuild a copy of the intact library (what
is under test is the check, not the compiler): a few examples in the suite,
``HYPOTHESIS_PROFILE=fuzz`` many more, with whole runs.
"""

import filecmp
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import COMM, serial_only

FUZZ = os.environ.get("HYPOTHESIS_PROFILE") == "fuzz"
SCENE = ["paper1", "--set", "time.end=0.1", "--quiet"]  # the compiled Picard loop
RODFEM = [sys.executable, "-m", "rodfem"]
KINDS = ["empty", "cut", "flip", "other version", "directory", "fifo", "symlink",
         "no record", "edited record", "record of another build"]


def _libraries(cache: Path, prefix: str = "_rodfem_picard_kernel_") -> tuple[Path, Path]:
    """The library and its record in a cache directory (``cache/rodfem``)."""
    [library] = [p for p in cache.glob(prefix + "*") if p.name.endswith(".so")]
    return library, library.with_name(library.name.split(".")[0] + ".json")


def _run(cache: Path, where: Path, *args: str, env: dict | None = None):
    """``rodfem ARGS`` with the cache ``cache``, ``out`` and ``run`` in ``where``; from one
    working directory (it names the operators' file: every run reads the fixture's)."""
    args = [str(where / a) if i and args[i - 1] in ("--out", "resume") else a
            for i, a in enumerate(args)]
    return subprocess.run([*RODFEM, *args], capture_output=True, text=True,
                          cwd=tempfile.gettempdir(),
                          env={**os.environ, "XDG_CACHE_HOME": str(cache.parent),
                               **(env or {})})


@pytest.fixture(scope="module")
def intact(tmp_path_factory):
    """A private cache with both compiled loops (and paper1's operators), built once, and the
    files of a run with it."""
    if COMM.size > 1:
        pytest.skip("starts its own processes; run serially")
    root = tmp_path_factory.mktemp("kernel-cache")
    cache = root / "cache" / "rodfem"
    done = _run(cache, root, "run", *SCENE, "--out", "ok")
    assert done.returncode == 0, done.stderr
    built = subprocess.run([sys.executable, "-c", "from rodfem.solver.compiled import direct; "
                            "assert direct.available(), direct.unavailable_reason()"],
                           env={**os.environ, "XDG_CACHE_HOME": str(cache.parent)})
    assert built.returncode == 0
    return cache, root / "ok"


@pytest.fixture
def cache(intact, tmp_path):
    """A copy of the intact cache for one case."""
    copy = tmp_path / "cache" / "rodfem"
    shutil.copytree(intact[0], copy)
    return copy


def _damage(kind: str, library: Path, record: Path, other: Path, at: float = 0.5,
            bit: int = 0) -> None:
    """Damage a cached library (or its record) in the way ``kind`` says; ``at`` is where (a
    fraction of its bytes) a cut or a flipped bit is."""
    data = library.read_bytes()
    where = min(int(at * len(data)), len(data) - 1)
    if kind == "empty":
        library.write_bytes(b"")
    elif kind == "cut":
        library.write_bytes(data[:where])
    elif kind == "flip":
        library.write_bytes(data[:where] + bytes([data[where] ^ (1 << bit)]) + data[where + 1:])
    elif kind == "other version":
        shutil.copyfile(other, library)
    elif kind == "directory":
        library.unlink()
        library.mkdir()
        (library / "inside").write_text("x")
    elif kind == "fifo":
        library.unlink()
        os.mkfifo(library)
    elif kind == "symlink":
        library.unlink()
        library.symlink_to(other)
    elif kind == "no record":
        record.unlink()
    elif kind == "edited record":
        written = json.loads(record.read_text())
        written["size"] += 1
        record.write_text(json.dumps(written))
    elif kind == "record of another build":
        written = json.loads(record.read_text())
        written["inputs"]["arithmetic"]["compile_args"] = ["-O3", "-ffast-math"]
        record.write_text(json.dumps(written))
    else:  # pragma: no cover
        raise ValueError(kind)


def _same_run(a: Path, b: Path) -> None:
    """Two runs' files: history.h5 byte for byte, the summaries' measures and loops."""
    assert filecmp.cmp(a / "history.h5", b / "history.h5", shallow=False)
    first, second = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    timing = [key for key in first["measures"] if key.endswith("_seconds")]
    assert [first["measures"].pop(key) for key in timing] and timing == ["loop_seconds"]
    assert first["measures"] == {k: v for k, v in second["measures"].items() if k not in timing}
    assert first["loops"] == second["loops"]
    assert second["loops"][0][1].startswith("compiled picard ")


def _whole(library: Path, record: Path) -> bool:
    written = json.loads(record.read_text())
    data = library.read_bytes()
    return len(data) == written["size"] and hashlib.sha256(data).hexdigest() == written["sha256"]


@serial_only
@pytest.mark.parametrize("kind", ["empty", "cut"])
def test_a_damaged_library_is_built_again_to_the_same_bits(kind, intact, cache, tmp_path):
    """An emptied library (the run switched to the PETSc loop, other last digits) and one cut
    short (a bus error in every run): built again, the same files as an intact cache's."""
    library, record = _libraries(cache)
    other, _ = _libraries(cache, "_rodfem_kernel_")
    _damage(kind, library, record, other, at=1000 / library.stat().st_size)
    done = _run(cache, tmp_path, "run", *SCENE, "--out", "run")
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # no word of another loop
    _same_run(intact[1], tmp_path / "run")
    assert _whole(library, record)
    # the next run loads it as it is: not built again
    before = library.stat()
    assert _run(cache, tmp_path, "run", *SCENE, "--out", "again").returncode == 0
    assert library.stat().st_ino == before.st_ino and library.stat().st_mtime_ns == \
        before.st_mtime_ns


@pytest.fixture
def no_compiler(tmp_path):
    """PATH with a C compiler (the interpreter's) that fails."""
    import sysconfig

    where = tmp_path / "bin"
    where.mkdir()
    compiler = where / sysconfig.get_config_var("CC").split()[0]
    compiler.write_text("#!/bin/sh\necho 'cc: not here' >&2\nexit 1\n")
    compiler.chmod(0o755)
    return {"PATH": f"{where}{os.pathsep}{os.environ['PATH']}"}


@serial_only
def test_a_library_that_cannot_be_built_again_refuses_the_run(cache, no_compiler, tmp_path):
    """No compiler and a damaged library: one line, exit 3, no run directory, and a stopped
    run's resume changes nothing; RODFEM_KERNEL=0 runs the PETSc loop, as asked, and records
    it."""
    assert _run(cache, tmp_path, "run", *SCENE, "--out", "stopped").returncode == 0
    before = {p.name: p.read_bytes() for p in (tmp_path / "stopped").iterdir() if p.is_file()}
    library, record = _libraries(cache)
    _damage("cut", library, record, library, at=0.1)
    done = _run(cache, tmp_path, "run", *SCENE, "--out", "run", env=no_compiler)
    assert done.returncode == 3
    [line] = done.stderr.splitlines()
    assert line.startswith("rodfem: error: ") and "Picard kernel is not available" in line
    assert "the C compiler failed" in line and "RODFEM_KERNEL=0" in line
    assert not (tmp_path / "run").exists()
    resumed = _run(cache, tmp_path, "resume", "stopped", "--set", "time.end=0.2",
                   env=no_compiler)
    assert resumed.returncode == 3
    [line] = resumed.stderr.splitlines()
    assert line.startswith("rodfem: error: ") and "--any-loop" in line
    assert {p.name: p.read_bytes() for p in (tmp_path / "stopped").iterdir()
            if p.is_file()} == before
    asked = _run(cache, tmp_path, "run", *SCENE, "--out", "petsc",
                 env={**no_compiler, "RODFEM_KERNEL": "0"})
    assert asked.returncode == 0, asked.stderr
    assert json.loads((tmp_path / "petsc" / "summary.json").read_text())["loops"] == [
        [0, "petsc"]]


@serial_only
def test_a_sweep_whose_loop_cannot_be_built_writes_nothing(cache, no_compiler, tmp_path):
    """A sweep builds its scenes' loops before it writes: without them, one line, exit 3."""
    library, record = _libraries(cache, "_rodfem_kernel_")  # the direct method's
    _damage("empty", library, record, library)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text('scene = "paper1"\n[set]\n"time.end" = 0.01\n"solver.method" = "direct"\n'
                     '[grid]\n"model.k" = [1, 2]\n')
    done = _run(cache, tmp_path, "sweep", str(sweep), "--out", "run", env=no_compiler)
    assert done.returncode == 3, done.stderr
    [line] = done.stderr.splitlines()
    assert line.startswith("rodfem: error: ") and "compiled kernel is not available" in line
    assert not (tmp_path / "run").exists()


@serial_only
@pytest.mark.parametrize("first, then", [("1", "0"), ("0", "1")])
def test_resume_with_another_loop_is_refused(first, then, cache, tmp_path):
    """A run made by one loop is not continued by the other: one line, exit 2, nothing changed;
    --any-loop continues it and records both loops with the step each began at."""
    run = tmp_path / "run"
    made = _run(cache, tmp_path, "run", *SCENE, "--out", "run", env={"RODFEM_KERNEL": first})
    assert made.returncode == 0, made.stderr
    before = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
    longer = ["resume", "run", "--set", "time.end=0.2", "--quiet"]
    refused = _run(cache, tmp_path, *longer, env={"RODFEM_KERNEL": then})
    assert refused.returncode == 2, refused.stderr
    [line] = refused.stderr.splitlines()
    assert line.startswith("rodfem: error: ") and "--any-loop" in line
    assert ("PETSc loop" in line) and ("compiled picard loop" in line)
    assert "RODFEM_KERNEL=0" in line
    assert {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()} == before
    # the same loop continues it; --any-loop with the other records both
    same = _run(cache, tmp_path, *longer, env={"RODFEM_KERNEL": first})
    assert same.returncode == 0, same.stderr
    loops = json.loads((run / "summary.json").read_text())["loops"]
    assert len(loops) == 1
    anyway = _run(cache, tmp_path, "resume", "run", "--set", "time.end=0.3", "--quiet",
                  "--any-loop", env={"RODFEM_KERNEL": then})
    assert anyway.returncode == 0, anyway.stderr
    loops = json.loads((run / "summary.json").read_text())["loops"]
    assert [step for step, _ in loops] == [0, 200]
    assert (loops[0][1] == "petsc") == (first == "0") and (loops[1][1] == "petsc") == (then == "0")


@serial_only
def test_a_checkpoint_without_loops_resumes_with_this_one(cache, tmp_path):
    """A run of an earlier rodfem (its checkpoint records no loop) resumes with the loop this
    one uses, its steps before recorded as unrecorded."""
    import numpy as np

    from rodfem.output.checkpoint import NAME, read_checkpoint, write_checkpoint

    run = tmp_path / "run"
    assert _run(cache, tmp_path, "run", *SCENE, "--out", "run").returncode == 0
    arrays, meta = read_checkpoint(run)
    del meta["loops"], meta["digest"], meta["format"]
    write_checkpoint(run, arrays, meta)
    assert "loops" not in json.loads(str(np.load(run / NAME)["meta"]))
    done = _run(cache, tmp_path, "resume", "run", "--set", "time.end=0.2", "--quiet",
                env={"RODFEM_KERNEL": "0"})
    assert done.returncode == 0, done.stderr
    assert json.loads((run / "summary.json").read_text())["loops"] == [
        [0, "unrecorded"], [100, "petsc"]]


# -- the property, in-process: every damage is caught before the loader sees the bytes ---------

def _source_in(cache: Path, monkeypatch, compiles: list, intact_bytes: bytes | None):
    """The Picard loop's CompiledSource on ``cache``, its compiler replaced by a copy of the
    intact library (None: a compiler that fails), its loads recorded."""
    from rodfem.solver.compiled import build, picard

    monkeypatch.setenv("XDG_CACHE_HOME", str(cache.parent))
    # the fallback directory beside it, not the machine's (/tmp/rodfem-<uid>)
    (cache.parent / "tmp").mkdir(exist_ok=True)
    monkeypatch.setattr(tempfile, "tempdir", str(cache.parent / "tmp"))
    loaded = []
    real_load = build._load
    monkeypatch.setattr(build, "_load", lambda name, data, directory: (
        loaded.append(hashlib.sha256(data).hexdigest()), real_load(name, data, directory))[1])
    source = build.CompiledSource(picard.SOURCE, "_rodfem_picard_kernel_", "Picard kernel",
                                  picard.check_library)

    def compile_(name, target, directory):
        compiles.append(name)
        if intact_bytes is None:
            raise RuntimeError("CompileError: no compiler")
        target.write_bytes(intact_bytes)

    monkeypatch.setattr(source, "_compile", compile_)
    return source, loaded


@serial_only
@settings(max_examples=200 if FUZZ else 12, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(KINDS), at=st.floats(0.0, 1.0), bit=st.integers(0, 7),
       compiler=st.booleans())
def test_no_damaged_library_is_ever_loaded(kind, at, bit, compiler, intact, tmp_path_factory,
                                           monkeypatch):
    """Whatever the damage, the bytes loaded are the intact library's (built again, once), or,
    without a compiler, nothing is loaded and the loop says why."""
    cache = tmp_path_factory.mktemp("damaged") / "cache" / "rodfem"
    shutil.copytree(intact[0], cache)
    library, record = _libraries(cache)
    other, _ = _libraries(cache, "_rodfem_kernel_")
    good = library.read_bytes()
    _damage(kind, library, record, other, at, bit)
    compiles: list = []
    source, loaded = _source_in(cache, monkeypatch, compiles, good if compiler else None)
    if compiler:
        assert source.available(), source.unavailable_reason()
        assert loaded == [hashlib.sha256(good).hexdigest()]
        assert len(compiles) == 1 and _whole(library, record)
    else:
        assert not source.available()
        assert loaded == [] and "no compiler" in source.unavailable_reason()


@serial_only
def test_an_intact_library_is_loaded_without_building(intact, cache, monkeypatch):
    compiles: list = []
    library, record = _libraries(cache)
    source, loaded = _source_in(cache, monkeypatch, compiles, None)
    assert source.available(), source.unavailable_reason()
    assert compiles == [] and loaded == [hashlib.sha256(library.read_bytes()).hexdigest()]


@pytest.mark.skipif(not FUZZ, reason="whole runs over damaged caches: HYPOTHESIS_PROFILE=fuzz")
@serial_only
@settings(max_examples=40, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(KINDS), at=st.floats(0.0, 1.0), bit=st.integers(0, 7))
def test_runs_over_damaged_caches_give_the_intact_bits(kind, at, bit, intact,
                                                        tmp_path_factory):
    where = tmp_path_factory.mktemp("fuzz")
    cache = where / "cache" / "rodfem"
    shutil.copytree(intact[0], cache)
    library, record = _libraries(cache)
    other, _ = _libraries(cache, "_rodfem_kernel_")
    _damage(kind, library, record, other, at, bit)
    done = _run(cache, where, "run", *SCENE, "--out", "run")
    assert done.returncode == 0, done.stderr
    _same_run(intact[1], where / "run")


# -- ranks --------------------------------------------------------------------------------------

def test_ranks_build_a_damaged_library_once_and_load_the_same(shared_dir, monkeypatch):
    """Under mpirun, every rank finds the library cut at once: one builds it, under the cache's
    lock, the others wait and load what it built; all load the same bytes (serially: one
    build)."""
    from rodfem.solver.compiled import build, picard

    cache = shared_dir / "cache" / "rodfem"
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache.parent))
    if COMM.rank == 0:  # the real compiler, once, for the intact library
        first = build.CompiledSource(picard.SOURCE, "_rodfem_picard_kernel_", "Picard kernel")
        assert first.available(), first.unavailable_reason()
        library, record = _libraries(cache)
        good = library.read_bytes()
        library.write_bytes(good[:1000])
    good = COMM.bcast(good if COMM.rank == 0 else None, root=0)
    COMM.barrier()
    compiles: list = []
    source, loaded = _source_in(cache, monkeypatch, compiles, good)
    assert source.available(), source.unavailable_reason()
    assert sum(COMM.allgather(len(compiles))) == 1
    assert COMM.allgather(loaded) == [[hashlib.sha256(good).hexdigest()]] * COMM.size


@serial_only
@pytest.mark.parametrize("value", ["false", "off", "", " 0"])
def test_rodfem_kernel_other_than_0_or_1_is_refused(value, tmp_path, monkeypatch, capsys):
    """RODFEM_KERNEL=false (meant as "off") must not run the compiled loop unasked: any value
    but 0 and 1 is refused in one line, exit 2, nothing written."""
    from rodfem.cli import main

    monkeypatch.setenv("RODFEM_KERNEL", value)
    out = tmp_path / "run"
    assert main(["run", *SCENE, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rodfem: error: RODFEM_KERNEL"), err
    assert not out.exists()
