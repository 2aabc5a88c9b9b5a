r"""The number of eigenvalues of the linearised pencil A X = λ B X in the closed right half-plane,
by the argument principle, independently of the eigenvalues found (:mod:`rodfem.solver.rightmost`,
whose verdict takes it only where the two are consistent), and the zeros it counts.

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
sampling resolves could pass between two samples unseen, and g could turn after the last. Where it
is not sound, the count is None.
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.banded import Band

MAX_SAMPLES = 20_000  # of g(iω) for the count
PHASE_STEP = np.pi / 4
SETTLED = 1e3  # the last sample's frequency, in units of the pencil's scale


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
