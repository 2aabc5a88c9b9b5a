"""Building rodfem's compiled loops (``direct.c``, ``picard.c``) with cffi, and loading only a
library that is the one its build wrote.

Both include the shared headers beside them: ``contact.h`` (the contact laws), ``exchange.h`` (the
heat-exchange laws) and ``record.h`` (the raw history row); ``direct.c`` also its own parts
``end.h`` and ``band.h``. A C source is compiled (API mode, the system's C compiler, as dolfinx's
JIT does) once per build key (:func:`inputs`: its text and its headers' texts, the compiler flags
and the compiler's variables, the cffi version and the interpreter) into
``$XDG_CACHE_HOME/rodfem`` (or ``~/.cache/rodfem``, else a per-user directory in the temporary
directory), used only if it is private: owned by this user and writable by nobody else.

**Compiled code is data too.** Beside each library its build writes a record (``<name>.json``:
the build's inputs, the library's size and the SHA-256 of its bytes). A library is loaded only if
it is a regular file (not a directory, a FIFO or a symbolic link), of the recorded size and digest,
and its record's inputs are this build's: an empty, cut, bit-flipped or foreign file, or one
without its record, is never handed to the dynamic loader (a cut one would be mapped and crash the
process with a bus error). Such a library is built again, under the cache directory's lock (so that
processes and MPI ranks build it once and never read half a file), in a temporary directory,
moved into place with :func:`os.replace`, its record written last. If it cannot be built (no
compiler, no writable directory) :meth:`CompiledSource.library` raises and the run refuses
(:func:`rodfem.solver.compiled.compiled_loop`): the PETSc loop's last digits differ. Nothing is
compiled at import.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import importlib.machinery
import importlib.util
import json
import os
import re
import shutil
import stat
import sys
import sysconfig
import tempfile
from pathlib import Path

from rodfem.discrete.cache import COMPILER_VARIABLES, cache_directory, private

COMPILE_ARGS = ["-O2", "-std=c99"]
RECORD_FORMAT = 1
LOCK = "build.lock"  # in the cache directory: held while a library is built
# the interpreter's own compilation settings, which distutils adds to ours
PYTHON_COMPILER = ("CC", "CFLAGS", "CCSHARED", "LDSHARED")
_kept: list[int] = []  # the in-memory files the loaded libraries were loaded from


def declarations(source: str) -> str:
    """The part of a C source between ``/* cdef begin … */`` and ``/* cdef end */``: what cffi
    is told of it. A header without them (a part of one source) declares nothing."""
    if "/* cdef begin" not in source:
        return ""
    begin = source.index("/* cdef begin")
    begin = source.index("*/", begin) + 2
    return source[begin:source.index("/* cdef end */")]


def headers(source: str, directory: Path) -> list[str]:
    """The texts of the local headers (``#include "x.h"``) a source includes, in order, each once
    (a header included twice, as adaptive.h is, is declared once)."""
    names = dict.fromkeys(re.findall(r'^#include "([\w.]+)"', source, flags=re.M))
    return [(directory / name).read_text() for name in names]


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def inputs(source: Path) -> dict:
    """What a build of ``source`` is made from (:func:`_inputs`), read once per process for
    each setting of the compiler's variables."""
    return json.loads(_inputs(source, tuple(os.environ.get(n) for n in COMPILER_VARIABLES)))


@functools.lru_cache(maxsize=None)
def _inputs(source: Path, variables: tuple) -> str:
    """What a build of ``source`` is made from. ``arithmetic`` is what decides the library's
    floating-point operations: the C texts (source and headers), our flags (``-std=c99``: no
    contraction into fused multiply-adds) and the compiler with its flags (the environment's and
    the interpreter's); ``build`` adds what else the library's bytes depend on (cffi, the
    interpreter, the extension's suffix). The library's own digest is not part of either: the
    same inputs give other bytes on another machine, or after a rebuild (debug paths)."""
    text = source.read_text()
    arithmetic = {
        "sources": _sha256("\n".join([*headers(text, source.parent), text])),
        "compile_args": COMPILE_ARGS,
        "compiler": dict(zip(COMPILER_VARIABLES, variables)),
        "python_compiler": {name: sysconfig.get_config_var(name) for name in PYTHON_COMPILER},
    }
    try:
        import cffi  # optional: without it nothing is built, and the caller says so
        version = cffi.__version__
    except ImportError:
        version = None
    build = {"cffi": version, "python": sys.version,
             "suffix": importlib.machinery.EXTENSION_SUFFIXES[0]}
    return json.dumps({"arithmetic": arithmetic, "build": build})


def arithmetic_digest(source: Path) -> str:
    """A short digest of the inputs that decide a compiled loop's arithmetic (:func:`inputs`):
    two runs whose loops have it equal take the same steps bit for bit."""
    return _sha256(json.dumps(inputs(source)["arithmetic"], sort_keys=True))[:16]


def _read_regular(path: Path, limit: int | None = None) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (not followed through a symbolic link,
    not waited on if it is a FIFO) of at most ``limit`` bytes, else None."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        status = os.fstat(fd)  # before open(), which refuses a directory
        if not stat.S_ISREG(status.st_mode) or (limit is not None and status.st_size > limit):
            return None
        with open(fd, "rb", closefd=False) as file:
            return file.read()
    except OSError:
        return None
    finally:
        os.close(fd)


def intact(target: Path, record: Path, wanted: dict) -> bytes | None:
    """The library's bytes if it is what its record says and the record is of a build of
    ``wanted`` inputs (:func:`inputs`), else None."""
    text = _read_regular(record, limit=1 << 16)
    if text is None:
        return None
    try:
        written = json.loads(text)
    except ValueError:
        return None
    if not isinstance(written, dict) or written.get("format") != RECORD_FORMAT \
            or written.get("inputs") != wanted:
        return None
    data = _read_regular(target, limit=1 << 28)
    if data is None or len(data) != written.get("size") \
            or hashlib.sha256(data).hexdigest() != written.get("sha256"):
        return None
    return data


@contextlib.contextmanager
def _locked(directory: Path):
    """The cache directory's build lock, held (blocking) for the block."""
    fd = os.open(directory / LOCK, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def _stderr_to(file):
    """The process's standard error (file descriptor 2: the compiler's, too) into ``file``."""
    sys.stderr.flush()
    saved = os.dup(2)
    os.dup2(file.fileno(), 2)
    try:
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _remove(path: Path) -> None:
    """Whatever is at a library's or record's name in the cache (a directory there is not a
    library; rodfem's cache is rodfem's)."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _write_record(record: Path, data: bytes, wanted: dict) -> None:
    """The record of a library of bytes ``data``, whole (temporary name, then renamed)."""
    fd, temporary = tempfile.mkstemp(prefix=".record-", dir=record.parent)
    try:
        with os.fdopen(fd, "w") as file:
            json.dump({"format": RECORD_FORMAT, "inputs": wanted, "size": len(data),
                       "sha256": hashlib.sha256(data).hexdigest()}, file, sort_keys=True)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, record)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def _load(name: str, data: bytes, directory: Path):
    """The extension module ``name`` made of the checked bytes ``data``.

    The bytes that were hashed are the bytes that are loaded: they are written to an anonymous
    in-memory file (memfd; a private temporary file in the cache directory where there is none)
    and the loader opens that. Loading the cache's path after checking it would leave a window in
    which another process could replace or cut the file between the check and the mapping."""
    if hasattr(os, "memfd_create"):
        # kept open for the process's life: the loader knows a library by its path, and a
        # closed descriptor's number (its /proc path) would be another library's next
        fd = os.memfd_create(name, os.MFD_CLOEXEC)
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
        _kept.append(fd)
        path, cleanup = f"/proc/self/fd/{fd}", lambda: None
    else:  # pragma: no cover (Linux has memfd)
        fd, path = tempfile.mkstemp(prefix=f".{name}-", suffix=".so", dir=directory)
        with os.fdopen(fd, "wb") as file:
            file.write(data)
        cleanup = lambda: os.unlink(path)  # noqa: E731
    try:
        spec = importlib.util.spec_from_loader(
            name, importlib.machinery.ExtensionFileLoader(name, path), origin=path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        cleanup()  # the loader keeps its own mapping
    return module


class CompiledSource:
    """One C source, built and loaded on first use: ``library()`` gives cffi's (ffi, lib)."""

    def __init__(self, source: Path, prefix: str, what: str, check=None):
        """``check(lib)`` runs once the library is loaded: it raises if the C side disagrees
        with the Python side (e.g. the raw row's slots or the laws' codes)."""
        self.source, self.prefix, self.what, self.check = source, prefix, what, check
        self._loaded: list = []  # [(ffi, lib)] once built
        self._failure: list[str] = []  # why it could not be built

    def arithmetic(self) -> str:
        """The digest of what decides this loop's arithmetic (:func:`arithmetic_digest`)."""
        return arithmetic_digest(self.source)

    def _compile(self, name: str, target: Path, directory: Path) -> None:
        """Compile into a temporary directory beside ``target``, then move it into place."""
        import cffi

        source = self.source.read_text()
        included = headers(source, self.source.parent)
        work = tempfile.mkdtemp(prefix=name + "-", dir=directory)
        try:
            ffi = cffi.FFI()
            ffi.cdef("".join(declarations(text) for text in [*included, source]))
            ffi.set_source(name, source, extra_compile_args=COMPILE_ARGS,
                           include_dirs=[str(self.source.parent)])
            with tempfile.TemporaryFile(dir=work) as said:
                try:
                    with _stderr_to(said):  # the compiler's words: in the one line, if it fails
                        built = ffi.compile(tmpdir=work, verbose=False)
                except Exception as error:
                    said.seek(0)
                    lines = [ln for ln in said.read().decode(errors="replace").splitlines()
                             if ln.strip()]
                    raise RuntimeError(f"the C compiler failed ({type(error).__name__}: "
                                       f"{error})" + (f": {lines[0]}" if lines else "")) from None
            os.replace(built, target)
        finally:
            shutil.rmtree(work, ignore_errors=True)

    def _build(self):
        wanted = inputs(self.source)
        name = self.prefix + _sha256(json.dumps(wanted, sort_keys=True))[:16]
        suffix = wanted["build"]["suffix"]
        fallback = Path(tempfile.gettempdir()) / f"rodfem-{os.getuid()}"
        unusable = []
        for directory in (cache_directory(), fallback):
            target, record = directory / (name + suffix), directory / (name + ".json")
            try:
                directory.mkdir(mode=0o700, parents=True, exist_ok=True)
                if not private(directory):
                    unusable.append(f"{directory} is not private")
                    continue
                data = intact(target, record, wanted)
                if data is None:
                    with _locked(directory):  # built once, by one process, whole
                        data = intact(target, record, wanted)  # another built it meanwhile
                        if data is None:
                            _remove(record)
                            _remove(target)
                            self._compile(name, target, directory)
                            _write_record(record, _read_regular(target) or b"", wanted)
                            data = intact(target, record, wanted)
            except OSError as error:  # e.g. a read-only cache: the next directory
                unusable.append(f"{directory}: {error.strerror or error}")
                continue
            if data is None:
                raise OSError(f"the {self.what} built in {directory} does not match its record")
            module = _load(name, data, directory)
            if self.check is not None:
                self.check(module.lib)
            return module.ffi, module.lib
        raise OSError(f"no private writable directory for the {self.what} "
                      f"({'; '.join(unusable)})")

    def library(self):
        """cffi's (ffi, lib), built on first call. RuntimeError if it cannot be."""
        if not self._loaded and not self._failure:
            try:
                self._loaded.append(self._build())
            except Exception as error:  # no cffi, no compiler, no directory: not available
                self._failure.append(" ".join(f"{type(error).__name__}: {error}".split()))
        if not self._loaded:
            raise RuntimeError(f"rodfem's compiled {self.what} is not available "
                               f"({self._failure[0]})")
        return self._loaded[0]

    def available(self) -> bool:
        """Whether it could be compiled and loaded (it is, on first call)."""
        try:
            self.library()
        except RuntimeError:
            return False
        return True

    def unavailable_reason(self) -> str | None:
        """Why :meth:`available` is False (None if it is True or was not asked yet)."""
        return self._failure[0] if self._failure else None
