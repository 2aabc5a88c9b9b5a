"""Building rodfem's compiled loops (``direct.c``, ``picard.c``) with cffi.

Both include the shared headers beside them: ``contact.h`` (the contact laws), ``exchange.h`` (the
heat-exchange laws) and ``record.h`` (the raw history row); ``direct.c`` also its own parts
``end.h`` and ``band.h``. A C source is compiled (API mode, the system's C compiler, as dolfinx's
JIT does) once per hash of its text and its headers' texts, the compiler flags, the cffi version and
the interpreter, into ``$XDG_CACHE_HOME/rodfem`` (or ``~/.cache/rodfem``, else a per-user directory
in the temporary directory): in a temporary directory beside the target, then moved into place with
:func:`os.replace`, so that MPI ranks compiling at once never see each other's half-written file. A
module found in the cache is loaded and run, so a directory is used only if it is private: owned by
this user and writable by nobody else. Nothing is compiled at import;
:meth:`CompiledSource.available` is False (and says why) without cffi, a compiler or a usable
directory, and the caller keeps the PETSc loop.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

from rodfem.discrete.cache import cache_directory, private

COMPILE_ARGS = ["-O2", "-std=c99"]


def declarations(source: str) -> str:
    """The part of a C source between ``/* cdef begin … */`` and ``/* cdef end */``: what cffi
    is told of it. A header without them (a part of one source) declares nothing."""
    if "/* cdef begin" not in source:
        return ""
    begin = source.index("/* cdef begin")
    begin = source.index("*/", begin) + 2
    return source[begin:source.index("/* cdef end */")]


def headers(source: str, directory: Path) -> list[str]:
    """The texts of the local headers (``#include "x.h"``) a source includes, in order."""
    return [(directory / name).read_text()
            for name in re.findall(r'^#include "([\w.]+)"', source, flags=re.M)]


class CompiledSource:
    """One C source, built and loaded on first use: ``library()`` gives cffi's (ffi, lib)."""

    def __init__(self, source: Path, prefix: str, what: str, check=None):
        """``check(lib)`` runs once the library is loaded: it raises if the C side disagrees
        with the Python side (e.g. the raw row's slots or the laws' codes)."""
        self.source, self.prefix, self.what, self.check = source, prefix, what, check
        self._loaded: list = []  # [(ffi, lib)] once built
        self._failure: list[str] = []  # why it could not be built

    def _build(self):
        import cffi  # optional: available() is False without it

        source = self.source.read_text()
        included = headers(source, self.source.parent)
        suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
        key = "\n".join([*included, source, repr(COMPILE_ARGS), cffi.__version__, sys.version,
                         suffix])
        name = self.prefix + hashlib.sha256(key.encode()).hexdigest()[:16]
        fallback = Path(tempfile.gettempdir()) / f"rodfem-{os.getuid()}"
        for directory in (cache_directory(), fallback):
            target = directory / (name + suffix)
            try:
                directory.mkdir(mode=0o700, parents=True, exist_ok=True)
            except OSError:
                continue
            if not private(directory):
                continue
            if not target.exists():
                try:
                    work = tempfile.mkdtemp(prefix=name + "-", dir=directory)
                except OSError:
                    continue
                try:
                    ffi = cffi.FFI()
                    ffi.cdef("".join(declarations(text) for text in [*included, source]))
                    ffi.set_source(name, source, extra_compile_args=COMPILE_ARGS,
                                   include_dirs=[str(self.source.parent)])
                    built = ffi.compile(tmpdir=work, verbose=False)
                    os.replace(built, target)
                finally:
                    shutil.rmtree(work, ignore_errors=True)
            spec = importlib.util.spec_from_file_location(name, target)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            if self.check is not None:
                self.check(module.lib)
            return module.ffi, module.lib
        raise OSError(f"no private writable directory for the {self.what}: {cache_directory()}, "
                      f"{fallback}")

    def library(self):
        """cffi's (ffi, lib), built on first call. RuntimeError if it cannot be."""
        if not self._loaded and not self._failure:
            try:
                self._loaded.append(self._build())
            except Exception as error:  # no cffi, no compiler, no directory: not available
                self._failure.append(f"{type(error).__name__}: {error}")
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
