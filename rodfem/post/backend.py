"""VTK, loaded safely next to dolfinx, and rendering without a display.

dolfinx 0.5 switches Python's dlopen flags to RTLD_GLOBAL when imported and leaves them so. Every
library loaded afterwards then binds to the instances of C++ templates that libdolfinx (and
Kokkos, through PETSc) export, ahead of its own: for the VTK wheel, built with the old libstdc++
string ABI, that means std::regex code of the new ABI, and a crash (std::bad_alloc in the label
format of a scalar bar). RTLD_DEEPBIND makes each VTK library look in itself and its own
dependencies first. All of VTK is loaded here, at once, so that pyvista's later imports find it
loaded whatever the flags are by then.
"""

from __future__ import annotations

import os
import sys

_flags = sys.getdlopenflags()
sys.setdlopenflags(os.RTLD_NOW | getattr(os, "RTLD_DEEPBIND", 0))
try:
    import pyvista as pv
    import vtkmodules.all  # noqa: F401 (every VTK library, now)
finally:
    sys.setdlopenflags(_flags)


def off_screen() -> None:
    """Render without a display, as in tests, containers and over ssh.

    Without a display VTK tries X first and warns before it falls back to EGL (then OSMesa);
    asking for EGL first skips the X attempt. An explicit choice in the environment wins.
    """
    pv.OFF_SCREEN = True
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

