"""Every dolfinx call whose spelling differs between the versions rodfem runs on.

Debian 12 ships dolfinx 0.5.2, Debian 13 (the container) 0.9.0, Debian unstable (sid) 0.11.0 with
PETSc 3.25 and FFCx 0.11 (containers/Dockerfile.sid). Everything else in rodfem uses calls that are
the same in all three; anything version-specific (dolfinx, UFL, basix, FFCx, petsc4py) goes here
and nowhere else.
"""

from __future__ import annotations

import logging

import dolfinx
import dolfinx.fem.petsc
import ffcx  # noqa: F401  (calls logging.basicConfig(): its handler is quietened below)
from dolfinx import fem
from petsc4py import PETSc

VERSION = tuple(int(part) for part in dolfinx.__version__.split(".")[:2])

# Each JIT build runs setuptools, which sets the root logger to INFO and reports every compiler
# call through the handler ffcx installed. Handler levels are left alone by that: raise them.
for _handler in logging.getLogger().handlers:
    _handler.setLevel(logging.WARNING)


def _remember_cached_modules() -> None:
    """FFCx looks for an already compiled form in its cache directory on every ``fem.form``: a
    fresh directory listing (about 0.6 ms with a thousand cached modules) and a module load, 13 ms
    of the 30 ms set-up of a 250-cell run. The answer never changes within a process, so remember
    it by module name (FFCx's own signature of the form). A lookup that finds nothing (FFCx is
    about to compile) is not remembered."""
    import ffcx.codegeneration.jit as jit

    lookup = getattr(jit, "get_cached_module", None)
    if lookup is None or getattr(lookup, "remembers", False):
        return
    found: dict = {}

    def remembering(module_name, object_names, cache_dir, timeout):
        key = (module_name, tuple(object_names), str(cache_dir))
        if key not in found:
            objects, module = lookup(module_name, object_names, cache_dir, timeout)
            if objects is None:
                return objects, module
            found[key] = (objects, module)
        return found[key]

    remembering.remembers = True
    jit.get_cached_module = remembering


_remember_cached_modules()


def function_space(mesh, family: str, degree: int):
    """A scalar Lagrange/DG function space."""
    if VERSION < (0, 7):
        return fem.FunctionSpace(mesh, (family, degree))
    return fem.functionspace(mesh, (family, degree))


def petsc_vector(f: fem.Function):
    """The PETSc vector (with ghosts) that holds the values of a Function."""
    if VERSION < (0, 7):
        return f.vector
    return f.x.petsc_vec


def interpolation_points(V):
    """The reference points at which V's element interpolates."""
    points = V.element.interpolation_points
    return points() if callable(points) else points


def set_bc(b, bcs) -> None:
    """Set the Dirichlet rows of b to the (homogeneous) boundary values."""
    dolfinx.fem.petsc.set_bc(b, bcs)


def assemble_matrix(a, bcs, diagonal: float):
    """Assemble a bilinear form into an assembled PETSc matrix."""
    if VERSION < (0, 10):
        A = dolfinx.fem.petsc.assemble_matrix(a, bcs=bcs, diagonal=diagonal)
    else:  # ``diag`` since the rewrite of dolfinx.fem.petsc in 0.10 (checked on 0.11)
        A = dolfinx.fem.petsc.assemble_matrix(a, bcs=bcs, diag=diagonal)
    A.assemble()
    return A


def assemble_vector(L):
    """Assemble a linear form into a PETSc vector, with ghost contributions summed."""
    from petsc4py import PETSc

    b = dolfinx.fem.petsc.assemble_vector(L)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b


# The reason SNES gives up on a residual that is not finite: PETSc 3.25 (Debian sid, with dolfinx
# 0.11) renamed SNES_DIVERGED_FNORM_NAN to SNES_DIVERGED_FUNCTION_NANORINF.
SNES_DIVERGED_NAN = (PETSc.SNES.ConvergedReason.DIVERGED_FUNCTION_NANORINF
                     if hasattr(PETSc.SNES.ConvergedReason, "DIVERGED_FUNCTION_NANORINF")
                     else PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN)


def ffcx_command(ufl_file, directory) -> list[str]:
    """The arguments of ``python -m ffcx`` that compile ``ufl_file`` into ``directory``: FFCx 0.5
    and 0.9 spell the output directory ``-o``/``--output-directory``, 0.11 ``-d``/``--dir`` (its
    ``-o`` is the generated files' name stem)."""
    import ffcx.main

    options = getattr(ffcx.main.parser, "_option_string_actions", {})
    flag = "--dir" if "--dir" in options else "--output-directory"
    return ["-m", "ffcx", str(ufl_file), flag, str(directory)]
