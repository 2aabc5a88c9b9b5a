"""fields.xdmf and fields/: θ and u per node, σ per cell, at the saved steps, in float64.

Layout (XDMF 3, as dolfinx writes it, which ParaView and pyvista open):

* ``fields/mesh.h5``: ``/geometry`` (nodes × 2: x, 0) and ``/topology`` (cells × 2), nodes in
  order of x, cell j between nodes j and j + 1;
* ``fields/steps-NNNNNN.h5``: one *segment* per checkpoint, ``/theta``, ``/u`` (saves × nodes)
  and ``/sigma`` (saves × cells), a row per saved step;
* ``fields.xdmf``: one temporal collection per field, each step a hyperslab (a row) of a segment,
  every data item declared ``Precision="8"`` so that VTK reads float64.

A save costs the same however many came before: rank 0 keeps the saves since the last checkpoint
in memory; :meth:`FieldFile.checkpoint` writes them as a new segment, closes and syncs it, and
only then replaces ``fields.xdmf`` (write-then-rename) to list it. A process killed at any instant
leaves every step up to its last checkpoint readable, and files that are each whole.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import h5py
import numpy as np
import scipy.sparse
from dolfinx import fem
from petsc4py import PETSc

import forms.copetti as copetti
from rodfem.discrete import compat
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.atomic import named, replacing, temporary

FIELDS = ("theta", "u", "sigma")
DIRECTORY = "fields"
MESH = "mesh.h5"


SEGMENT = re.compile(r"^steps-\d{6,}\.h5$")


def segment_name(k: int) -> str:
    return f"steps-{k:06d}.h5"


def _write_h5(path: Path, datasets: dict[str, np.ndarray]) -> None:
    """An HDF5 file of float64/int64 datasets, written whole (to a temporary file, synced,
    renamed)."""
    part = temporary(path)
    try:
        with h5py.File(part, "w") as f:
            for name, data in datasets.items():
                f.create_dataset(name, data=data)
        fd = os.open(part, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(part, path)
    except BaseException as err:
        part.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise named(err, path) from None
        raise


class FieldFile:
    """The saved fields of a run (collective: every rank calls :meth:`write`).

    ``saves``: the steps already on disk (a resumed run), each ``[step, t, segment, row]``.
    ``path=None``: nothing is written; the saves are kept (:meth:`kept`)."""

    def __init__(self, path: Path | None, disc: Discretisation, saves: list | None = None,
                 segments: int = 0):
        self.path, self.comm = path, disc.comm
        self.Θ, self.U = disc.function("Θ"), disc.function("U")
        self.U_prev = disc.function("U_prev")
        self.theta = disc.function("theta")
        self.sigma = fem.Function(disc.W)
        c = disc.const
        θ = copetti.temperature(self.Θ, c.theta_A, disc.r)
        σ = copetti.stress(self.U, self.U_prev, θ, c.dt, c.zeta, c.a)
        self.theta_expr = fem.Expression(θ, compat.interpolation_points(disc.V))
        self.sigma_expr = fem.Expression(σ, compat.interpolation_points(disc.W))
        self.nodes = disc.nodes
        # Rank 0 puts the owned values of every rank in order: nodes by x, cells by midpoint.
        self._owned_nodes = disc.V.dofmap.index_map.size_local
        self._owned_cells = disc.W.dofmap.index_map.size_local
        midpoints = disc.W.tabulate_dof_coordinates()[: self._owned_cells, 0]
        gathered = self.comm.gather((self.nodes.owned, midpoints), root=0)
        self.saves = [list(s) for s in saves or []]
        self.segments = segments
        self._pending: list[tuple[int, float, np.ndarray, np.ndarray, np.ndarray]] = []
        if self.comm.rank == 0:
            self._node_positions = np.concatenate([g[0] for g in gathered])
            self._cell_order = np.argsort(np.concatenate([g[1] for g in gathered]),
                                          kind="stable")
            self.x = self.nodes.x.copy()
            self.cells = self.x.size - 1
            self.x_cells = np.sort(np.concatenate([g[1] for g in gathered]))
        self._read_maps(disc)
        if self.comm.rank == 0:
            if path is None:
                return
            (path.parent / DIRECTORY).mkdir(exist_ok=True)
            if saves is None:
                geometry = np.stack([self.x, np.zeros_like(self.x)], axis=1)
                topology = np.stack([np.arange(self.cells), np.arange(1, self.cells + 1)],
                                    axis=1).astype(np.int64)
                _write_h5(path.parent / DIRECTORY / MESH,
                          {"geometry": geometry, "topology": topology})
            self._write_xdmf()

    def _gather(self, values: np.ndarray) -> np.ndarray | None:
        parts = self.comm.gather(np.ascontiguousarray(values), root=0)
        return np.concatenate(parts) if self.comm.rank == 0 else None

    def _evaluate(self, theta, u, u_prev) -> tuple[np.ndarray, np.ndarray] | None:
        """θ at the nodes and σ per cell (rank 0; None elsewhere) for the node-ordered vectors
        Θ, U, U_prev, by interpolating the forms' expressions (collective)."""
        for f, values in ((self.Θ, theta), (self.U, u), (self.U_prev, u_prev)):
            compat.petsc_vector(f).array[:] = self.nodes.owned_values(values)
            f.x.scatter_forward()
        self.theta.interpolate(self.theta_expr)
        self.sigma.interpolate(self.sigma_expr)
        theta_owned = self._gather(self.theta.x.array[: self._owned_nodes])
        sigma_owned = self._gather(self.sigma.x.array[: self._owned_cells])
        if self.comm.rank != 0:
            return None
        θ = np.empty(self.x.size)
        θ[self._node_positions] = theta_owned
        return θ, sigma_owned[self._cell_order]

    def _read_maps(self, disc: Discretisation) -> None:
        """θ and σ are affine in (Θ, U, U_prev): read their coefficients off the expressions once,
        so that a save is a few NumPy operations on rank 0 instead of two interpolations and two
        gathers (most of a save's cost). θ = Θ + θ₀ with θ₀ = θ(0); σ of cell j is
        Σ_f (l_f f_j + r_f f_{j+1}) + σ₀ over f = U, U_prev, Θ, the coefficients found by
        probing with f = 1 on every third node (so that no cell sees two probed nodes) with
        θ_A = 0, where the expressions are linear; σ₀ = σ(0) with the scene's θ_A."""
        n = self.nodes.size
        vectors = [PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF) for _ in range(3)]
        for v in vectors:
            v.zeroEntries()
        base = self._evaluate(*vectors)
        coefficients = {}
        theta_A = disc.const.theta_A
        value = float(theta_A.value)
        theta_A.value = 0.0
        try:
            for f, name in enumerate(("theta", "u", "u_prev")):
                left, right, unit = np.zeros(n - 1), np.zeros(n - 1), None
                for k in range(3):
                    probe = (np.arange(n) % 3 == k).astype(float)
                    vectors[f].array[:] = probe
                    response = self._evaluate(*vectors)
                    if response is not None:
                        sigma = response[1]
                        left[probe[:-1] == 1.0] = sigma[probe[:-1] == 1.0]
                        right[probe[1:] == 1.0] = sigma[probe[1:] == 1.0]
                        if f == 0:
                            unit = response[0] if unit is None else unit + response[0]
                vectors[f].zeroEntries()
                coefficients[name] = (left, right)
                if f == 0 and unit is not None and not np.array_equal(unit, np.ones(n)):
                    raise RuntimeError("θ is not Θ plus a function of x: the maps do not apply")
        finally:
            theta_A.value = value
        for v in vectors:
            v.destroy()
        if base is not None:
            self._theta0, self._sigma0 = base
            # σ = S [Θ; U; U_prev] + σ₀, S sparse: a row per cell, its two nodes in each block
            cells = np.arange(n - 1)
            rows, columns, values = [], [], []
            for block, name in enumerate(("theta", "u", "u_prev")):
                left, right = coefficients[name]
                rows += [cells, cells]
                columns += [block * n + cells, block * n + cells + 1]
                values += [left, right]
            self._sigma_map = scipy.sparse.csr_matrix(
                (np.concatenate(values), (np.concatenate(rows), np.concatenate(columns))),
                shape=(n - 1, 3 * n))

    def write(self, step: int, t: float, theta, u, u_prev) -> None:
        """Keep the fields of ``step`` at time t, whose Θ, U, U_prev are the given node-ordered
        vectors, until the next :meth:`checkpoint`."""
        if self.comm.rank != 0:
            return
        Θ, U, U_prev = theta.array_r, u.array_r, u_prev.array_r
        σ = self._sigma_map @ np.concatenate([Θ, U, U_prev])
        σ += self._sigma0
        self._pending.append((step, t, Θ + self._theta0, U.copy(), σ))

    def kept(self) -> tuple[np.ndarray, ...] | None:
        """The saves so far (of a FieldFile without a path), as arrays: the steps, t, and θ, u
        (saves × nodes) and σ (saves × cells); None on ranks other than 0."""
        if self.comm.rank != 0:
            return None
        columns = list(zip(*self._pending, strict=True)) or [[], [], [], [], []]
        shapes = ((0,), (0,), (0, self.x.size), (0, self.x.size), (0, self.cells))
        return tuple(np.array(c) if len(c) else np.zeros(shape)
                     for c, shape in zip(columns, shapes, strict=True))

    def checkpoint(self) -> None:
        """Write the kept saves as a new segment, then list them in fields.xdmf (rank 0)."""
        if self.comm.rank != 0 or not self._pending or self.path is None:
            return
        k = self.segments
        _write_h5(self.path.parent / DIRECTORY / segment_name(k),
                  {name: np.stack([p[2 + i] for p in self._pending])
                   for i, name in enumerate(FIELDS)})
        self.saves += [[p[0], p[1], k, row] for row, p in enumerate(self._pending)]
        self.segments, self._pending = k + 1, []
        self._write_xdmf()

    def _write_xdmf(self) -> None:
        nodes, cells = self.x.size, self.cells
        include = ('<xi:include xpointer="xpointer(/Xdmf/Domain/Grid[@GridType=\'Uniform\'][1]'
                   '/*[self::Topology or self::Geometry])" />')
        rows = {k: sum(1 for s in self.saves if s[2] == k) for k in {s[2] for s in self.saves}}
        lines = [
            '<?xml version="1.0"?>',
            '<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>',
            '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">',
            "  <Domain>",
            '    <Grid Name="mesh" GridType="Uniform">',
            f'      <Topology TopologyType="PolyLine" NumberOfElements="{cells}" '
            'NodesPerElement="2">',
            f'        <DataItem Dimensions="{cells} 2" NumberType="Int" Precision="8" '
            f'Format="HDF">{DIRECTORY}/{MESH}:/topology</DataItem>',
            "      </Topology>",
            '      <Geometry GeometryType="XY">',
            f'        <DataItem Dimensions="{nodes} 2" NumberType="Float" Precision="8" '
            f'Format="HDF">{DIRECTORY}/{MESH}:/geometry</DataItem>',
            "      </Geometry>",
            "    </Grid>",
        ]
        for name in FIELDS:
            size, center = (cells, "Cell") if name == "sigma" else (nodes, "Node")
            lines.append(f'    <Grid Name="{name}" GridType="Collection" '
                         'CollectionType="Temporal">')
            for _, t, k, row in self.saves:
                lines += [
                    f'      <Grid Name="{name}" GridType="Uniform">',
                    f"        {include}",
                    f'        <Time Value="{float(t)!r}" />',
                    f'        <Attribute Name="{name}" AttributeType="Scalar" '
                    f'Center="{center}">',
                    f'          <DataItem ItemType="HyperSlab" Dimensions="{size} 1" '
                    'Type="HyperSlab">',
                    f'            <DataItem Dimensions="3 2" Format="XML">{row} 0 1 1 1 {size}'
                    "</DataItem>",
                    f'            <DataItem Dimensions="{rows[k]} {size}" NumberType="Float" '
                    f'Precision="8" Format="HDF">{DIRECTORY}/{segment_name(k)}:/{name}'
                    "</DataItem>",
                    "          </DataItem>",
                    "        </Attribute>",
                    "      </Grid>",
                ]
            lines.append("    </Grid>")
        lines += ["  </Domain>", "</Xdmf>", ""]
        with replacing(self.path) as file:
            file.write("\n".join(lines))
