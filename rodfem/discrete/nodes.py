"""The rod's nodes in order of x, the same on every rank.

dolfinx distributes the mesh, assembles and writes files in parallel. The time loop, however, runs
on every rank on the whole rod, on sequential PETSc objects whose rows are the nodes in order of
x: the operators are gathered into that order once, after assembly.

Why: a parallel run must write the serial history to 1e-12. Distributed linear algebra sums in
another order (a parallel LU such as MUMPS, mat-vecs split at partition boundaries), and over a
paper run that alone moves u(1, t) by 1.2e-12 (paper1, MUMPS against PETSc's LU, both serial):
at the tolerance, and more on longer runs. A sequential tridiagonal loop in node order does the
serial arithmetic on every rank, bit for bit, whatever the partition; a 1D rod's state is small
enough to hold whole, and at 250 cells MUMPS costs 3.4 ms a step against 50 µs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rodfem.discrete.arrays import Matrix

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc


class NodeOrder:
    """Maps between the distributed PETSc numbering of a P1 space and node order x_0 < … < x_s."""

    def __init__(self, comm: MPI.Comm, x: np.ndarray, position: np.ndarray,
                 owned: np.ndarray):
        self.comm = comm
        #: the nodes' coordinates, in order
        self.x = x
        #: position[g] = the node-order position of the dof with PETSc global index g
        self.position = position
        #: node-order positions of this rank's owned dofs, in its local order
        self.owned = owned

    @classmethod
    def of_space(cls, V) -> NodeOrder:
        """The node order of the P1 space V (collective)."""
        comm: MPI.Comm = V.mesh.comm
        index_map = V.dofmap.index_map
        owned = index_map.size_local
        start = index_map.local_range[0]
        x_owned = V.tabulate_dof_coordinates()[:owned, 0]
        gathered = comm.allgather((np.arange(start, start + owned), x_owned))
        global_index = np.concatenate([g for g, _ in gathered])
        x = np.concatenate([c for _, c in gathered])
        order = np.argsort(x, kind="stable")
        position = np.empty(global_index.size, dtype=np.int64)
        position[global_index[order]] = np.arange(order.size)
        return cls(comm, x[order], position, position[np.arange(start, start + owned)])

    @property
    def size(self) -> int:
        return self.x.size

    def _gathered(self, part):
        return [part] if self.comm.size == 1 else self.comm.allgather(part)

    def matrix(self, A: PETSc.Mat) -> PETSc.Mat:
        """A sequential copy of the distributed matrix A, rows and columns in node order."""
        from petsc4py import PETSc

        rstart, rend = A.getOwnershipRange()
        indptr, cols, values = A.getValuesCSR()
        rows = np.repeat(np.arange(rstart, rend), np.diff(indptr))
        parts = self._gathered((rows, cols, values))
        r = self.position[np.concatenate([p[0] for p in parts])]
        c = self.position[np.concatenate([p[1] for p in parts])]
        v = np.concatenate([p[2] for p in parts])
        order = np.lexsort((c, r))
        r, c, v = r[order], c[order], v[order]
        indptr = np.searchsorted(r, np.arange(self.size + 1)).astype(PETSc.IntType)
        B = PETSc.Mat().createAIJ(
            size=(self.size, self.size), csr=(indptr, c.astype(PETSc.IntType), v),
            comm=PETSc.COMM_SELF,
        )
        B.assemble()
        return B

    def vector(self, b: PETSc.Vec) -> PETSc.Vec:
        """A sequential copy of the distributed vector b, in node order."""
        from petsc4py import PETSc

        rstart, rend = b.getOwnershipRange()
        parts = self._gathered((np.arange(rstart, rend), b.array_r.copy()))
        values = np.empty(self.size)
        for g, v in parts:
            values[self.position[g]] = v
        return PETSc.Vec().createWithArray(values, comm=PETSc.COMM_SELF)

    def owned_values(self, u: PETSc.Vec) -> np.ndarray:
        """This rank's owned entries, in its local order, of the node-ordered vector u."""
        return u.array_r[self.owned]

    # A point within this fraction of a cell from a node is the node: x = 0.3 is the node that
    # the mesh places at 0.30000000000000004.
    SNAP = 1e-10

    def interpolation(self, x0: float) -> tuple[np.ndarray, np.ndarray]:
        """Node positions and weights with u(x0) = Σ w_j u_j for u in P1: one node, weight 1,
        where x0 is a node (to :attr:`SNAP` of a cell)."""
        j = int(np.clip(np.searchsorted(self.x, x0, side="right") - 1, 0, self.size - 2))
        t = (x0 - self.x[j]) / (self.x[j + 1] - self.x[j])
        if t <= self.SNAP or t >= 1.0 - self.SNAP:
            return np.array([j + int(t >= 0.5)], dtype=np.intp), np.array([1.0])
        return np.array([j, j + 1], dtype=np.intp), np.array([1.0 - t, t])


def block_matrix(blocks: list[list[PETSc.Mat | None]]) -> PETSc.Mat | Matrix:
    """The sequential AIJ matrix [[B_00, B_01, …], …] of sequential AIJ blocks (None: zero).
    Every block row has one block of each row count; every block column, of each column count.
    Of NumPy blocks (:class:`~rodfem.discrete.arrays.Matrix`), a NumPy matrix of the same CSR
    arrays."""
    heights = [next(B for B in row if B is not None).getSize()[0] for row in blocks]
    widths = [next(row[j] for row in blocks if row[j] is not None).getSize()[1]
              for j in range(len(blocks[0]))]
    row_offsets, col_offsets = np.cumsum([0, *heights]), np.cumsum([0, *widths])
    rows, cols, values = [], [], []
    for i, row in enumerate(blocks):
        for j, B in enumerate(row):
            if B is None:
                continue
            indptr, indices, v = B.getValuesCSR()
            rows.append(np.repeat(np.arange(heights[i]), np.diff(indptr)) + row_offsets[i])
            cols.append(indices + col_offsets[j])
            values.append(v)
    r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(values)
    order = np.lexsort((c, r))
    r, c, v = r[order], c[order], v[order]
    if any(isinstance(B, Matrix) for row in blocks for B in row):
        indptr = np.searchsorted(r, np.arange(row_offsets[-1] + 1)).astype(np.int32)
        return Matrix(indptr, c.astype(np.int32), v, col_offsets[-1])
    from petsc4py import PETSc

    indptr = np.searchsorted(r, np.arange(row_offsets[-1] + 1)).astype(PETSc.IntType)
    A = PETSc.Mat().createAIJ(size=(row_offsets[-1], col_offsets[-1]),
                              csr=(indptr, c.astype(PETSc.IntType), v), comm=PETSc.COMM_SELF)
    A.assemble()
    return A


def block_diagonal(blocks: list[PETSc.Mat]) -> PETSc.Mat | Matrix:
    """diag(B_1, …, B_m) of sequential AIJ matrices."""
    return block_matrix([[B if i == j else None for j, B in enumerate(blocks)]
                         for i in range(len(blocks))])
