r"""The rightmost eigenvalues of the linearised pencil A X = λ B X at any mesh size, and the
stability verdict they earn, without a dense eigenproblem (:mod:`rodfem.solver.spectrum` for the
pencil and the dense path).

**Finding them.** SLEPc's Krylov–Schur runs on the shift-and-invert operator (A − σB)⁻¹B, its
solves by the banded LU of :mod:`rodfem.solver.banded` (LAPACK with partial pivoting: PETSc's
own LU does not pivot, and A − σB has zeros on its diagonal); its eigenvalues μ give λ = σ + 1/μ,
those nearest the real target σ first. A first pass at σ = 0 finds the nearest; where its
rightmost is real, a second pass at a target just right of it resolves the eigenvalues that
crowd there. A Kelvin–Voigt rod's eigenvalues accumulate at −1/ζ (its fast modes, overdamped),
and Krylov–Schur would spend its restarts on that cluster's members one by one: its passes
leave out a disk about −1/ζ (SLEPc's region, radius CLUSTER/ζ, its right rim a tenth of that
right of −1/ζ). Where nothing found lies right of the disk, the rightmost is in it (the
cluster's edge, or a member standing apart just right of −1/ζ), found by :func:`edge`: block
inverse iteration at a target, the rightmost few Ritz values refined, the target moved a
hundredth of the way towards −1/ζ round by round, where the next members are far better
separated relative to their distance from it, until a round finds none further right. Only the
rightmost guesses are refined. Each eigenvalue is then refined by
two-sided inverse iteration with the pencil factored at λ, which gives its left eigenvector y
beside the right one x, and its error, to first order,

    |δλ| ≤ (min(‖(A − λB) x‖, ‖(A − λB)ᴴ y‖) + eps (‖A‖_F + |λ| ‖B‖_F)) / |yᴴ B x|,

‖x‖ = ‖y‖ = 1: the smaller residual's backward error and round-off, times the eigenvalue's
condition number.

**What is certain.** Shift-and-invert finds eigenvalues near a target, not the rightmost, so an
eigenvalue with Re λ ≥ 0 far from the target could be missed. It cannot be here: the count of
eigenvalues in the closed right half-plane is taken independently, by the argument principle
(:mod:`rodfem.solver.right_half_plane`). The verdict takes it only where it is consistent: stable
where the count is 0 and every eigenvalue found is resolved left of the axis; unstable where one
found is resolved right of it; where the count and the eigenvalues found disagree, or the count's g
comes near 0 on the axis, or the laws break the conditions of its energy identity (ζ = 0 is allowed
by it, but its waves then lie near the axis), unresolved, never a guess. The growth rate is the
largest real part among those found.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from rodfem.solver.banded import Band
from rodfem.solver.right_half_plane import Exchange

EPS = float(np.finfo(float).eps)
NEAREST = 6  # eigenvalues found beyond the ``count`` asked, per target
TOLERANCE = 1e-6  # SLEPc's relative residual; the refinement brings it to round-off
RESTARTS = 30  # of Krylov–Schur, the Kelvin–Voigt cluster left out: it converges in one or two
CLUSTER = 0.05  # the Kelvin–Voigt cluster's disk about −1/ζ: radius CLUSTER/ζ
BLOCK = 8  # vectors of the block inverse iteration at the cluster's edge
EDGE_ROUNDS = 10  # of targets moved towards −1/ζ at the cluster's edge


@dataclasses.dataclass(frozen=True)
class Rightmost:
    """Eigenvalues, largest real part first, with each one's error bound (``errors``), and
    ``right``: the number of eigenvalues with Re λ ≥ 0 by the argument principle (None where it
    could not be taken)."""

    values: np.ndarray
    errors: np.ndarray
    right: int | None


class _Inverse:
    """(A − σB)⁻¹ B as a PETSc shell matrix (its ``mult``)."""

    def __init__(self, factor, B):
        self.factor, self.B = factor, B

    def mult(self, mat, x, y):
        y.array[:] = self.factor.solve(self.B @ x.array_r).real


def _region(sigma: float, cluster: tuple[float, float]):
    """SLEPc's region of the operator's eigenvalues μ = 1/(λ − σ) that lie outside the disk
    |λ − c| < r, ``cluster`` = (c, r), c real: the disk's image is the disk on the diameter
    1/(c − r − σ), 1/(c + r − σ) (a Möbius map takes circles to circles, the real axis to
    itself), its outside kept where σ lies outside the disk, its inside where σ lies inside."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    c, r = cluster
    ends = 1.0 / (c - r - sigma), 1.0 / (c + r - sigma)
    region = SLEPc.RG().create(comm=PETSc.COMM_SELF)
    region.setType(SLEPc.RG.Type.ELLIPSE)
    region.setEllipseParameters(0.5 * (ends[0] + ends[1]), 0.5 * abs(ends[0] - ends[1]), 1.0)
    region.setComplement(abs(sigma - c) > r)
    return region


def nearest(A: sp.csr_matrix, B: sp.csr_matrix, band: Band, sigma: float,
            nev: int, cluster: tuple[float, float] | None = None) -> np.ndarray:
    """The ``nev`` (or more) eigenvalues of A x = λ B x nearest the real ``sigma``, by SLEPc's
    Krylov–Schur on (A − σB)⁻¹B (sequential: every rank computes the same, from the same start
    vector), those in the disk ``cluster`` = (centre, radius) left out and not waited for.
    Eigenvalues at infinity (μ = 0) are left out."""
    from petsc4py import PETSc
    from slepc4py import SLEPc

    if cluster is not None and abs(abs(sigma - cluster[0]) - cluster[1]) <= 1e-9 * cluster[1]:
        sigma += 1e-6 * cluster[1]  # σ on the disk's rim: its image would be a line
    factor = band.factor(sigma)
    if factor.singular:
        return np.zeros(0, dtype=complex)
    size = A.shape[0]
    nev = min(nev, size - 2)
    op = PETSc.Mat().createPython([size, size], _Inverse(factor, B), comm=PETSc.COMM_SELF)
    op.setUp()
    eps = SLEPc.EPS().create(comm=PETSc.COMM_SELF)
    region = _region(sigma, cluster) if cluster is not None else None
    try:
        eps.setOptionsPrefix("rodfem_spectrum_")
        eps.setOperators(op)
        eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
        eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
        eps.setDimensions(nev, min(size, max(2 * nev + 1, nev + 40)))
        eps.setTolerances(TOLERANCE, RESTARTS)
        if region is not None:
            eps.setRG(region)
        start = op.createVecRight()
        start.array[:] = np.random.default_rng(0).standard_normal(size)
        eps.setInitialSpace([start])
        eps.solve()
        found = [eps.getEigenvalue(i) for i in range(eps.getConverged())]
    finally:
        eps.destroy()
        op.destroy()
        if region is not None:
            region.destroy()
    mu = np.asarray(found, dtype=complex)
    mu = mu[np.abs(mu) > 1e3 * EPS * (np.abs(mu).max() if mu.size else 1.0)]
    return sigma + 1.0 / mu


def crowded(B: sp.csr_matrix, band: Band, centre: float, block: int = BLOCK,
            steps: int = 6) -> np.ndarray:
    """Guesses at the eigenvalues nearest ``centre`` where they crowd (the Kelvin–Voigt
    cluster's edge): ``steps`` of block inverse iteration with (A − cB)⁻¹B on ``block`` vectors
    from the same random start on every rank, and the Ritz values of that operator on the
    subspace they span (Rayleigh–Ritz), λ = c + 1/μ. Krylov–Schur would wait for these to
    converge one by one, and they need not; :func:`refined` takes each to an eigenvalue."""
    import scipy.linalg

    factor = band.factor(centre)
    if factor.singular:
        centre = centre * (1 + 4 * EPS) + 4 * EPS
        factor = band.factor(centre)
        if factor.singular:
            return np.asarray([centre], dtype=complex)
    X = np.random.default_rng(2).standard_normal((B.shape[0], block))
    for _ in range(steps):
        X, _ = scipy.linalg.qr(factor.solve(B @ X), mode="economic")
    mu = scipy.linalg.eigvals(X.T @ factor.solve(B @ X))
    mu = mu[np.abs(mu) > 1e3 * EPS * np.abs(mu).max()]
    return centre + 1.0 / mu


def refined(A, B, band: Band, guess: complex, norms: tuple[float, float],
            steps: int = 3) -> tuple[complex, float]:
    """An eigenvalue near ``guess`` refined by two-sided inverse iteration, and its error bound
    (the module's doc); NaN where the pencil cannot be factored near it."""
    rng = np.random.default_rng(1)
    size = A.shape[0]
    x = rng.standard_normal(size) + 0j
    y = rng.standard_normal(size) + 0j
    lam = complex(guess)
    for _ in range(steps):
        factor = band.factor(lam)
        if factor.singular:  # λ is an eigenvalue to the last bit
            factor = band.factor(lam * (1 + 4 * EPS) + 4 * EPS)
            if factor.singular:
                return lam, float("nan")
        x = factor.solve(B @ x)
        y = factor.solve(B.conj().T @ y, adjoint=True)
        x, y = x / np.linalg.norm(x), y / np.linalg.norm(y)
        angle = np.vdot(y, B @ x)
        if angle == 0:
            return lam, float("inf")
        lam = np.vdot(y, A @ x) / angle
    # λ is an exact eigenvalue of the pencil with A changed by r xᴴ (right) or by y sᴴ (left):
    # the smaller residual bounds its change, to first order, with round-off's
    residual = min(np.linalg.norm(A @ x - lam * (B @ x)),
                   np.linalg.norm(A.conj().T @ y - np.conj(lam) * (B.conj().T @ y)))
    angle = abs(np.vdot(y, B @ x))
    error = (residual + EPS * (norms[0] + abs(lam) * norms[1])) / angle
    return complex(lam), float(error) if np.isfinite(error) else float("inf")


def edge(A, B, band: Band, centre: float, rim: float, norms: tuple[float, float],
         rounds: int = EDGE_ROUNDS) -> tuple[complex, float]:
    """The rightmost eigenvalue found in the disk :func:`rightmost` leaves out, whose right rim
    is ``rim`` right of −1/ζ (``centre``), and its error bound. First those nearest the rim
    (:func:`crowded`): a member between −1/ζ and the rim stands apart from the cluster and is
    the one, or one of a crowd there (a massless rod's, b = 0). Then, round by round, the
    target is moved to a hundredth of the way from the rightmost found so far towards −1/ζ
    (where the Kelvin–Voigt cluster's members crowd from the left) or towards the previous
    target (where the rightmost lies right of −1/ζ), −1/ζ itself after the rim where none lies
    right of it: those found nearest it, the rightmost few refined, are far better separated
    relative to their distance from it, and a round that finds none further right ends the
    search."""
    best: tuple[complex, float] | None = None
    target = centre + rim
    for _ in range(rounds):
        guesses = crowded(B, band, target)
        found = [refined(A, B, band, g, norms, steps=6)
                 for g in guesses[np.argsort(-guesses.real)][:3]]
        found = [p for p in found if np.isfinite(p[0]) and np.isfinite(p[1])]
        if not found:
            break
        top = max(found, key=lambda p: p[0].real)
        if best is not None and top[0].real <= best[0].real + best[1]:
            break
        best = top
        if best[0].real < centre < target:
            target = centre  # none right of −1/ζ: the cluster's edge, from −1/ζ
        else:
            anchor = centre if best[0].real < centre else target
            target = best[0].real + (anchor - best[0].real) / 100.0
    return best if best is not None else (complex("nan"), float("nan"))


def _unique(values: np.ndarray, errors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The eigenvalues found twice (by two targets, or a pair's two members refined to one) kept
    once: two within each other's error bounds and 1e-13 relative."""
    order = np.lexsort((-values.imag, -values.real))
    kept: list[int] = []
    for i in order:
        close = [j for j in kept if abs(values[i] - values[j])
                 <= max(errors[i], errors[j], 1e-13 * abs(values[i]))]
        if not close:
            kept.append(i)
    kept_ = np.asarray(kept, dtype=int)
    return values[kept_], errors[kept_]


def _candidates(guesses: np.ndarray, count: int, extra: tuple[complex, ...]) -> np.ndarray:
    """The guesses worth refining: of each conjugate pair the member above the axis (the pencil
    is real: the other is its conjugate, with the same bound), each once (two targets find the
    same), the ``count`` + 2 of largest real part, and every ``extra``."""
    upper = np.concatenate([guesses, np.asarray(extra, dtype=complex)])
    upper = np.where(upper.imag < 0.0, upper.conj(), upper)
    upper = upper[np.isfinite(upper)]
    order = np.argsort(-upper.real, kind="stable")
    kept: list[complex] = []
    for lam in upper[order]:
        if all(abs(lam - k) > 1e-5 * max(1.0, abs(k)) for k in kept):
            kept.append(lam)
    best = kept[:count + 2]
    for z in np.asarray(extra, dtype=complex):
        z = z.conjugate() if z.imag < 0.0 else z
        if np.isfinite(z) and all(abs(z - k) > 1e-5 * max(1.0, abs(k)) for k in best):
            best.append(z)
    return np.asarray(best, dtype=complex)


def rightmost(A: sp.csr_matrix, B: sp.csr_matrix, count: int,
              extra: tuple[complex, ...] = (), zeta: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` eigenvalues of largest real part among those nearest the targets, those
    at the Kelvin–Voigt cluster's edge where it may hold the rightmost (ζ > 0), and those near
    the ``extra`` guesses (the module's doc), refined, with their error bounds, largest real
    part first (of a complex pair, the member above the axis first)."""
    band = Band(A, B)
    norms = (float(sp.linalg.norm(A)), float(sp.linalg.norm(B)))
    nev = count + NEAREST
    # the disk left out reaches CLUSTER/ζ left of −1/ζ, where the cluster's members crowd, and a
    # tenth of that right of it (the held end's pencil has a member at −1/ζ + 0.021 at 100 cells)
    rim = 0.1 * CLUSTER / zeta if zeta > 0.0 else 0.0
    cluster = (-1.0 / zeta + rim - CLUSTER / zeta, CLUSTER / zeta) if zeta > 0.0 else None
    guesses = nearest(A, B, band, 0.0, nev, cluster)
    if guesses.size == 0:  # λ = 0 is an eigenvalue: a target beside it
        guesses = nearest(A, B, band, -1e-8 * (1.0 + norms[0] / max(norms[1], EPS)), nev,
                          cluster)
    if guesses.size:
        top = guesses[np.argmax(guesses.real)]
        if abs(top.imag) <= 1e-12 * abs(top):
            sigma = top.real + 1e-3 * max(1.0, abs(top.real))
            guesses = np.concatenate([guesses, nearest(A, B, band, sigma, nev, cluster)])
    pairs = [refined(A, B, band, g, norms) for g in _candidates(guesses, count, extra)]
    pairs += [(np.conj(lam), err) for lam, err in pairs if lam.imag != 0.0]
    if cluster is not None and not any(
            np.isfinite(p[0]) and p[0].real > cluster[0] + cluster[1] for p in pairs):
        pairs.append(edge(A, B, band, -1.0 / zeta, rim, norms))
    values = np.array([p[0] for p in pairs], dtype=complex)
    errors = np.array([p[1] for p in pairs], dtype=float)
    good = np.isfinite(values)
    values, errors = _unique(values[good], errors[good])
    return values[:count], errors[:count]


def spectrum(A, B, A0, B0, count: int, dissipative: bool, zeta: float = 0.0) -> Rightmost:
    """The ``count`` rightmost eigenvalues of A x = λ B x found (:func:`rightmost`, on the
    balanced pencil), the zeros of the exchange's g in Re λ ≥ 0 among them, and their count
    (``right``, None where :mod:`~rodfem.solver.right_half_plane`'s energy identity does not
    hold or the count is not sound)."""
    from rodfem.solver.banded import balanced

    right, extra = None, []
    exchange = Exchange.of(A, B, A0, B0) if dissipative else None
    if dissipative and (A - A0).nnz == 0 and (B - B0).nnz == 0:
        right = 0
    elif exchange is not None:
        right, minima = exchange.count()
        if right:
            extra = exchange.zeros(minima, right)
    Ab, Bb, _, _ = balanced(A, B)
    values, errors = rightmost(Ab, Bb, count, tuple(extra), zeta)
    return Rightmost(values, errors, right)


def judged(found: Rightmost):
    """The verdict (:class:`rodfem.solver.spectrum.Verdict`'s words) the eigenvalues found and
    the count earn (the module's doc): (verdict, growth rate, its error)."""
    nan = float("nan")
    if found.values.size == 0:
        return "unresolved", nan, nan
    top = int(np.argmax(found.values.real))
    rate, error = float(found.values[top].real), float(found.errors[top])
    if np.any(found.values.real > found.errors):
        return "unstable", rate, error
    if found.right == 0 and np.all(found.values.real < -found.errors):
        return "stable", rate, error
    return "unresolved", rate, error
