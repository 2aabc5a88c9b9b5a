"""The files of a run: history.csv, fields.xdmf (+ .h5), scene.toml and summary.json.

Rank 0 writes the text files; the XDMF file is written collectively. Files are written as the run
goes, so a run that fails or is interrupted keeps everything it computed.
"""

from __future__ import annotations

import json
import queue
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
