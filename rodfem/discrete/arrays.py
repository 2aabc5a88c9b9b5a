"""Sequential vectors and matrices in NumPy, for a run whose steps PETSc never takes.

A serial run whose time loop is compiled (:mod:`rodfem.solver.compiled`) uses its operators and
its state as containers: the loop reads their arrays once and steps in C. What Python still does
with them (the paper scheme's first step, the energy of the first rows, the right-hand sides of
the response to a unit force) is a few products and sums. :class:`Vector` and :class:`Matrix`
hold the same arrays as the sequential PETSc objects would (the CSR rows as assembled, the
vectors' values) and offer the part of petsc4py's ``Vec`` and ``Mat`` that rodfem calls, so that
such a run needs neither petsc4py nor PETSc's start (70 ms of a small run's 0.35 s).

**The same arithmetic as PETSc's, bit for bit.** Each operation is PETSc's (3.18 to 3.25), in
PETSc's order:

* ``multAdd`` (z = y + A x): per row, from y's entry, the products added in the CSR's column
  order (MatMultAdd_SeqAIJ); ``mult`` the same from 0.
* ``axpy``, ``aypx``, ``waxpy``, ``scale``: one product and one sum per entry, as PETSc's loops
  and the BLAS take them for the weights ±1 the runs use (a product by ±1 is exact, so a fused
  multiply-add gives the same).
* ``dot``: the BLAS ``ddot`` PETSc calls, through NumPy's ``dot``, which calls the same
  library's (both link ``libblas.so.3``).
* the LU of a matrix in its natural ordering (:class:`NaturalLU`): PETSc's MatLUFactorNumeric
  and MatSolve for SeqAIJ, with the inverted pivots they store.

``tests/test_arrays.py`` checks each against petsc4py on the operators of the built-in scenes.
"""

from __future__ import annotations

import numpy as np


class Vector:
    """A sequential vector over ``array`` (shared, not copied)."""

    def __init__(self, array: np.ndarray):
        self.array = array

    @classmethod
    def zeros(cls, n: int) -> Vector:
        return cls(np.zeros(n))

    @property
    def array_r(self) -> np.ndarray:
        return self.array

    def getSize(self) -> int:  # noqa: N802 (petsc4py's names)
        return self.array.size

    def getValue(self, i: int) -> float:  # noqa: N802
        return float(self.array[i])

    def duplicate(self) -> Vector:
        return Vector(np.zeros_like(self.array))

    def copy(self, target: Vector | None = None) -> Vector:
        if target is None:
            return Vector(self.array.copy())
        target.array[:] = self.array
        return target

    def zeroEntries(self) -> None:  # noqa: N802
        self.array[:] = 0.0

    def set(self, value: float) -> None:
        self.array[:] = value

    def scale(self, alpha: float) -> None:
        if alpha == 0.0:
            self.array[:] = 0.0
        elif alpha != 1.0:
            self.array *= alpha

    def axpy(self, alpha: float, x: Vector) -> None:
        """self ← self + α x."""
        if alpha != 0.0:
            self.array += alpha * x.array

    def aypx(self, alpha: float, x: Vector) -> None:
        """self ← x + α self."""
        if alpha == -1.0:
            np.subtract(x.array, self.array, out=self.array)
        elif alpha == 0.0:
            self.array[:] = x.array
        else:
            self.array[:] = x.array + alpha * self.array

    def waxpy(self, alpha: float, x: Vector, y: Vector) -> None:
        """self ← α x + y."""
        if alpha == 1.0:
            np.add(y.array, x.array, out=self.array)
        elif alpha == -1.0:
            np.subtract(y.array, x.array, out=self.array)
        else:
            self.array[:] = alpha * x.array + y.array

    def dot(self, other: Vector) -> float:
        return float(np.dot(other.array, self.array))

    def norm(self, kind=None) -> float:
        """The max-norm (the only one rodfem asks for)."""
        return float(np.max(np.abs(self.array))) if self.array.size else 0.0

    def stateIncrease(self) -> None:  # noqa: N802 (no norms are cached here)
        pass

    def destroy(self) -> None:
        pass


class Matrix:
    """A sequential sparse matrix in CSR form: ``indptr``, ``indices``, ``values`` as assembled
    (explicit zeros kept: PETSc keeps them, and they take part in its LU's pattern)."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, values: np.ndarray,
                 columns: int | None = None):
        self.indptr = np.asarray(indptr)
        self.indices = np.asarray(indices)
        self.values = np.asarray(values, dtype=float)
        self.shape = (self.indptr.size - 1,
                      self.indptr.size - 1 if columns is None else int(columns))
        self._rows = None

    def getSize(self) -> tuple[int, int]:  # noqa: N802
        return self.shape

    def getValuesCSR(self):  # noqa: N802
        return self.indptr, self.indices, self.values

    def getValue(self, i: int, j: int) -> float:  # noqa: N802
        start, end = self.indptr[i], self.indptr[i + 1]
        found = np.flatnonzero(self.indices[start:end] == j)
        return float(self.values[start + found[0]]) if found.size else 0.0

    def getRow(self, i: int):  # noqa: N802
        start, end = self.indptr[i], self.indptr[i + 1]
        return self.indices[start:end].copy(), self.values[start:end].copy()

    def copy(self) -> Matrix:
        return Matrix(self.indptr, self.indices, self.values.copy(), self.shape[1])

    def duplicate(self, copy: bool = False) -> Matrix:
        """The same pattern, with the values too where ``copy`` (else zero)."""
        made = self.copy()
        if not copy:
            made.zeroEntries()
        return made

    def zeroEntries(self) -> None:  # noqa: N802
        self.values[:] = 0.0

    def scale(self, alpha: float) -> None:
        self.values *= alpha

    def createVecRight(self) -> Vector:  # noqa: N802
        return Vector.zeros(self.shape[1])

    def createVecLeft(self) -> Vector:  # noqa: N802
        return Vector.zeros(self.shape[0])

    def destroy(self) -> None:
        pass

    def _by_place(self):
        """For each place k in a row (the k-th entry), the rows that have one and the entries'
        positions: the products are added in the CSR's column order, a place at a time."""
        if self._rows is None:
            counts = np.diff(self.indptr)
            self._rows = [(rows, self.indptr[rows] + k) for k in range(int(counts.max(initial=0)))
                          for rows in [np.flatnonzero(counts > k)]]
        return self._rows

    def multAdd(self, x: Vector, y: Vector, z: Vector) -> None:  # noqa: N802
        """z ← y + A x, each row summed from y's entry in column order (MatMultAdd_SeqAIJ)."""
        total = y.array.copy()
        xs = x.array
        for rows, at in self._by_place():
            total[rows] += self.values[at] * xs[self.indices[at]]
        z.array[:] = total

    def mult(self, x: Vector, y: Vector) -> None:
        """y ← A x (MatMult_SeqAIJ: each row summed from 0 in column order)."""
        self.multAdd(x, Vector(np.zeros(self.shape[0])), y)

    def petsc(self):
        """The same matrix as a sequential PETSc AIJ matrix (imports petsc4py)."""
        from petsc4py import PETSc

        A = PETSc.Mat().createAIJ(size=self.shape, comm=PETSc.COMM_SELF, csr=(
            self.indptr.astype(PETSc.IntType), self.indices.astype(PETSc.IntType), self.values))
        A.assemble()
        return A


def stacked(parts: int, n: int) -> tuple[Vector, list[Vector]]:
    """A vector of ``parts`` blocks of length n, and a vector for each block sharing its
    memory."""
    array = np.zeros(parts * n)
    return Vector(array), [Vector(array[i * n:(i + 1) * n]) for i in range(parts)]


def petsc_vector(vector: Vector):
    """A sequential PETSc vector over the same memory (imports petsc4py)."""
    from petsc4py import PETSc

    return PETSc.Vec().createWithArray(vector.array, comm=PETSc.COMM_SELF)


class NaturalLU:
    """PETSc's LU of a sequential AIJ matrix in its natural ordering (MatLUFactorNumeric_SeqAIJ,
    no pivoting, no shift) and its solve (MatSolve_SeqAIJ_NaturalOrdering), for a pattern
    without fill (the operators in node order are tridiagonal; ValueError otherwise).

    Row i of the factor is eliminated as PETSc does: its entries loaded into a work row, then for
    each k < i in L's pattern whose entry is not zero, l = a_ik · (1/u_kk) and a_ij −= l u_kj
    for the j of U's row k; PETSc stores 1/u_ii. The solve is
    x_i = b_i − Σ_{k<i} l_ik x_k (column order) forward, then
    x_i = (x_i − Σ_{j>i} u_ij x_j) · (1/u_ii) backward."""

    def __init__(self, A: Matrix):
        n = A.shape[0]
        indptr, indices, values = A.indptr, A.indices, A.values
        lower, upper, inverse = [], [], np.empty(n)
        for i in range(n):
            cols = indices[indptr[i]:indptr[i + 1]]
            row = dict(zip(cols.tolist(), values[indptr[i]:indptr[i + 1]].tolist()))
            if i not in row:
                raise ValueError("the matrix has no diagonal entry in a row")
            below = sorted(c for c in row if c < i)
            for k in below:
                if row[k] != 0.0:
                    multiplier = row[k] * inverse[k]
                    row[k] = multiplier
                    for j, u in upper[k]:
                        if j not in row:
                            raise ValueError("the LU of this pattern has fill")
                        row[j] -= multiplier * u
            lower.append([(k, row[k]) for k in below])
            upper.append([(j, row[j]) for j in sorted(c for c in row if c > i)])
            if row[i] == 0.0:
                raise ZeroDivisionError(f"zero pivot in row {i}")
            inverse[i] = 1.0 / row[i]
        self._lower, self._upper, self._inverse = lower, upper, inverse

    def solve(self, b: Vector, x: Vector) -> None:
        values = b.array.tolist()
        for i, row in enumerate(self._lower):
            total = values[i]
            for k, l in row:
                total -= l * values[k]
            values[i] = total
        inverse = self._inverse.tolist()
        for i in range(len(values) - 1, -1, -1):
            total = values[i]
            for j, u in self._upper[i]:
                total -= u * values[j]
            values[i] = total * inverse[i]
        x.array[:] = values
