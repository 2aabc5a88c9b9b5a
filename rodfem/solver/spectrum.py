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
infinite and left out. The largest real part of the rest is the state's growth rate.
"""

from __future__ import annotations

import dataclasses

import numpy as np

# |β| ≤ this × eps × ‖B‖: an infinite eigenvalue α/β of the pencil (QZ leaves β at round-off)
INFINITE = 1e3


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


def eigenvalues(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The finite eigenvalues of A x = λ B x, largest real part first."""
    import scipy.linalg

    alpha, beta = scipy.linalg.eigvals(A, B, homogeneous_eigvals=True)
    finite = np.abs(beta) > INFINITE * np.finfo(float).eps * np.linalg.norm(B, np.inf)
    found = alpha[finite] / beta[finite]
    return found[np.argsort(-found.real, kind="stable")]


class Spectra:
    """The spectra of a scene's steady states, its operators assembled once per mesh, mass and
    time step (what they depend on): a continuation over a model value reuses them."""

    def __init__(self, comm=None):
        from mpi4py import MPI

        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self._operators: dict[tuple, Operators] = {}

    def operators(self, scene) -> Operators:
        from rodfem.discrete.discretisation import Discretisation

        key = (*Discretisation.key(scene), scene["time.dt"])
        if key not in self._operators:
            self._operators[key] = operators(Discretisation(scene, self.comm))
        return self._operators[key]

    def eigenvalues(self, scene, lin) -> np.ndarray:
        """The finite eigenvalues about the state linearised as ``lin``, largest real first."""
        A, B = pencil(self.operators(scene), scene["model.a"], scene["model.b"],
                      scene["model.zeta"], lin)
        return eigenvalues(A, B)

    def growth_rate(self, scene, lin) -> float:
        """The largest real part of the spectrum: the state is stable where it is < 0 (NaN if
        every eigenvalue is infinite, which no scene with a heat equation gives)."""
        found = self.eigenvalues(scene, lin)
        return float(found[0].real) if found.size else float("nan")
