"""Point values of P1 functions in parallel.

A point x0 lies in one cell; the rank that owns that cell (the lowest such rank, if x0 is a vertex
shared by two) computes the cell's interpolation weights once, and each rank keeps the weights of
the nodes it owns. A value is then the sum over ranks of Σ w_j u_j over owned nodes: on one rank
it is a couple of reads, and the sums over ranks can be taken for many values at once.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


class PointProbe:
    """u(x0) for u in the P1 space V, through the PETSc vectors that hold u's owned values."""

    def __init__(self, V, x0: float):
        self.x0 = float(x0)
        comm = V.mesh.comm
        index_map = V.dofmap.index_map
        coordinates = V.tabulate_dof_coordinates()[:, 0]
        num_cells = V.mesh.topology.index_map(V.mesh.topology.dim).size_local
        dofs = np.array([V.dofmap.cell_dofs(c) for c in range(num_cells)]).reshape(-1, 2)
        xs = coordinates[dofs]
        lo, hi = xs.min(axis=1), xs.max(axis=1)
        hits = np.flatnonzero((lo <= self.x0) & (self.x0 <= hi))
        owner = comm.allreduce(comm.rank if hits.size else comm.size, op=MPI.MIN)
        if owner == comm.size:
            raise ValueError(f"point x = {x0} is outside the mesh")
        payload = None
        if comm.rank == owner:
            cell = hits[0]
            h = hi[cell] - lo[cell]
            weights = 1.0 - np.abs(xs[cell] - self.x0) / h
            payload = (index_map.local_to_global(dofs[cell].astype(np.int32)), weights)
        global_dofs, weights = comm.bcast(payload, root=owner)
        start, end = index_map.local_range
        mine = [(int(g), float(w)) for g, w in zip(global_dofs, weights) if start <= g < end and w]
        self.indices = [g for g, _ in mine]
        self.weights = [w for _, w in mine]
        self.comm = comm

    def local(self, u: PETSc.Vec) -> float:
        """This rank's share of u(x0); the shares of all ranks sum to u(x0)."""
        return sum(w * u.getValue(g) for g, w in zip(self.indices, self.weights))

    def value(self, u: PETSc.Vec) -> float:
        """u(x0) on every rank (collective)."""
        share = self.local(u)
        return self.comm.allreduce(share) if self.comm.size > 1 else share
