"""fields.xdmf and fields/: the fields a scene chooses (``output.fields``: θ, u and the velocity
per node, σ and the heat flux per cell; θ, u and σ by default) at the saved steps, in float64.

Layout (XDMF 3, as dolfinx writes it, which ParaView and pyvista open):

* ``fields/mesh.h5``: ``/geometry`` (nodes × 2: x, 0) and ``/topology`` (cells × 2), nodes in
  order of x, cell j between nodes j and j + 1;
* ``fields/steps-NNNNNN.h5``: one *segment* per checkpoint, a dataset per field, ``/theta``,
  ``/u``, ``/velocity`` (saves × nodes), ``/sigma``, ``/heat_flux`` (saves × cells), a row per
  saved step;
* ``fields.xdmf``: one temporal collection per field, each step a hyperslab (a row) of a segment,
  every data item declared ``Precision="8"`` so that VTK reads float64.

A save costs the same however many came before: rank 0 keeps the saves since the last checkpoint
in memory; :meth:`FieldFile.checkpoint` writes them as a new segment, closes and syncs it, and
only then replaces ``fields.xdmf`` (write-then-rename) to list it. A process killed at any instant
leaves every step up to its last checkpoint readable, and files that are each whole.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import h5py
import numpy as np

from rodfem.discrete.discretisation import Discretisation
from rodfem.output.atomic import named, replacing, temporary
from rodfem.output.pointwise import CELL_FIELDS, NODE_FIELDS, Pointwise

FIELDS = (*NODE_FIELDS, *CELL_FIELDS)  # what output.fields may name
DIRECTORY = "fields"
MESH = "mesh.h5"


SEGMENT = re.compile(r"^steps-\d{6,}\.h5$")


def segment_name(k: int) -> str:
    return f"steps-{k:06d}.h5"


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes (a checkpoint records those of the files it counts)."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _write_h5(path: Path, datasets: dict[str, np.ndarray]) -> str:
    """An HDF5 file of float64/int64 datasets, written whole (to a temporary file, synced,
    renamed); its SHA-256."""
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
        digest = file_digest(part)
        os.replace(part, path)
        return digest
    except BaseException as err:
        part.unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise named(err, path) from None
        raise


class FieldFile:
    """The saved fields of a run (collective: every rank calls :meth:`write`): those of the
    scene's ``output.fields``, from the affine maps of :class:`rodfem.output.pointwise.Pointwise`.

    ``saves``: the steps already on disk (a resumed run), each ``[step, t, segment, row]``;
    ``digests``: the SHA-256 of the mesh and of each segment (:meth:`digests`) then.
    ``path=None``: nothing is written; the saves are kept (:meth:`kept`)."""

    def __init__(self, path: Path | None, disc: Discretisation, saves: list | None = None,
                 segments: int = 0, pointwise: Pointwise | None = None,
                 digests: dict | None = None):
        self.path, self.comm = path, disc.comm
        self.names = tuple(disc.scene["output.fields"])
        self.pointwise = pointwise or Pointwise(disc)
        self.saves = [list(s) for s in saves or []]
        self.segments = segments
        self.mesh_digest = (digests or {}).get("mesh")
        self.segment_digests = list((digests or {}).get("segments", []))
        self._pending: list[tuple[int, float, list[np.ndarray]]] = []
        self.x = self.pointwise.x
        self.cells = self.x.size - 1
        if self.comm.rank == 0:
            if path is None:
                return
            (path.parent / DIRECTORY).mkdir(exist_ok=True)
            if saves is None:
                geometry = np.stack([self.x, np.zeros_like(self.x)], axis=1)
                topology = np.stack([np.arange(self.cells), np.arange(1, self.cells + 1)],
                                    axis=1).astype(np.int64)
                self.mesh_digest = _write_h5(path.parent / DIRECTORY / MESH,
                                             {"geometry": geometry, "topology": topology})
            self._write_xdmf()

    def write(self, step: int, t: float, state: np.ndarray, dt: float | None = None) -> None:
        """Keep the fields of ``step`` at time t, of the state [Θ; D; U] (node order), D over a
        step of length ``dt`` (None: the scene's time.dt), until the next :meth:`checkpoint`."""
        if self.comm.rank != 0:
            return
        self._pending.append((step, t, [self.pointwise.field(name, state, dt)
                                        for name in self.names]))

    def kept(self) -> tuple | None:
        """The saves so far (of a FieldFile without a path): the steps, t, and per saved field
        its values (saves × nodes or cells), by name; None on ranks other than 0."""
        if self.comm.rank != 0:
            return None
        steps = np.array([p[0] for p in self._pending], dtype=np.int64)
        t = np.array([p[1] for p in self._pending], dtype=float)
        values = {}
        for i, name in enumerate(self.names):
            size = self.x.size if name in NODE_FIELDS else self.cells
            values[name] = (np.array([p[2][i] for p in self._pending]) if self._pending
                            else np.zeros((0, size)))
        return steps, t, values

    def checkpoint(self) -> None:
        """Write the kept saves as a new segment, then list them in fields.xdmf (rank 0)."""
        if self.comm.rank != 0 or not self._pending or self.path is None:
            return
        k = self.segments
        self.segment_digests.append(_write_h5(
            self.path.parent / DIRECTORY / segment_name(k),
            {name: np.stack([p[2][i] for p in self._pending])
             for i, name in enumerate(self.names)}))
        self.saves += [[p[0], p[1], k, row] for row, p in enumerate(self._pending)]
        self.segments, self._pending = k + 1, []
        self._write_xdmf()

    def digests(self) -> dict:
        """The SHA-256 of the mesh and of every segment written (rank 0), for the checkpoint."""
        return {"mesh": self.mesh_digest, "segments": list(self.segment_digests)}

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
        for name in self.names:
            size, center = (nodes, "Node") if name in NODE_FIELDS else (cells, "Cell")
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
