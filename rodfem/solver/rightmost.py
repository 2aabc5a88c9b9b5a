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

**What is certain.** Shift-and-invert finds eigenvalues near a target, not the rightmost, so
an eigenvalue with Re λ ≥ 0 far from the target could be missed. It cannot be here: the count of
eigenvalues in the closed right half-plane is taken independently, by the argument principle.
Without the exchange's change with the end's place and force (c_u, c_p), the pencil A₀ − λB₀ is
dissipative: an eigenvector's energy E = Θᴴ M Θ + b Vᴴ M_b V + Uᴴ K U + κ|U(1)|² > 0 obeys

    Re λ · E = −Θᴴ K Θ − h |Θ(1)|² − ζ |λ|² Uᴴ K U < 0

(the coupling's terms cancel; h > −1 and κ, ζ, b ≥ 0 are required, and Θ(1)² ≤ Θᴴ K Θ holds
for P1 with Θ(0) = 0), so A₀ − λB₀ is regular in Re λ ≥ 0. c_u and c_p add one row,
e dᵀ(λ), so det(A − λB) = det(A₀ − λB₀) g(λ) with g(λ) = 1 + d(λ)ᵀ(A₀ − λB₀)⁻¹e, analytic in
Re λ ≥ 0: the number of eigenvalues there is the number of zeros of g, −Δ arg g(iω)/π over
ω ∈ [0, ∞) (g(−iω) is g(iω)'s conjugate). Where c_u = c_p = 0 there are none (g = 1): the
state is stable by the identity alone. Otherwise g(iω) is sampled, one banded solve a point,
on a grid of doublings refined until consecutive samples differ by less than π/4 in phase and
a factor of 2 in modulus, up to a frequency a thousand times the pencil's scale where g must
have settled. This count is numerical, not a proof: a zero of g closer to the axis than the
sampling resolves could pass between two samples unseen, and g could turn after the last. The
verdict takes it only where it is consistent: stable where the count is 0 and every eigenvalue
found is resolved left of the axis; unstable where one found is resolved right of it; where the
count and the eigenvalues found disagree, or g comes near 0 on the axis, or the laws break the
identity's conditions (ζ = 0 is allowed by it, but its waves then lie near the axis),
unresolved, never a guess. The growth rate is the largest real part among those found.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from rodfem.solver.banded import Band

EPS = float(np.finfo(float).eps)
NEAREST = 6  # eigenvalues found beyond the ``count`` asked, per target
TOLERANCE = 1e-6  # SLEPc's relative residual; the refinement brings it to round-off
RESTARTS = 30  # of Krylov–Schur, the Kelvin–Voigt cluster left out: it converges in one or two
CLUSTER = 0.05  # the Kelvin–Voigt cluster's disk about −1/ζ: radius CLUSTER/ζ
BLOCK = 8  # vectors of the block inverse iteration at the cluster's edge
EDGE_ROUNDS = 10  # of targets moved towards −1/ζ at the cluster's edge
MAX_SAMPLES = 20_000  # of g(iω) for the count
PHASE_STEP = np.pi / 4
SETTLED = 1e3  # the last sample's frequency, in units of the pencil's scale


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
    (``right``, None where the energy identity does not hold or the count is not sound)."""
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


class Exchange:
    """g(λ) = det(A − λB)/det(A₀ − λB₀) = 1 + d(λ)ᵀ(A₀ − λB₀)⁻¹e and its derivative, where
    A − λB = A₀ − λB₀ + e d(λ)ᵀ, d(λ) = d_A − λ d_B: the exchange's one row (the module's doc).
    ``None`` from :meth:`of` where the difference is not one row."""

    def __init__(self, A0, B0, row: int, d_A: np.ndarray, d_B: np.ndarray):
        self.band, self.B0 = Band(A0, B0), B0
        self.d_A, self.d_B = d_A, d_B
        self.e = np.zeros(A0.shape[0], dtype=complex)
        self.e[row] = 1.0
        B_diagonal = np.abs(B0.diagonal())
        self.scale = max(1.0, float(abs(A0).max()) / float(B_diagonal[B_diagonal > 0].min()))
        self.size = max(1.0, float(np.abs(d_A).sum() + np.abs(d_B).sum()))

    @classmethod
    def of(cls, A, B, A0, B0) -> Exchange | None:
        D_A, D_B = (A - A0).tocsr(), (B - B0).tocsr()
        D_A.eliminate_zeros()
        D_B.eliminate_zeros()
        rows = np.union1d(np.unique(D_A.tocoo().row), np.unique(D_B.tocoo().row))
        if rows.size != 1:
            return None
        row = int(rows[0])
        return cls(A0, B0, row, D_A[row].toarray().ravel(), D_B[row].toarray().ravel())

    def __call__(self, lam: complex) -> tuple[complex, complex]:
        """(g(λ), g'(λ)); g = 0 where A₀ − λB₀ is singular (never in Re λ ≥ 0)."""
        factor = self.band.factor(lam)
        if factor.singular:
            return 0j, 0j
        z = factor.solve(self.e)
        d = self.d_A - lam * self.d_B
        dz = factor.solve(self.B0 @ z)  # d/dλ (A₀ − λB₀)⁻¹e = (A₀ − λB₀)⁻¹ B₀ (A₀ − λB₀)⁻¹e
        return complex(1.0 + d @ z), complex(-self.d_B @ z + d @ dz)

    def count(self) -> tuple[int | None, list[float]]:
        """The zeros of g in Re λ ≥ 0, by −Δ arg g(iω)/π over ω ∈ [0, ∞), sampled (the
        module's doc), and the frequencies where |g(iω)| has a local minimum (seeds for the
        zeros); None where the sampled count is not sound."""
        omegas = [0.0, *(self.scale * 2.0 ** np.arange(-60, int(np.log2(SETTLED)) + 2))]
        values = [self(1j * w) for w in omegas]
        i = 0
        while i + 1 < len(omegas):
            (w0, w1), ((g0, s0), (g1, s1)) = omegas[i:i + 2], values[i:i + 2]
            if min(abs(g0), abs(g1)) <= 1e-10 * self.size:
                return None, []  # a zero of g on the axis, to round-off
            swing = (w1 - w0) * max(abs(s0 / g0), abs(s1 / g1))
            if (abs(np.angle(g1 / g0)) > PHASE_STEP or abs(np.log(abs(g1) / abs(g0))) > 0.7
                    or swing > PHASE_STEP):
                mid = 0.5 * (w0 + w1) if w0 == 0.0 or w1 < 4.0 * w0 else np.sqrt(w0 * w1)
                if not w0 < mid < w1 or len(omegas) >= MAX_SAMPLES or w1 - w0 <= 1e-12 * w1:
                    return None, []
                omegas.insert(i + 1, mid)
                values.insert(i + 1, self(1j * mid))
                continue
            i += 1
        g = np.array([v[0] for v in values])
        if np.max(np.abs(g[-8:] - g[-1])) > 0.05 * abs(g[-1]) or abs(g[-1].imag) > 0.05 * abs(
                g[-1]):
            return None, []  # g has not settled to its real limit by the last frequency
        zeros = -float(np.sum(np.angle(g[1:] / g[:-1]))) / np.pi
        count = int(round(zeros))
        if abs(zeros - count) > 0.25 or count < 0:
            return None, []
        modulus = np.abs(g)
        inner = [k for k in range(1, len(g) - 1)
                 if modulus[k] < modulus[k - 1] and modulus[k] < modulus[k + 1]]
        minima = [omegas[k] for k in sorted(inner, key=lambda k: modulus[k])]
        return count, minima

    def zeros(self, minima: list[float], wanted: int | None = None) -> list[complex]:
        """Zeros of g in Re λ ≥ 0 by Newton's method, from the positive real axis (where g's
        sign changes between 0 and ∞: g is real and continuous there) and from beside each
        local minimum of |g(iω)|, deepest first; each zero once (with its conjugate where
        complex), the seeds left once ``wanted`` are found (the count's)."""
        seeds = [1j * w + 1e-3 * max(1.0, w) for w in minima]
        g0, g_inf = self(0.0)[0].real, self(SETTLED * self.scale)[0].real
        if g0 * g_inf < 0:
            lo, hi = 0.0, SETTLED * self.scale
            for _ in range(200):
                mid = np.sqrt(lo * hi) if lo > 0 else 1e-12 * hi
                if not lo < mid < hi or hi - lo <= 1e-14 * hi:
                    break
                if self(mid)[0].real * g0 > 0:
                    lo = mid
                else:
                    hi = mid
            seeds.insert(0, 0.5 * (lo + hi))
        found: list[complex] = []
        for lam in seeds:
            if wanted is not None and len(found) >= wanted:
                break
            lam = self._newton(complex(lam))
            if lam is None or any(abs(lam - z) <= 1e-10 * max(1.0, abs(z)) for z in found):
                continue
            found.append(lam)
            if abs(lam.imag) > 1e-12 * abs(lam):
                found.append(lam.conjugate())
        return found

    def _newton(self, lam: complex) -> complex | None:
        """A zero of g in Re λ ≥ 0 by Newton's method from ``lam``; None where the steps stop
        shrinking before |g| reaches round-off's 1e-8 of its size, or leave the frequencies
        where g was sampled."""
        previous = np.inf
        for _ in range(60):
            g, slope = self(lam)
            if abs(g) <= 1e-13 * self.size or slope == 0:
                break
            step = g / slope
            if not np.isfinite(step) or abs(step) >= previous and abs(g) > 1e-8 * self.size:
                return None  # diverging, or stalled above round-off
            if abs(step) >= previous or abs(step) <= 1e-14 * max(1.0, abs(lam)):
                break  # at round-off
            lam, previous = lam - step, abs(step)
            if abs(lam) > 10.0 * SETTLED * self.scale:
                return None
        ok = np.isfinite(lam) and lam.real >= 0.0 and abs(self(lam)[0]) <= 1e-8 * self.size
        return lam if ok else None


def dissipative(lin, zeta: float, b: float) -> bool:
    """Whether the energy identity (the module's doc) holds for the laws at the state."""
    return lin.h > -1.0 and lin.kappa >= 0.0 and zeta >= 0.0 and b >= 0.0
