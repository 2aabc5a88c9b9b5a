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


def save_image(plotter, path) -> None:
    """The plotter's picture in the format of the path's suffix, written whole or not at all (a
    full disk leaves no half image): PNG from a screenshot, PDF or SVG through VTK's GL2PS export
    (text and lines as vectors)."""
    from pathlib import Path

    from PIL import Image

    from rodfem.output.atomic import named, replacing
    from rodfem.output.figures import of

    path = Path(path)
    fmt = of(path)
    if fmt == "png":
        image = Image.fromarray(plotter.screenshot(None, return_img=True))
        with replacing(path, "wb") as file:
            image.save(file, format="PNG")
        return
    part = path.with_name(f".{path.stem}.{os.getpid()}.{fmt}")  # GL2PS reads the suffix
    try:
        plotter.save_graphic(str(part), title=path.stem, raster=True, painter=True)
        if not part.is_file() or part.stat().st_size == 0:
            raise OSError(5, "the vector export wrote nothing", str(path))
        with open(part, "rb+") as file:
            os.fsync(file.fileno())
        os.replace(part, path)
    except BaseException as err:
        part.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise named(err, path) from None
        raise
