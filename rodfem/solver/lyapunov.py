r"""The first Lyapunov coefficient of a Hopf point: whether the periodic orbits born there are
stable (supercritical) or not (subcritical).

For M ẋ = f(x) at a steady state x* whose linearisation A = f_x has the simple pair ±iω
(A q = iω M q) and no other eigenvalue on the imaginary axis, the flow on the centre manifold,
in x = x* + z q + z̄ q̄ + O(|z|²), has the normal form ż = (μ + iω) z + c₁ |z|² z + O(|z|⁴), and
the first Lyapunov coefficient l₁ = Re c₁/ω is (Kuznetsov, *Elements of Applied Bifurcation
Theory*, §3.5, eq. (3.20); §10.2 for n dimensions)

    l₁ = (1/(2ω)) Re[ pᴴ C(q, q, q̄) − 2 pᴴ B(q, A⁻¹ B(q, q̄))
                      + pᴴ B(q̄, (2iω M − A)⁻¹ B(q, q)) ],

with pᴴ A = iω pᴴ M, pᴴ M q = 1, and B, C the second and third derivatives of f at x* as
symmetric multilinear forms. M enters only through the eigenvectors and the shift 2iωM: the
formula is the one for ẋ = M⁻¹ f(x) with p̃ᴴ = pᴴ M.

**Normalisation.** l₁ scales with |q|²; here q is scaled so that a chosen component (the
end's displacement u(1) on the rod) is 1/2. Then x ≈ x* + z q e^{iωt} + c.c. moves that
component by |z| cos(ωt + φ), and where μ(λ) = Re λ'(λ_H)(λ − λ_H) + … the orbits born at the
Hopf point have that component's amplitude a with

    a² = −Re λ′ (λ − λ_H) / (ω l₁) + O((λ − λ_H)²).

l₁ < 0: the orbits exist where the state is unstable and are stable (supercritical); l₁ > 0:
they exist where it is stable and are unstable (subcritical).

**Round-off.** :func:`coefficient` gives l₁ with an estimate of its round-off: each term's size
times eps and the condition numbers of the solves with A and 2iωM − A and of the eigenvalue
(the factor by which the eigenvectors' error grows), plus the located point's distance from
the axis, |Re λ|/ω of the terms. |l₁| within it is *degenerate*: the criticality is then
decided only by higher order terms (a system linear about the state has l₁ = 0 exactly).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

EPS = float(np.finfo(float).eps)
ITERATIONS = 3  # of inverse iteration at the eigenvalue itself: each gains eps/|λ|'s distance


@dataclasses.dataclass(frozen=True)
class Lyapunov:
    """l₁ (``value``), its round-off estimate (``error``) and the three terms inside Re[…]."""

    value: float
    error: float
    terms: tuple[complex, complex, complex]

    @property
    def criticality(self) -> str:
        """``supercritical`` (l₁ < 0), ``subcritical`` (l₁ > 0), ``degenerate`` (|l₁| within
        its round-off), or ``""`` where l₁ is not known."""
        if not (math.isfinite(self.value) and math.isfinite(self.error)):
            return ""
        if abs(self.value) <= self.error:
            return "degenerate"
        return "supercritical" if self.value < 0.0 else "subcritical"


UNKNOWN = Lyapunov(math.nan, math.nan, (complex(math.nan),) * 3)


class _Factor:
    """A sparse LU of a (complex) matrix, its solves and its 1-norm condition number."""

    def __init__(self, mat):
        import scipy.sparse.linalg as spla

        self.mat = sp.csc_matrix(mat, dtype=complex)
        self.lu = spla.splu(self.mat)

    def solve(self, rhs: np.ndarray, adjoint: bool = False) -> np.ndarray:
        return self.lu.solve(np.asarray(rhs, dtype=complex), trans="H" if adjoint else "N")

    def condition(self) -> float:
        import scipy.sparse.linalg as spla

        n = self.mat.shape[0]
        inverse = spla.LinearOperator((n, n), matvec=self.solve, dtype=complex,
                                      rmatvec=lambda b: self.solve(b, adjoint=True))
        norm = float(abs(self.mat).sum(axis=0).max())
        return norm * float(spla.onenormest(inverse))


def critical_vectors(A, M, eigenvalue: complex, normal: int):
    """(q, p, condition): the right and left eigenvectors of A x = λ M x at ``eigenvalue`` by
    inverse iteration (A dense or sparse), q with q[normal] = 1/2, pᴴ M q = 1, and the
    eigenvalue's condition number ‖q‖ ‖p‖ ‖M‖₁ (with pᴴ M q = 1)."""
    size = A.shape[0]
    Ms = sp.csc_matrix(M, dtype=complex)
    shift = complex(eigenvalue)
    try:
        factor = _Factor(sp.csc_matrix(A, dtype=complex) - shift * Ms)
    except RuntimeError:  # exactly singular: a shift off by round-off finds the same vectors
        shift += 64.0 * EPS * abs(shift)
        factor = _Factor(sp.csc_matrix(A, dtype=complex) - shift * Ms)
    rng = np.random.default_rng(1)
    q = rng.standard_normal(size) + 1j * rng.standard_normal(size)
    p = rng.standard_normal(size) + 1j * rng.standard_normal(size)
    for _ in range(ITERATIONS):
        q = factor.solve(Ms @ q)
        q /= np.linalg.norm(q)
        p = factor.solve(Ms.conj().T @ p, adjoint=True)
        p /= np.linalg.norm(p)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(p))) or q[normal] == 0.0:
        raise ValueError("the critical eigenvectors could not be found")
    q = q * (0.5 / q[normal])
    p = p / np.conj(np.vdot(p, Ms @ q))
    condition = float(np.linalg.norm(q) * np.linalg.norm(p) * abs(Ms).sum(axis=0).max())
    return q, p, condition


def coefficient(A, M, eigenvalue: complex, B: Callable, C: Callable, normal: int) -> Lyapunov:
    """l₁ of M ẋ = f(x) at a Hopf point (the module's doc): A = f_x and M dense or sparse,
    ``eigenvalue`` the critical one (Im > 0, Re at round-off), B(x, y) and C(x, y, z) f's
    second and third derivatives, ``normal`` the component of q set to 1/2."""
    omega = float(eigenvalue.imag)
    q, p, eig_condition = critical_vectors(A, M, eigenvalue, normal)
    As = sp.csc_matrix(A, dtype=complex)
    Ms = sp.csc_matrix(M, dtype=complex)
    still, doubled = _Factor(As), _Factor(2j * omega * Ms - As)
    qb = q.conj()
    ph = p.conj()
    t1 = complex(ph @ C(q, q, qb))
    t2 = complex(ph @ B(q, still.solve(B(q, qb))))
    t3 = complex(ph @ B(qb, doubled.solve(B(q, q))))
    value = (t1 - 2.0 * t2 + t3).real / (2.0 * omega)
    sizes = (abs(t1) + 2.0 * abs(t2) + abs(t3)) / (2.0 * omega)
    error = EPS * ((abs(t1) + 2.0 * abs(t2) + abs(t3)) * eig_condition
                   + 2.0 * abs(t2) * still.condition() + abs(t3) * doubled.condition()) / (
        2.0 * omega) + abs(eigenvalue.real) / omega * sizes
    return Lyapunov(float(value), float(error), (t1, t2, t3))


def end_forms(expansion, theta: int, u: int, heat: int, force: int, size: int):
    """B(x, y) and C(x, y, z) of the rod's f (:mod:`rodfem.model.expansion`): nonzero only in
    the heat row of x = 1 (index ``heat``) and its momentum row (``force``), functions of the
    end's θ (index ``theta``) and u (``u``) alone."""
    _, h1, h2, h3 = expansion.h
    P2, P3 = expansion.force[2], expansion.force[3]
    J = expansion.jump

    def B(x, y):
        out = np.zeros(size, dtype=complex)
        out[heat] = -h1 * (x[theta] * y[u] + x[u] * y[theta]) - h2 * J * x[u] * y[u]
        out[force] = -P2 * x[u] * y[u]
        return out

    def C(x, y, z):
        out = np.zeros(size, dtype=complex)
        out[heat] = (-h2 * (x[theta] * y[u] * z[u] + x[u] * y[theta] * z[u]
                            + x[u] * y[u] * z[theta]) - h3 * J * x[u] * y[u] * z[u])
        out[force] = -P3 * x[u] * y[u] * z[u]
        return out

    return B, C


def end_indices(n: int, node_order: bool) -> tuple[int, int, int, int]:
    """(θ(1), u(1), heat row, momentum row) of x = 1 in the pencil of n nodes on S_E whose end
    is not held: block order (Θ, U, V) (:func:`rodfem.solver.spectrum.pencil`) or node order
    (:func:`rodfem.solver.banded.order`)."""
    block = (n - 1, 2 * n - 1, n - 1, 3 * n - 1)
    if not node_order:
        return block
    from rodfem.solver.banded import order

    index = order(n, False)
    return tuple(int(np.flatnonzero(index == j)[0]) for j in block)


def of_rod(A, M, eigenvalue: complex, expansion, n: int, node_order: bool) -> Lyapunov:
    """l₁ at a Hopf point of the rod's pencil (A, M) about a state whose end's laws expand as
    ``expansion``, q normalised by u(1) (the module's doc); :data:`UNKNOWN` where the rigid
    obstacle holds the end (its reaction is a multiplier: no expansion)."""
    if expansion.held:
        return UNKNOWN
    theta, u, heat, force = end_indices(n, node_order)
    B, C = end_forms(expansion, theta, u, heat, force, A.shape[0])
    return coefficient(A, M, eigenvalue, B, C, u)
