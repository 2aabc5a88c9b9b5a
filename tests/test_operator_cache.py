"""The operator cache (rodfem/discrete/cache.py) never changes a result: a run with an empty cache,
with a warm one, with a broken one and without any gives the same history and fields bit for bit;
a warm serial run does not import dolfinx; runs on two ranks leave it alone."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse
from mpi4py import MPI

import rodfem.scene
from conftest import history_rows
from rodfem.discrete.cache import cache_directory
from rodfem.output.pointwise import CellMap
from rodfem.run import simulate

COMM = MPI.COMM_WORLD
SCENES = {  # the compiled Picard loop, the compiled direct loop (Crank–Nicolson), the PETSc loop
    "paper1": ("paper1", ["time.end=0.02", "output.every=5", "mesh.cells=40"]),
    "impact": ("impact", ["time.end=0.02", "output.every=5", "mesh.cells=40"]),
    "newton": ("paper1", ["time.end=0.01", "solver.method=newton", "mesh.cells=40",
                          "discretisation.mass=redistributed-lumped"]),
}


@pytest.fixture
def cache(monkeypatch):
    """An empty cache directory, the same on every rank."""
    import shutil
    import tempfile

    path = Path(tempfile.mkdtemp(prefix="rodfem-cache-")) if COMM.rank == 0 else None
    path = COMM.bcast(path, root=0)
    monkeypatch.setenv("XDG_CACHE_HOME", str(path))
    yield path / "rodfem"
    COMM.barrier()
    if COMM.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def run(name: str) -> tuple[np.ndarray, dict]:
    scene, overrides = SCENES[name]
    result = simulate(rodfem.scene.load(scene, overrides), None, COMM, progress=False,
                      keep_fields=True)
    assert result.status == "complete"
    fields = result.fields[2] if result.fields is not None else {}
    return result.history, fields


def assert_same_bits(a: tuple[np.ndarray, dict], b: tuple[np.ndarray, dict]) -> None:
    assert a[0].tobytes() == b[0].tobytes()
    assert a[1].keys() == b[1].keys()
    for name in a[1]:
        assert np.asarray(a[1][name]).tobytes() == np.asarray(b[1][name]).tobytes(), name


def operator_files(directory: Path) -> list[Path]:
    return sorted(directory.glob("operators-*.npz")) if directory.exists() else []


@pytest.mark.parametrize("name", SCENES)
def test_results_are_the_same_bits_with_and_without_the_cache(name, cache, monkeypatch):
    cold = run(name)  # an empty cache: assembled, then stored (serially)
    assert len(operator_files(cache)) == (1 if COMM.size == 1 else 0)
    warm = run(name)  # read back
    monkeypatch.setenv("RODFEM_CACHE", "0")
    without = run(name)
    assert_same_bits(cold, warm)
    assert_same_bits(cold, without)


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
def test_a_broken_file_is_assembled_again_and_replaced(cache):
    expected = run("paper1")
    (path,) = operator_files(cache)
    whole = path.read_bytes()
    middle = len(whole) // 2
    for broken in (b"junk", whole[:middle],
                   whole[:middle] + bytes([whole[middle] ^ 1]) + whole[middle + 1:]):
        path.write_bytes(broken)
        assert_same_bits(run("paper1"), expected)
        assert path.read_bytes() != broken  # replaced by a whole file
    assert_same_bits(run("paper1"), expected)


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
def test_an_edited_array_fails_the_checksum(cache):
    """A whole file whose arrays were changed (the zip itself consistent) is not used."""
    expected = run("paper1")
    (path,) = operator_files(cache)
    with np.load(path) as data:
        arrays = dict(data)
    blob = arrays["blob"].copy()
    blob[len(blob) // 2] ^= 1  # a bit of some array's value
    np.savez(path, **{**arrays, "blob": blob})
    assert_same_bits(run("paper1"), expected)
    with np.load(path) as data:
        assert data["blob"].tobytes() == arrays["blob"].tobytes()  # replaced by the right one


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
def test_another_constant_is_another_file(cache, monkeypatch):
    """The digest names the forms' constants: a scene with another k does not read the first
    one's operators (its results are those of a run without the cache)."""
    run("paper1")
    scene, overrides = SCENES["paper1"]
    SCENES["other"] = (scene, [*overrides, "model.k=2.5"])
    try:
        warm = run("other")
        assert len(operator_files(cache)) == 2
        monkeypatch.setenv("RODFEM_CACHE", "0")
        assert_same_bits(warm, run("other"))
    finally:
        del SCENES["other"]


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
def test_a_directory_others_can_write_is_not_used(cache):
    cache.mkdir(parents=True)
    cache.chmod(0o777)
    expected = run("paper1")
    assert operator_files(cache) == []
    cache.chmod(0o700)
    assert_same_bits(run("paper1"), expected)
    assert len(operator_files(cache)) == 1


def test_the_cache_directory_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_directory() == tmp_path / "rodfem"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_directory() == Path.home() / ".cache" / "rodfem"


@pytest.mark.parametrize("relative", ["cache", ".", "~/cache"])
def test_a_relative_xdg_cache_home_is_not_used(relative, monkeypatch, tmp_path):
    """The XDG specification: a relative $XDG_CACHE_HOME is ignored, not a cache made in the
    directory a run starts from."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", relative)
    assert cache_directory() == Path.home() / ".cache" / "rodfem"


@pytest.mark.skipif(COMM.size > 1, reason="starts its own processes; run serially")
def test_a_warm_run_does_not_import_dolfinx(cache, tmp_path):
    """The second run of a scene as a command: no dolfinx, UFL or FFCx in the process, and the
    same history file as the first's."""
    code = ("import sys; from rodfem.__main__ import main; code = main(); "
            "print(sorted(m for m in ('dolfinx', 'ufl', 'ffcx') if m in sys.modules)); "
            "sys.exit(code)")
    env = dict(os.environ, XDG_CACHE_HOME=str(cache.parent))
    loaded, histories = [], []
    for i in range(2):
        out = tmp_path / f"run{i}"
        done = subprocess.run([sys.executable, "-c", code, "run", "paper1",
                               "--set", "time.end=0.01", "--out", str(out), "--quiet"],
                              env=env, capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        loaded.append(done.stdout.strip().splitlines()[-1])
        histories.append(rodfem.load(out).history)
    assert loaded == ["['dolfinx', 'ffcx', 'ufl']", "[]"]
    assert histories[0].dtype == histories[1].dtype
    assert histories[0].tobytes() == histories[1].tobytes()


def test_a_cell_map_sums_as_a_sparse_product():
    """CellMap.apply adds the products from 0 in the table's order, as SciPy's CSR product does:
    the same bits, signed zeros included."""
    rng = np.random.default_rng(3)
    n = 50
    values = rng.standard_normal((n - 1, 6)) * 10.0 ** rng.integers(-8, 8, (n - 1, 6))
    values[::7, 2] = 0.0
    values[::5, 3] = -0.0
    cells = np.arange(n - 1)
    columns = np.stack([part * n + cells + side for part in range(3) for side in (0, 1)],
                       axis=1)
    s = rng.standard_normal(3 * n)
    s[::4] = -0.0
    sparse = scipy.sparse.csr_matrix(
        (values.ravel(), columns.ravel(), np.arange(0, 6 * n - 5, 6)), shape=(n - 1, 3 * n))
    assert (sparse @ s).tobytes() == CellMap(values, columns).apply(s).tobytes()


def _edited(name: str, arrays: dict[str, np.ndarray]) -> None:
    """One array of a cached discretisation changed in kind or shape (as a run of it never
    makes them)."""
    def first(start: str, end: str = "") -> str:
        return next(k for k in arrays if k.startswith(start) and k.endswith(end))

    if name == "fewer nodes":
        arrays["nodes|x"] = arrays["nodes|x"][:-1]
    elif name == "a vector in single precision":
        key = first("('vector', ('thermal load',)")
        arrays[key] = arrays[key].astype(np.float32)
    elif name == "a shorter vector":
        key = first("('vector', ('contact',)")
        arrays[key] = arrays[key][:-3]
    elif name == "a column beyond the matrix":
        key = first("('matrix', ('mass',)", "|indices")
        arrays[key] = arrays[key] + 1000
    elif name == "a value fewer in a matrix":
        key = first("('matrix', ('stiffness',)", "|values")
        arrays[key] = arrays[key][:-1]
    elif name == "a cell map of five columns":
        arrays["pointwise|sigma_values"] = arrays["pointwise|sigma_values"][:, :5].copy()
    elif name == "a cell map beyond the state":
        arrays["pointwise|sigma_columns"] = arrays["pointwise|sigma_columns"] + 10**6
    elif name == "an array more":
        arrays["pointwise|extra"] = np.zeros(3)


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
@pytest.mark.parametrize("edit", ["fewer nodes", "a vector in single precision",
                                  "a shorter vector", "a column beyond the matrix",
                                  "a value fewer in a matrix", "a cell map of five columns",
                                  "a cell map beyond the state", "an array more"])
def test_a_file_of_other_kinds_or_shapes_is_not_used(edit, cache, monkeypatch):
    """A file whose checksum holds but whose arrays are not those this discretisation makes
    (edited, the checksum recomputed) is assembled again and replaced: the run neither fails
    nor gives another result (a single-precision vector, a cell map short of a column did)."""
    from rodfem.discrete import cache as operator_cache

    expected = run("paper1")
    (path,) = operator_files(cache)
    arrays = operator_cache._read(path)
    _edited(edit, arrays)
    with open(path, "wb") as file:
        np.savez(file, **operator_cache._packed(arrays))
    assert operator_cache._read(path) is not None  # the checksum holds
    assert_same_bits(run("paper1"), expected)
    assert_same_bits(run("paper1"), expected)  # from the file written in its place
    replaced = operator_cache._read(path)
    assert "pointwise|extra" not in replaced
    monkeypatch.setenv("RODFEM_CACHE", "0")
    assert_same_bits(run("paper1"), expected)


@pytest.mark.skipif(COMM.size > 1, reason="the cache is serial")
def test_a_fifo_in_place_of_the_file_does_not_block_the_run(cache):
    """Reading the cache never waits: a named pipe where the file should be is not read (and a
    run replaces it with the file)."""
    import threading

    from rodfem.discrete import cache as operator_cache

    expected = run("paper1")
    (path,) = operator_files(cache)
    path.unlink()
    os.mkfifo(path)
    read = []
    reader = threading.Thread(target=lambda: read.append(operator_cache._read(path)),
                              daemon=True)
    reader.start()
    reader.join(timeout=30)
    assert read == [None]  # not left waiting for a writer
    assert_same_bits(run("paper1"), expected)
    assert path.is_file()
    assert_same_bits(run("paper1"), expected)


@pytest.mark.parametrize("setting", ["working directory", "configuration", "environment"])
def test_the_compilation_settings_name_the_file(setting, monkeypatch, tmp_path):
    """dolfinx's and FFCx's parameter files (in the working directory and $XDG_CONFIG_HOME)
    and the compiler's variables change the compiled forms, so the assembled values: they are
    part of the digest."""
    from rodfem.discrete.cache import digest

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    monkeypatch.delenv("CFLAGS", raising=False)
    before = digest({"mesh.cells": 10}, {"dt": 0.1})
    assert before == digest({"mesh.cells": 10}, {"dt": 0.1})
    if setting == "working directory":
        (tmp_path / "ffcx_parameters.json").write_text('{"table_rtol": 1e-3}')
    elif setting == "configuration":
        (tmp_path / "config" / "dolfinx").mkdir(parents=True)
        (tmp_path / "config" / "dolfinx" / "dolfinx_jit_parameters.json").write_text(
            '{"cffi_extra_compile_args": ["-O0"]}')
    else:
        monkeypatch.setenv("CFLAGS", "-ffast-math")
    assert digest({"mesh.cells": 10}, {"dt": 0.1}) != before


@pytest.mark.skipif(COMM.size > 1, reason="starts its own processes; run serially")
def test_a_run_with_other_compilation_settings_does_not_read_the_operators(cache, tmp_path):
    """Operators assembled from forms compiled with -ffast-math are other bits: a run in a
    directory holding such a dolfinx_jit_parameters.json gives, with the cache another run
    warmed without it, what it gives without the cache."""
    env = dict(os.environ, XDG_CACHE_HOME=str(cache.parent))
    fast = tmp_path / "fast"
    fast.mkdir()
    (fast / "dolfinx_jit_parameters.json").write_text(
        '{"cffi_extra_compile_args": ["-O3", "-ffast-math", "-march=native"]}')
    histories = {}
    for name, where, cached in (("plain", tmp_path, "1"), ("warm", fast, "1"),
                                ("without", fast, "0")):
        done = subprocess.run(
            [sys.executable, "-m", "rodfem", "run", "paper1", "--set", "time.end=0.02",
             "--set", "mesh.cells=30", "--set", "discretisation.mass=consistent",
             "--out", str(tmp_path / name), "--quiet"],
            env={**env, "RODFEM_CACHE": cached}, capture_output=True, text=True, cwd=where)
        assert done.returncode == 0, done.stderr
        histories[name] = history_rows(tmp_path / name).tobytes()
    assert histories["warm"] == histories["without"]


def test_a_change_in_a_library_s_subpackage_changes_its_stamp(monkeypatch, tmp_path):
    """FFCx's code generation lives in subpackages of ffcx, dolfinx's assembly in dolfinx.fem:
    a library's stamp (part of the digest) sees a change to any of its files, bytecode aside."""
    from rodfem.discrete.cache import _library_stamp

    package = tmp_path / "rodfem_stamped"
    (package / "codegeneration" / "__pycache__").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "codegeneration" / "__init__.py").write_text("")
    generator = package / "codegeneration" / "C.py"
    generator.write_text("FLAGS = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    before = _library_stamp("rodfem_stamped")
    (package / "codegeneration" / "__pycache__" / "C.cpython-311.pyc").write_bytes(b"\0")
    assert _library_stamp("rodfem_stamped") == before  # Python's bytecode is no change
    generator.write_text("FLAGS = 22\n")
    assert _library_stamp("rodfem_stamped") != before
