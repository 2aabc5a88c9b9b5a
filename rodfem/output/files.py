"""A run's directory: history.csv, fields.xdmf (+ .h5), scene.toml and summary.json.

Rank 0 writes the text files; the XDMF file is written collectively. Files are written as the run
goes, so a run that fails or is interrupted keeps everything it computed.
"""

from __future__ import annotations

import json
import queue
import shutil
import threading
import time
from pathlib import Path

import numpy as np
from dolfinx import fem
from dolfinx.io import XDMFFile
from mpi4py import MPI

import forms.copetti as copetti
from rodfem.discrete import compat
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.columns import COLUMNS, NAMES

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


class HistoryFile:
    """history.csv, one row per step, appended block by block (rank 0).

    Printing a row's seven numbers to round-trip precision takes about 2 µs, as long as a compiled
    step itself, so rank 0 formats and writes the blocks in a thread of its own while the time
    loop (a C call that releases the GIL) goes on. :meth:`close` waits for every block and passes
    on any error of the writer."""

    ROW = ",".join("%d" if c.integer else "%.17g" for c in COLUMNS) + "\n"  # round-trip floats

    def __init__(self, path: Path, comm: MPI.Comm):
        self.file = open(path, "w", encoding="utf-8") if comm.rank == 0 else None
        self._error: BaseException | None = None
        if self.file:
            self.file.write(",".join(NAMES) + "\n")
            self._blocks: queue.Queue = queue.Queue()
            self._writer = threading.Thread(target=self._write, name="history.csv", daemon=True)
            self._writer.start()

    def _write(self) -> None:
        row = self.ROW
        while (rows := self._blocks.get()) is not None:
            if self._error is None:
                try:
                    for part in range(0, len(rows), 64):  # short holds of the GIL
                        self.file.write("".join([row % tuple(r)
                                                 for r in rows[part:part + 64].tolist()]))
                        time.sleep(0)
                    self.file.flush()
                except BaseException as err:  # noqa: BLE001 (handed to close)
                    self._error = err

    def append(self, rows: np.ndarray) -> None:
        if self.file:
            self._blocks.put(np.array(rows, copy=True))

    def close(self) -> None:
        if self.file:
            self._blocks.put(None)
            self._writer.join()
            self.file.close()
            if self._error is not None:
                raise self._error


class FieldFile:
    """fields.xdmf: θ (P1), u (P1) and σ (DG0, constant per cell) at saved steps."""

    def __init__(self, path: Path, disc: Discretisation):
        self.Θ, self.U = disc.function("Θ"), disc.function("U")
        self.U_prev = disc.function("U_prev")
        self.theta, self.u = disc.function("theta"), self.U
        self.u.name = "u"
        self.sigma = fem.Function(disc.W)
        self.sigma.name = "sigma"
        c = disc.const
        θ = copetti.temperature(self.Θ, c.theta_A, disc.r)
        σ = copetti.stress(self.U, self.U_prev, θ, c.dt, c.zeta, c.a)
        self.theta_expr = fem.Expression(θ, compat.interpolation_points(disc.V))
        self.sigma_expr = fem.Expression(σ, compat.interpolation_points(disc.W))
        self.nodes = disc.nodes
        self.file = XDMFFile(disc.comm, str(path), "w")
        self.file.write_mesh(disc.mesh)

    def write(self, t: float, theta, u, u_prev) -> None:
        """Write the fields of the step whose Θ, U, U_prev are the given node-ordered vectors."""
        for f, values in ((self.Θ, theta), (self.U, u), (self.U_prev, u_prev)):
            compat.petsc_vector(f).array[:] = self.nodes.owned_values(values)
            f.x.scatter_forward()
        self.theta.interpolate(self.theta_expr)
        self.sigma.interpolate(self.sigma_expr)
        for f in (self.theta, self.u, self.sigma):
            self.file.write_function(f, t)

    def close(self) -> None:
        self.file.close()


def write_text(path: Path, text: str, comm: MPI.Comm) -> None:
    if comm.rank == 0:
        path.write_text(text, encoding="utf-8")


def write_json(path: Path, data: dict, comm: MPI.Comm) -> None:
    """Strict JSON: a non-finite number is written as null."""

    def finite(value):
        if isinstance(value, float) and not np.isfinite(value):
            return None
        if isinstance(value, dict):
            return {k: finite(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [finite(v) for v in value]
        return value

    write_text(path, json.dumps(finite(data), indent=2, allow_nan=False) + "\n", comm)
