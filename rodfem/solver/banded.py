r"""The linearised pencil of :mod:`rodfem.solver.spectrum` as sparse band matrices, for meshes
whose dense eigenproblem is too slow.

Its unknowns are taken node by node, (θ_i, u_i, v_i) for i = 1 … n (the held end keeps only θ_n):
P1's M, M_b, K and G are tridiagonal, and the exchange's terms at x = 1 couple only the last
nodes, so A and B are banded with at most 5 diagonals on each side. :class:`Band` factors
A − z B by LAPACK's banded LU with partial pivoting (real arithmetic for a real z) in O(N)
memory and time: the solves of shift-and-invert (:mod:`rodfem.solver.rightmost`) and the
determinant's phase of the stability count.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp


@dataclasses.dataclass(frozen=True)
class SparseOperators:
    """M, M_b, K and G on S_E (the node x = 0 left out), sparse (CSR), in node order."""

    M: sp.csr_matrix
    Mb: sp.csr_matrix
    K: sp.csr_matrix
    G: sp.csr_matrix

    @property
    def size(self) -> int:
        return self.K.shape[0]


def _sparse(A) -> sp.csr_matrix:
    """A sequential PETSc matrix as CSR, the row and column of x = 0 left out (never dense)."""
    indptr, indices, values = A.getValuesCSR()
    size = indptr.size - 1
    A.destroy()
    return sp.csr_matrix((values, indices, indptr), shape=(size, size))[1:, 1:].tocsr()


def operators(disc) -> SparseOperators:
    """M, M_b, K and G of a :class:`~rodfem.discrete.discretisation.Discretisation`, from the
    forms, sparse (collective: every rank gets them whole)."""
    import ufl

    import forms.copetti as copetti

    u, w = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
    dx_b = disc.dx_m if disc.dx_b is None else disc.dx_b
    return SparseOperators(
        M=_sparse(disc.matrix(lambda: copetti.mass(u, w, disc.dx_m))),
        Mb=_sparse(disc.matrix(lambda: copetti.inertia(u, w, dx_b))),
        K=_sparse(disc.matrix(lambda: copetti.stiffness(u, w, disc.dx))),
        G=_sparse(disc.matrix(lambda: copetti.coupling(u, w, disc.dx))),
    )


def order(n: int, held: bool) -> np.ndarray:
    """The block order's index (Θ, U, V) of each unknown in node order, the held end's U(1) and
    V(1) left out: the node order's position i holds block index ``order[i]``."""
    nodes = np.arange(n)
    index = np.stack([nodes, n + nodes, 2 * n + nodes], axis=1).ravel()
    if held:
        index = index[~np.isin(index, [2 * n - 1, 3 * n - 1])]
    return index


def pencil(ops: SparseOperators, a: float, b: float, zeta: float, lin,
           exchange: bool = True) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """(A, B) of :func:`rodfem.solver.spectrum.pencil`, sparse, in node order (:func:`order`).
    Without ``exchange`` the exchange's own change with the end's place and force (c_u, c_p) is
    left out: the dissipative pencil A₀ − λ B₀ of the count
    (:mod:`rodfem.solver.right_half_plane`)."""
    K, G, n = ops.K, ops.G, ops.size
    c_u = lin.exchange_u if exchange else 0.0
    c_p = lin.exchange_p if exchange else 0.0
    E = sp.csr_matrix(([1.0], ([n - 1], [n - 1])), shape=(n, n))
    One = sp.identity(n, format="csr")
    A = sp.bmat([[-K - lin.h * E, -c_u * E, -a * G],
                 [None, None, One],
                 [a * G.T, -K - lin.kappa * E, -zeta * K]], format="lil")
    B = sp.bmat([[ops.M, None, None], [None, One, None], [None, None, b * ops.Mb]], format="lil")
    if lin.held:
        # the heat row of x = 1 gains −c_p p̃, p̃ = −(b M_b V̇ + K U + ζ K V − a Gᵀ Θ)(1)
        end = n - 1
        row = sp.hstack([-c_p * a * G[:, end].T, c_p * K[end], c_p * zeta * K[end]]).tolil()
        A[end, :] = A[end, :] + row
        B[end, 2 * n:] = B[end, 2 * n:] - c_p * b * ops.Mb[end]
    index = order(n, lin.held)
    A, B = A.tocsr(), B.tocsr()
    return A[index][:, index].tocsr(), B[index][:, index].tocsr()


def balanced(A: sp.csr_matrix, B: sp.csr_matrix, sweeps: int = 8):
    """(D_l A D_r, D_l B D_r, D_l, D_r) by powers of 2, as :func:`rodfem.solver.spectrum.balanced`
    on the dense pencil: the same eigenvalues, a stiff contact's entries brought near the rest."""
    M = (abs(A) + abs(B)).tocsr()
    rows, cols = np.zeros(M.shape[0]), np.zeros(M.shape[1])
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        for _ in range(sweeps):
            sums = (M @ np.exp2(cols)) * np.exp2(rows)
            rows -= np.where(sums > 0.0, np.log2(sums), 0.0)
            sums = (M.T @ np.exp2(rows)) * np.exp2(cols)
            cols -= np.where(sums > 0.0, np.log2(sums), 0.0)
    left = sp.diags(np.exp2(np.round(np.nan_to_num(rows))))
    right = sp.diags(np.exp2(np.round(np.nan_to_num(cols))))
    return (left @ A @ right).tocsr(), (left @ B @ right).tocsr(), left, right


def bandwidths(*mats: sp.spmatrix) -> tuple[int, int]:
    """(kl, ku): the sub- and super-diagonals that the matrices' entries reach."""
    kl = ku = 0
    for S in mats:
        C = S.tocoo()
        if C.nnz:
            kl, ku = max(kl, int(np.max(C.row - C.col))), max(ku, int(np.max(C.col - C.row)))
    return kl, ku


def _storage(S: sp.spmatrix, kl: int, ku: int) -> np.ndarray:
    """S in LAPACK's banded LU storage (kl extra rows for the fill-in of pivoting)."""
    C = S.tocoo()
    ab = np.zeros((2 * kl + ku + 1, S.shape[1]), dtype=np.result_type(C.data, float),
                  order="F")
    np.add.at(ab, (kl + ku + C.row - C.col, C.col), C.data)
    return ab


class Band:
    """A − z B for any complex z, factored by LAPACK's banded LU in O(N kl (kl + ku)): in real
    arithmetic (dgbtrf) where z and the pencil are real, four times cheaper than complex."""

    def __init__(self, A: sp.spmatrix, B: sp.spmatrix):
        self.kl, self.ku = bandwidths(A, B)
        self.size = A.shape[0]
        self._A, self._B = _storage(A, self.kl, self.ku), _storage(B, self.kl, self.ku)
        self.real = not (np.iscomplexobj(A.data) or np.iscomplexobj(B.data))

    def factor(self, z: complex) -> Factor:
        from scipy.linalg import lapack

        z = complex(z)
        if self.real and z.imag == 0.0:
            lu, pivots, info = lapack.dgbtrf(self._A.real - z.real * self._B.real, self.kl,
                                             self.ku, overwrite_ab=True)
        else:
            lu, pivots, info = lapack.zgbtrf(self._A - z * self._B, self.kl, self.ku,
                                             overwrite_ab=True)
        return Factor(lu, pivots, info, self.kl, self.ku)


@dataclasses.dataclass
class Factor:
    """The banded LU of A − z B (real where z is); ``singular`` where a pivot is exactly 0."""

    lu: np.ndarray
    pivots: np.ndarray
    info: int
    kl: int
    ku: int

    @property
    def singular(self) -> bool:
        return self.info != 0

    def solve(self, rhs: np.ndarray, adjoint: bool = False) -> np.ndarray:
        """(A − z B)⁻¹ rhs, or (A − z B)⁻ᴴ rhs with ``adjoint``; real where the factor and
        ``rhs`` are (a real factor solves a complex ``rhs`` as its two real columns)."""
        from scipy.linalg import lapack

        rhs = np.asarray(rhs)
        if np.isrealobj(self.lu):
            if np.iscomplexobj(rhs):
                parts = self.solve(np.stack([rhs.real, rhs.imag], axis=-1), adjoint)
                return parts[..., 0] + 1j * parts[..., 1]
            x, info = lapack.dgbtrs(self.lu, self.kl, self.ku, np.asarray(rhs, dtype=float),
                                    self.pivots, trans=1 if adjoint else 0)
        else:
            x, info = lapack.zgbtrs(self.lu, self.kl, self.ku, np.asarray(rhs, dtype=complex),
                                    self.pivots, trans=2 if adjoint else 0)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded solve failed (info {info})")
        return x

    def phase(self) -> float:
        """arg det(A − z B) in (−π, π]: the pivots' phases and a swap's π each."""
        diagonal = self.lu[self.kl + self.ku]
        swaps = np.count_nonzero(self.pivots != np.arange(1, self.pivots.size + 1))
        return float(np.angle(np.exp(1j * (np.sum(np.angle(diagonal)) + np.pi * swaps))))
