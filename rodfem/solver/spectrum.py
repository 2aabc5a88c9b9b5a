r"""The stability of a steady state: the spectrum of the dynamic problem linearised about it,
discretised in space like the scene.

About a steady state (:mod:`rodfem.model.steady`) small perturbations θ̃, ũ, ṽ = ũ_t obey

    (θ̃_t, w) + (θ̃_x, w_x) + a (ṽ_x, w) + h θ̃(1) w(1) + c_u ũ(1) w(1) = 0,
    b (ṽ_t, v)_b + (ũ_x + ζ ṽ_x − a θ̃, v_x) + κ ũ(1) v(1) = 0,        ũ_t = ṽ,

with h the exchange coefficient at the state, κ = dp/du(1) the contact's slope and
c_u = (θ(1) − θ_O)(∂q/∂u(1) + ∂q/∂p κ) the exchange's own change with the end's place
(:class:`~rodfem.model.steady.Linearisation`). In P1 on S_E, with the scene's masses M and M_b,
K, G_ij = (η_j', η_i) and e the unit vector of x = 1, that is the pencil A X = λ B X in
X = (Θ, U, V):

    A = [[−K − h e eᵀ, −c_u e eᵀ, −a G], [0, 0, I], [a Gᵀ, −K − κ e eᵀ, −ζ K]],
    B = diag(M, I, b M_b).

Against the rigid obstacle in contact U(1) = V(1) = 0 are held and the contact force
p̃ = −(b M_b V̇ + K U + ζ K V − a Gᵀ Θ)(1), the row of x = 1, is the constraint's reaction; it
enters the heat row through c_p = (θ(1) − θ_O) ∂q/∂p, and its V̇ term through B.

A massless end (the mass redistributed) or b = 0 makes B singular: those eigenvalues are
infinite and left out. The largest real part of the rest is the state's growth rate, and
:func:`judged` says whether round-off leaves its sign, hence the state's stability, earned:
stable, unstable, neutral (on the imaginary axis to round-off) or unresolved.

This module solves the pencil dense (QZ: every eigenvalue, O(N³)); above :data:`DENSE_CELLS`
cells :class:`Spectra` takes the sparse path of :mod:`rodfem.solver.rightmost` (the rightmost
few by shift-and-invert, in O(N)), whose verdicts this one checks where both apply.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rodfem.solver.determinant import positive_real

# |β| ≤ this × eps × ‖B‖: an infinite eigenvalue α/β of the pencil (QZ leaves β at round-off)
INFINITE = 1e3
# An eigenvalue not resolved from the imaginary axis, its error below this × the largest |λ|
# (√eps): a neutral one, on the axis to round-off (an undamped bar's).
NEUTRAL = float(np.sqrt(np.finfo(float).eps))
# Above this many cells :class:`Spectra` judges a state on the sparse path (QZ with both
# eigenvectors takes about 1 s a state at 400 cells and grows as cells³).
DENSE_CELLS = 400


@dataclasses.dataclass(frozen=True)
class Operators:
    """The scene's matrices on S_E (the node x = 0 left out), dense, in node order: the heat's
    mass M, the inertia's M_b, the stiffness K and the coupling G."""

    M: np.ndarray
    Mb: np.ndarray
    K: np.ndarray
    G: np.ndarray


def _dense(A) -> np.ndarray:
    """A sequential PETSc matrix as a dense array, the row and column of x = 0 left out."""
    import scipy.sparse

    indptr, indices, values = A.getValuesCSR()
    size = indptr.size - 1
    A.destroy()
    return scipy.sparse.csr_matrix((values, indices, indptr), shape=(size, size)).toarray()[
        1:, 1:]


def operators(disc) -> Operators:
    """M, M_b, K and G of a :class:`~rodfem.discrete.discretisation.Discretisation`, from the
    forms (collective: every rank gets them whole)."""
    import ufl

    import forms.copetti as copetti

    u, w = ufl.TrialFunction(disc.V), ufl.TestFunction(disc.V)
    dx_b = disc.dx_m if disc.dx_b is None else disc.dx_b
    return Operators(
        M=_dense(disc.matrix(lambda: copetti.mass(u, w, disc.dx_m))),
        Mb=_dense(disc.matrix(lambda: copetti.inertia(u, w, dx_b))),
        K=_dense(disc.matrix(lambda: copetti.stiffness(u, w, disc.dx))),
        G=_dense(disc.matrix(lambda: copetti.coupling(u, w, disc.dx))),
    )


def pencil(ops: Operators, a: float, b: float, zeta: float, lin) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the linearised problem about a state whose
    :class:`~rodfem.model.steady.Linearisation` is ``lin``."""
    K, G = ops.K, ops.G
    n = K.shape[0]
    One, Z = np.eye(n), np.zeros((n, n))
    E = np.zeros((n, n))
    E[-1, -1] = 1.0
    A = np.block([[-K - lin.h * E, -lin.exchange_u * E, -a * G],
                  [Z, Z, One],
                  [a * G.T, -K - lin.kappa * E, -zeta * K]])
    B = np.block([[ops.M, Z, Z], [Z, One, Z], [Z, Z, b * ops.Mb]])
    if not lin.held:
        return A, B
    # The heat row of x = 1 gains −c_p p̃, p̃ = −(b M_b V̇ + K U + ζ K V − a Gᵀ Θ)(1).
    end, c_p = n - 1, lin.exchange_p
    A[end, :n] -= c_p * a * G[:, end]
    A[end, n:2 * n] += c_p * K[end]
    A[end, 2 * n:] += c_p * zeta * K[end]
    B[end, 2 * n:] -= c_p * b * ops.Mb[end]
    keep = np.setdiff1d(np.arange(3 * n), [n + end, 2 * n + end])
    return A[np.ix_(keep, keep)], B[np.ix_(keep, keep)]


def balanced(A: np.ndarray, B: np.ndarray, sweeps: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """(D_l A D_r, D_l B D_r): the pencil with its rows and columns scaled by powers of 2 (exact)
    so that those of |A| + |B| have sums near 1 (Sinkhorn's sweeps), the same eigenvalues. A
    stiff contact (κ = 1/ε up to 1e12) makes entries of A twelve orders larger than the rest and
    the eigenvector's ũ(1) = p̃/κ as much smaller: QZ's normwise round-off then swamps that
    component, and the unstable state's eigenvalue is lost, unless the pencil is balanced."""
    M = np.abs(A) + np.abs(B)
    rows, cols = np.zeros(M.shape[0]), np.zeros(M.shape[1])
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        for _ in range(sweeps):
            sums = (M * np.exp2(cols)).sum(axis=1) * np.exp2(rows)
            rows -= np.where(sums > 0.0, np.log2(sums), 0.0)
            sums = (M.T * np.exp2(rows)).sum(axis=1) * np.exp2(cols)
            cols -= np.where(sums > 0.0, np.log2(sums), 0.0)
        left = np.exp2(np.round(np.nan_to_num(rows)))[:, None]
        right = np.exp2(np.round(np.nan_to_num(cols)))[None, :]
        return left * A * right, left * B * right


def _finite(alpha: np.ndarray, beta: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Which of the eigenvalues α/β are finite: |β| above round-off of ‖B‖."""
    return np.abs(beta) > INFINITE * np.finfo(float).eps * np.linalg.norm(B, np.inf)


def eigenvalues(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The finite eigenvalues of A x = λ B x, largest real part first."""
    import scipy.linalg

    alpha, beta = scipy.linalg.eigvals(A, B, homogeneous_eigvals=True)
    finite = _finite(alpha, beta, B)
    found = alpha[finite] / beta[finite]
    return found[np.argsort(-found.real, kind="stable")]


def rightmost(A: np.ndarray, B: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` finite eigenvalues of largest real part by QZ (of the balanced pencil),
    largest real part first (of a pair, the member above the axis first), and each one's
    first-order error bound eps (‖A‖ + |λ| ‖B‖) ‖x‖ ‖y‖/|yᴴ B x| (:func:`verdict`)."""
    import scipy.linalg

    A, B = balanced(A, B)
    (alpha, beta), left, right = scipy.linalg.eig(A, B, left=True, right=True,
                                                  homogeneous_eigvals=True)
    finite = _finite(alpha, beta, B)
    found, x, y = alpha[finite] / beta[finite], right[:, finite], left[:, finite]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        angle = np.abs(np.einsum("ij,ij->j", y.conj(), B @ x))
        cond = np.linalg.norm(x, axis=0) * np.linalg.norm(y, axis=0) / angle
        error = np.finfo(float).eps * (np.linalg.norm(A, "fro") + np.abs(found)
                                       * np.linalg.norm(B, "fro")) * cond
    order = np.lexsort((-found.imag, -found.real))[:count]
    return found[order], np.where(np.isfinite(error[order]), error[order], np.inf)


@dataclasses.dataclass(frozen=True)
class Verdict:
    """A state's stability as the spectrum earns it: ``stable``, ``unstable``, ``neutral`` (the
    rightmost eigenvalues lie on the imaginary axis to round-off) or ``unresolved`` (round-off
    of the eigenvalues, by their condition numbers, could put them on either side of it);
    ``growth_rate`` the largest real part found, ``error`` its error bound."""

    verdict: str
    growth_rate: float
    error: float


def verdict(A: np.ndarray, B: np.ndarray, regular: bool) -> Verdict:
    """The verdict of one QZ solve of A x = λ B x with left and right eigenvectors. Each
    eigenvalue's error is bounded, to first order, by eps (‖A‖ + |λ| ‖B‖) ‖x‖ ‖y‖/|yᴴ B x|
    (QZ is backward stable in norm): a real part beyond its bound has its sign. Unstable:
    one eigenvalue resolved right of the axis. Stable: every one resolved left of it and none
    lost (a finite eigenvalue QZ leaves with β at round-off, counted by B's rank). Neutral:
    those not resolved lie on the axis within √eps of the largest |λ| among them, their errors
    at round-off there. Unresolved otherwise, or where QZ fails or the pencil is not finite.
    ``regular``: whether B is (its rank, of the pencil before any balancing)."""
    import scipy.linalg

    nan = float("nan")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        return Verdict("unresolved", nan, nan)
    try:
        (alpha, beta), left, right = scipy.linalg.eig(A, B, left=True, right=True,
                                                      homogeneous_eigvals=True)
    except (np.linalg.LinAlgError, ValueError):
        return Verdict("unresolved", nan, nan)
    finite = _finite(alpha, beta, B)
    # with B regular every eigenvalue is finite: one QZ leaves with β at round-off is lost (a
    # singular B's infinite eigenvalues may be defective, more than its rank deficiency)
    lost = int(np.count_nonzero(~finite)) if regular else 0
    if not finite.any():
        return Verdict("unresolved", nan, nan)
    found, x, y = alpha[finite] / beta[finite], right[:, finite], left[:, finite]
    eps = np.finfo(float).eps
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        angle = np.abs(np.einsum("ij,ij->j", y.conj(), B @ x))
        cond = np.linalg.norm(x, axis=0) * np.linalg.norm(y, axis=0) / angle
        error = eps * (np.linalg.norm(A, "fro") + np.abs(found) * np.linalg.norm(B, "fro")) * cond
    error = np.where(np.isfinite(error), error, np.inf)
    top = int(np.argmax(found.real))
    rate, bound = float(found[top].real), float(error[top])
    if not np.isfinite(rate):
        return Verdict("unresolved", rate, bound)
    if np.any(found.real > error):
        return Verdict("unstable", rate, bound)
    open_ = found.real >= -error
    if lost > 0:
        return Verdict("unresolved", rate, bound)
    if not open_.any():
        return Verdict("stable", rate, bound)
    scale = float(np.max(np.abs(found[open_])))
    if np.all(error[open_] <= NEUTRAL * scale):
        return Verdict("neutral", rate, bound)
    return Verdict("unresolved", rate, bound)


def regular(ops: Operators, b: float, held: bool) -> bool:
    """Whether B is regular: b > 0 and the masses M and M_b (without x = 1 where the end is
    held) positive definite. B is then block triangular with these and I on its diagonal (the
    reaction's row adds only above it), so det(−B) has the sign (−1)^N, N its order, however
    large the reaction's entries make its condition number."""
    Mb = ops.Mb[:-1, :-1] if held else ops.Mb
    try:
        np.linalg.cholesky(ops.M)
        np.linalg.cholesky(Mb)
    except np.linalg.LinAlgError:
        return False
    return b > 0.0


def judged(A: np.ndarray, B: np.ndarray, regular: bool) -> Verdict:
    """The verdict of two QZ solves, the pencil balanced (:func:`balanced`) and as it is, and of
    the signs of two determinants (``regular``: whether B is, :func:`regular`). The pencil as it is
    is solved only where the balanced one is unresolved: where only one resolves the spectrum, that
    one; where their resolved verdicts differ, unresolved. An odd number of positive real
    eigenvalues (:func:`~rodfem.solver.determinant.positive_real`) makes the state unstable
    whatever QZ found: its growth rate is then at least that eigenvalue."""
    Ab, Bb = balanced(A, B)
    first = verdict(Ab, Bb, regular)
    # the second solve only where the first is unresolved (it costs as much again)
    second = first if first.verdict != "unresolved" else verdict(A, B, regular)
    if second.verdict in ("unresolved", first.verdict):
        found = first
    elif first.verdict == "unresolved":
        found = second
    else:
        found = Verdict("unresolved", first.growth_rate, first.error)
    if found.verdict == "unstable":
        return found
    real = positive_real(Ab, Bb, (-1.0) ** B.shape[0]) if regular else None
    if real is None:
        return found
    return Verdict("unstable", *real)


class Spectra:
    """The spectra of a scene's steady states, its operators assembled once per mesh, mass and
    time step (what they depend on): a continuation over a model value reuses them. Meshes of
    more than ``dense_cells`` cells are judged on the sparse path (:mod:`rodfem.solver.rightmost`);
    ``dense_cells=None`` keeps every mesh dense, 0 none."""

    def __init__(self, comm=None, dense_cells: int | None = DENSE_CELLS):
        from mpi4py import MPI

        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self.dense_cells = dense_cells
        self._operators: dict[tuple, Operators] = {}
        self._sparse: dict[tuple, object] = {}

    def operators(self, scene) -> Operators:
        from rodfem.discrete.discretisation import Discretisation

        key = (*Discretisation.key(scene), scene["time.dt"])
        if key not in self._operators:
            self._operators[key] = operators(Discretisation(scene, self.comm))
        return self._operators[key]

    def sparse_operators(self, scene):
        """The operators as sparse matrices (:mod:`rodfem.solver.banded`), never dense."""
        from rodfem.discrete.discretisation import Discretisation
        from rodfem.solver import banded

        key = (*Discretisation.key(scene), scene["time.dt"])
        if key not in self._sparse:
            self._sparse[key] = banded.operators(Discretisation(scene, self.comm))
        return self._sparse[key]

    def assemble(self, scene) -> None:
        """The operators of ``scene``'s mesh, dense or sparse as its spectra are taken
        (collective: every rank calls it before any rank's share of a study)."""
        if self.dense(scene):
            self.operators(scene)
        else:
            self.sparse_operators(scene)

    def dense(self, scene) -> bool:
        """Whether ``scene``'s mesh is judged on the dense path."""
        return self.dense_cells is None or scene["mesh.cells"] <= self.dense_cells

    def pencil(self, scene, lin) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) about the state linearised as ``lin`` (infinite or NaN entries where a law's
        slope is infinite there: its verdict is then unresolved)."""
        with np.errstate(invalid="ignore", over="ignore"):
            return pencil(self.operators(scene), scene["model.a"], scene["model.b"],
                          scene["model.zeta"], lin)

    def eigenvalues(self, scene, lin) -> np.ndarray:
        """The finite eigenvalues about the state linearised as ``lin``, largest real first
        (of the balanced pencil; dense at any mesh size)."""
        return eigenvalues(*balanced(*self.pencil(scene, lin)))

    def _sparse_spectrum(self, scene, lin, count: int):
        from rodfem.solver import banded, rightmost
        from rodfem.solver.right_half_plane import dissipative

        ops = self.sparse_operators(scene)
        a, b, zeta = scene["model.a"], scene["model.b"], scene["model.zeta"]
        with np.errstate(invalid="ignore", over="ignore"):
            A, B = banded.pencil(ops, a, b, zeta, lin)
            A0, B0 = banded.pencil(ops, a, b, zeta, lin, exchange=False)
        if not all(np.all(np.isfinite(M.data)) for M in (A, B)):
            return None
        return rightmost.spectrum(A, B, A0, B0, count, dissipative(lin, zeta, b), zeta)

    def rightmost(self, scene, lin, count: int = 6):
        """The ``count`` eigenvalues of largest real part about the state linearised as ``lin``
        and their error bounds, largest real part first: a
        :class:`~rodfem.solver.rightmost.Rightmost` (its ``right``, the count of eigenvalues
        with Re λ ≥ 0, None on the dense path, where every eigenvalue is found). Dense QZ up to
        ``dense_cells`` cells, else the sparse path (what it guarantees:
        :mod:`rodfem.solver.rightmost`)."""
        from rodfem.solver.rightmost import Rightmost

        if self.dense(scene):
            A, B = self.pencil(scene, lin)
            if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
                return Rightmost(np.zeros(0, complex), np.zeros(0), None)
            return Rightmost(*rightmost(A, B, count), None)
        found = self._sparse_spectrum(scene, lin, count)
        return found if found is not None else Rightmost(np.zeros(0, complex), np.zeros(0), None)

    def verdict(self, scene, lin) -> Verdict:
        """The stability of the state linearised as ``lin``, as its spectrum earns it
        (:func:`judged` dense, :func:`rodfem.solver.rightmost.judged` above ``dense_cells``)."""
        if self.dense(scene):
            return judged(*self.pencil(scene, lin),
                          regular(self.operators(scene), scene["model.b"], lin.held))
        from rodfem.solver import rightmost

        found = self._sparse_spectrum(scene, lin, 6)
        if found is None:
            return Verdict("unresolved", float("nan"), float("nan"))
        return Verdict(*rightmost.judged(found))

    def growth_rate(self, scene, lin) -> float:
        """The largest real part of the spectrum: the state is stable where it is < 0 (NaN if
        every eigenvalue is infinite, which no scene with a heat equation gives)."""
        if not self.dense(scene):
            found = self.rightmost(scene, lin, 1).values
            return float(found[0].real) if found.size else float("nan")
        found = self.eigenvalues(scene, lin)
        return float(found[0].real) if found.size else float("nan")
