"""A run's directory, and the directories of the studies: created for a new result, replaced
with ``--force`` only where everything in them is rodfem's."""

from __future__ import annotations

import shutil
from pathlib import Path

from mpi4py import MPI

RUN_FILES = ("history.csv", "fields.xdmf", "fields.h5", "scene.toml", "summary.json")
FIGURE_DIRS = ("figures", "figure5")
FIGURE_SUFFIXES = (".png", ".gif", ".mp4")
PAPER_ENTRIES = ("index.md", *(f"paper{i}" for i in range(1, 6)))


class OutputError(ValueError):
    """The output directory cannot be used (exit code 2)."""


def _foreign(path: Path) -> str | None:
    """The first entry below ``path`` that rodfem did not write (a run's files, its figures, the
    paper's runs and index), or None: only then may ``--force`` remove the directory."""
    for p in sorted(path.iterdir()):
        if p.is_symlink():
            return p.name
        if p.is_file() and (p.name in RUN_FILES or p.name == "index.md"):
            continue
        if p.is_dir() and p.name in FIGURE_DIRS:
            if all(f.is_file() and not f.is_symlink() and f.suffix in FIGURE_SUFFIXES
                   for f in p.iterdir()):
                continue
        elif p.is_dir() and p.name in PAPER_ENTRIES and _foreign(p) is None:
            continue
        return p.name
    return None


def prepare_directory(path: Path, force: bool, comm: MPI.Comm, keep: Path | None = None) -> None:
    """Create ``path`` for a new run. An existing one is replaced only with ``force``, and only if
    it holds nothing but what rodfem writes (runs, figures, the paper's index); never if it holds
    ``keep`` (the scene being run)."""
    error = None
    if comm.rank == 0:
        try:
            if path.exists() or path.is_symlink():
                if not force:
                    raise OutputError(f"output directory {path} exists; use --force to replace it")
                if not path.is_dir() or path.is_symlink():
                    raise OutputError(f"output path {path} exists and is not a directory")
                foreign = _foreign(path)
                if foreign is not None:
                    raise OutputError(
                        f"{path} is not a rodfem output directory (it holds {foreign}); "
                        "not replacing it, even with --force"
                    )
                if keep is not None and path.resolve() in keep.resolve().parents:
                    raise OutputError(f"the scene {keep} is inside the output directory {path}")
                shutil.rmtree(path)  # only what rodfem wrote, checked above
            path.mkdir(parents=True)
        except OSError as err:
            error = f"cannot create output directory {path}: {err.strerror}"
        except OutputError as err:
            error = str(err)
    error = comm.bcast(error, root=0)
    if error:
        raise OutputError(error)


def prepare_result_directory(out: Path, force: bool, comm: MPI.Comm,
                             files: tuple[str, ...]) -> None:
    """Create ``out`` for a command's result (``rodfem stability``, ``verify``,
    ``work-precision``); with ``force``, replace an earlier result of that command (its ``files``
    and a figures/ of PNGs) but nothing else.

    Raises:
        OutputError: it exists (without ``force``), or holds something else.
    """
    error = None
    if comm.rank == 0 and force and out.is_dir() and not out.is_symlink():
        entries = sorted(out.iterdir())
        ours = [p for p in entries if p.name in files and p.is_file() and not p.is_symlink()]
        for p in entries:
            if p in ours:
                continue
            if (p.name == "figures" and p.is_dir() and not p.is_symlink()
                    and all(f.is_file() and not f.is_symlink() and f.suffix == ".png"
                            for f in p.iterdir())):
                continue
            error = (f"{out} is not a rodfem output directory (it holds {p.name}); "
                     "not replacing it, even with --force")
            break
        if error is None:
            for p in ours:
                p.unlink()
    error = comm.bcast(error, root=0)
    if error:
        raise OutputError(error)
    prepare_directory(out, force, comm)
