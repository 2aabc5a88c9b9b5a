"""A run's directory: history.csv, fields.xdmf (+ .h5), scene.toml and summary.json.

Rank 0 writes the text files; the XDMF file is written collectively. Files are written as the run
goes, so a run that fails or is interrupted keeps everything it computed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from dolfinx import fem
from dolfinx.io import XDMFFile
from mpi4py import MPI

import forms.copetti as copetti
from rodfem import compat
from rodfem.discretisation import Discretisation
from rodfem.history import COLUMNS

RUN_FILES = ("history.csv", "fields.xdmf", "fields.h5", "scene.toml", "summary.json")


class OutputError(ValueError):
    """The output directory cannot be used (exit code 2)."""


def prepare_directory(path: Path, force: bool, comm: MPI.Comm, keep: Path | None = None) -> None:
    """Create ``path`` for a new run. An existing one is replaced only with ``force``, and only if
    it holds nothing but a previous run's files, which are the only ones removed; never if it
    holds ``keep`` (the scene being run)."""
    error = None
    if comm.rank == 0:
        try:
            if path.exists() or path.is_symlink():
                if not force:
                    raise OutputError(f"output directory {path} exists; use --force to replace it")
                if not path.is_dir() or path.is_symlink():
                    raise OutputError(f"output path {path} exists and is not a directory")
                contents = list(path.iterdir())
                foreign = [p.name for p in contents if p.name not in RUN_FILES or not p.is_file()]
                if foreign:
                    raise OutputError(
                        f"{path} is not a rodfem run directory (it holds {foreign[0]}); "
                        "not replacing it, even with --force"
                    )
                if keep is not None and keep.resolve().parent == path.resolve():
                    raise OutputError(f"the scene {keep} is inside the output directory {path}")
                for p in contents:
                    p.unlink()
                path.rmdir()
            path.mkdir(parents=True)
        except OSError as err:
            error = f"cannot create output directory {path}: {err.strerror}"
        except OutputError as err:
            error = str(err)
    error = comm.bcast(error, root=0)
    if error:
        raise OutputError(error)


class HistoryFile:
    """history.csv, one row per step, appended block by block (rank 0)."""

    def __init__(self, path: Path, comm: MPI.Comm):
        self.file = open(path, "w", encoding="utf-8") if comm.rank == 0 else None
        if self.file:
            self.file.write(",".join(COLUMNS) + "\n")

    def append(self, rows: np.ndarray) -> None:
        if self.file:
            for row in rows:
                self.file.write(",".join(f"{v:.17g}" for v in row[:-1]) + f",{int(row[-1])}\n")
            self.file.flush()

    def close(self) -> None:
        if self.file:
            self.file.close()


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
        return value

    write_text(path, json.dumps(finite(data), indent=2, allow_nan=False) + "\n", comm)
