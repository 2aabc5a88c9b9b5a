"""A serial run's operators kept on disk, so that the next run of the same discretisation starts
without dolfinx: no import of it (nor of UFL and FFCx), no form compiled or assembled.

What the time loop and the outputs read off the forms (the node-ordered matrices and vectors of
:class:`~rodfem.discrete.discretisation.Discretisation`, the nodes, the maps of
:mod:`rodfem.output.pointwise`) depends only on the mesh, the mass, the forms' constants (Δt and
the model's parameters), the code that writes and assembles the forms, the libraries that
compile them and the user's settings of that compilation. One file holds a discretisation's
arrays, named by a digest of all of these, in the per-user cache directory
(``$XDG_CACHE_HOME/rodfem``, else ``~/.cache/rodfem``), beside the compiled loops
(:mod:`rodfem.solver.compiled.build`).

**It never changes a result.** The arrays are the assembled ones, bit for bit, and the PETSc
objects are made from them as they are after assembly (the same CSR rows, the same vectors). A
file that cannot be read (or is not a regular file), whose checksum is wrong, or whose arrays are
not of the kinds and shapes this discretisation's are (:func:`conforms`, checked where they are
used), is ignored: the operators are assembled again and the file replaced. Files are written
whole to a temporary name and renamed; only a private directory (this user's, writable by
nobody else) is used, as for the compiled loops. Runs on more than one rank, discretisations of
more than :data:`CELLS_MAX` cells and ``RODFEM_CACHE=0`` in the environment do without it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import stat
import tempfile
from pathlib import Path

import numpy as np

import rodfem

FORMAT = 2
CELLS_MAX = 10_000  # a few MB a file; beyond, the loop outweighs the start
KEEP = 64  # files kept in the directory, the most recently used
ROOT = Path(__file__).resolve().parents[2]
# The code the arrays come from: the forms, their assembly, and what reads them off.
SOURCES = ("forms/copetti.py", "rodfem/discrete/discretisation.py", "rodfem/discrete/nodes.py",
           "rodfem/discrete/compat.py", "rodfem/discrete/cache.py",
           "rodfem/discrete/arrays.py", "rodfem/solver/methods/base.py",
           "rodfem/solver/methods/direct.py", "rodfem/solver/linalg.py", "rodfem/output/history.py",
           "rodfem/output/pointwise.py", "rodfem/solver/compiled/laurent.py")
LIBRARIES = ("dolfinx", "ufl", "ffcx", "basix", "petsc4py")
# The user's settings of the compilation of the forms, which change the assembled values (a
# -ffast-math does): dolfinx's and FFCx's parameter files, read where they read them (the
# working directory and $XDG_CONFIG_HOME), and the compiler's variables.
PARAMETER_FILES = ("dolfinx/dolfinx_jit_parameters.json", "ffcx/ffcx_parameters.json")
COMPILER_VARIABLES = ("CC", "CFLAGS", "CPPFLAGS", "LDSHARED", "LDFLAGS")
KINDS = {"int": "i", "str": "U"}  # the kinds of dtype conforms() takes for any of their sizes


def cache_directory() -> Path:
    """rodfem's per-user cache directory (the compiled loops and the operators). A relative
    $XDG_CACHE_HOME is not used (the XDG base directory specification: it would put the cache in
    whatever directory a run starts from)."""
    base = os.environ.get("XDG_CACHE_HOME", "")
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rodfem"


def private(directory: Path) -> bool:
    """Whether ``directory`` is ours alone: owned by this user, writable by nobody else (a shared
    /tmp fallback could otherwise hold a file planted by another user)."""
    status = directory.stat()
    return status.st_uid == os.getuid() and not status.st_mode & 0o022


def _library_stamp(name: str) -> list:
    """The installed files of a library's package, its subpackages' too (names, sizes, times;
    not the bytecode Python writes): a new version, a rebuild, or a change to any of its parts
    (FFCx's code generation is in a subpackage, petsc4py's extension module in lib/) changes
    them."""
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.origin:
        return [name, None]
    root = Path(spec.origin).parent
    files = []
    for directory, subdirectories, names in os.walk(root):
        subdirectories[:] = [d for d in subdirectories if d != "__pycache__"]
        for file in names:
            status = os.stat(os.path.join(directory, file))
            files.append((os.path.relpath(os.path.join(directory, file), root),
                          status.st_size, status.st_mtime_ns))
    return [name, sorted(files)]


def _compiler_settings() -> list:
    """What the user set of the forms' compilation: the parameter files dolfinx and FFCx read
    (their contents, None where absent) and the compiler's environment variables."""
    config = Path(os.getenv("XDG_CONFIG_HOME", default=Path.home() / ".config"))
    files = []
    for name in PARAMETER_FILES:
        for path in (config / name, Path.cwd() / Path(name).name):
            try:
                files.append([str(path), path.read_text(errors="replace")])
            except OSError:
                files.append([str(path), None])
    return [files, [os.environ.get(name) for name in COMPILER_VARIABLES]]


def digest(structure: dict, constants: dict) -> str | None:
    """The name of a discretisation's file: a digest of its structure (mesh, mass), the forms'
    constants, rodfem's code that makes the arrays, the libraries that compile the forms and the
    user's settings of that compilation (None if that code cannot be read: then nothing is
    cached)."""
    try:
        sources = [hashlib.sha256((ROOT / name).read_bytes()).hexdigest() for name in SOURCES]
    except OSError:
        return None
    text = json.dumps([FORMAT, rodfem.__version__, structure, constants, sources,
                       [_library_stamp(name) for name in LIBRARIES], _compiler_settings()],
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def conforms(arrays: dict[str, np.ndarray], layout: dict[str, tuple[str, tuple]]) -> bool:
    """Whether ``arrays`` are exactly the fields of ``layout``, each of its kind (a NumPy dtype
    string, or "int" for any integer, "str" for any string) and shape (None where any length
    goes): a file may hold what a run of this discretisation would never make (edited with its
    checksum recomputed), which would fail the run or, worse, change its result."""
    if arrays.keys() != layout.keys():
        return False
    for name, (kind, shape) in layout.items():
        array = arrays[name]
        if (array.dtype.kind != KINDS[kind] if kind in KINDS else array.dtype != np.dtype(kind)):
            return False
        if array.ndim != len(shape) or any(
                length is not None and length != actual
                for length, actual in zip(shape, array.shape)):
            return False
    return True


def _checksum(entries: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(entries):
        array = entries[name]
        h.update(f"{name}|{array.dtype.str}|{array.shape}|".encode())
        h.update(np.ascontiguousarray(array).tobytes())
    return h.hexdigest()


class OperatorCache:
    """The arrays of one discretisation: those found on disk (:meth:`get`), and those made in
    this process (:meth:`put`), written by :meth:`save`."""

    def __init__(self, path: Path, entries: dict[str, np.ndarray] | None = None):
        self.path = path
        self.entries = entries or {}
        self.found = bool(entries)
        self.changed = False

    @classmethod
    def open(cls, name: str | None) -> OperatorCache | None:
        """The cache of the discretisation called ``name`` (:func:`digest`), empty if its file
        is absent or not whole; None without a name or a private directory."""
        if name is None:
            return None
        directory = cache_directory()
        try:
            directory.mkdir(mode=0o700, parents=True, exist_ok=True)
            if not private(directory):
                return None
        except OSError:
            return None
        path = directory / f"operators-{name}.npz"
        return cls(path, _read(path))

    def get(self, name: str) -> dict[str, np.ndarray] | None:
        """The arrays stored under ``name`` (a dict of field → array), or None."""
        prefix = name + "|"
        found = {k[len(prefix):]: v for k, v in self.entries.items() if k.startswith(prefix)}
        return found or None

    def put(self, name: str, arrays: dict[str, np.ndarray]) -> None:
        """Store ``arrays`` under ``name``, in place of any it had (which the caller refused)."""
        prefix = name + "|"
        for key in [key for key in self.entries if key.startswith(prefix)]:
            del self.entries[key]
        for field, array in arrays.items():
            self.entries[f"{name}|{field}"] = np.array(array)
        self.changed = True

    def save(self) -> None:
        """Write the arrays if any were added (whole, then renamed; a failure leaves no file and
        costs only the next run's start), and keep the :data:`KEEP` newest files."""
        if not self.changed:
            if self.found:
                _touch(self.path)
            return
        self.changed = False
        arrays = _packed(self.entries)
        try:
            descriptor, temporary = tempfile.mkstemp(prefix=".operators-", suffix=".npz",
                                                     dir=self.path.parent)
            try:
                with os.fdopen(descriptor, "wb") as file:
                    np.savez(file, **arrays)
                os.replace(temporary, self.path)
            except BaseException:
                os.unlink(temporary)
                raise
        except OSError:
            return
        _prune(self.path.parent)


def _packed(entries: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The arrays as one byte string and its layout (a member of an .npz costs about half a
    millisecond to read: a discretisation has some fifty arrays), with their checksum."""
    layout, offset = [], 0
    for name, array in entries.items():
        layout.append([name, array.dtype.str, list(array.shape), offset])
        offset += array.nbytes
    blob = b"".join(np.ascontiguousarray(array).tobytes() for array in entries.values())
    return {"blob": np.frombuffer(blob, dtype=np.uint8), "layout": np.array(json.dumps(layout)),
            "checksum": np.array(_checksum(entries))}


def _read(path: Path) -> dict[str, np.ndarray] | None:
    """A file's arrays by name, or None if it is absent, unreadable or fails its checksum."""
    try:
        # opened without waiting (a FIFO in its place would block the run) and read only if it
        # is a regular file
        with open(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as file:
            if not stat.S_ISREG(os.fstat(file.fileno()).st_mode):
                return None
            with np.load(file, allow_pickle=False) as data:
                blob, layout = data["blob"], json.loads(str(data["layout"]))
                checksum = str(data["checksum"])
        entries = {}
        for name, dtype, shape, offset in layout:
            count = int(np.prod(shape, dtype=np.int64))
            entries[name] = np.frombuffer(blob, dtype=np.dtype(dtype), count=count,
                                          offset=offset).reshape(shape).copy()
    except Exception:  # noqa: BLE001 (absent, cut, edited: assembled again)
        return None
    return entries if checksum == _checksum(entries) else None


def _touch(path: Path) -> None:
    try:
        os.utime(path)
    except OSError:
        pass


def _prune(directory: Path) -> None:
    """Remove all but the :data:`KEEP` most recently used operator files."""
    try:
        files = sorted(directory.glob("operators-*.npz"), key=lambda p: p.stat().st_mtime_ns)
        for path in files[:-KEEP]:
            path.unlink(missing_ok=True)
    except OSError:
        pass
