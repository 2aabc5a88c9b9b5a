"""A real eigenvalue μ > 0 of a real pencil A x = λ B x, certain from the signs of two
determinants where QZ's round-off could leave it on either side of the axis
(:func:`rodfem.solver.spectrum.judged`): the sign of det(A − μB) at 0 and at infinity, each
taken only where the LU factors' round-off cannot change it, then bisection on that sign."""

from __future__ import annotations

import numpy as np


def positive_real(A: np.ndarray, B: np.ndarray, B_sign: float) -> tuple[float, float] | None:
    """A real eigenvalue μ > 0 of A x = λ B x and the width of its bracket, where the signs of
    det A and det(−B) differ (then det(A − μB), a real polynomial of degree n for B regular,
    changes sign an odd number of times on (0, ∞): complex eigenvalues come in pairs), found
    by bisection on that sign; None where they agree or A is too badly conditioned for the sign
    of its LU factors to be certain (cond × n × eps ≥ 1/8). ``B_sign``: the sign of det(−B),
    B regular (:func:`rodfem.solver.spectrum.regular`; a balancing's powers of 2 keep the sign)."""
    eps = np.finfo(float).eps
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        return None
    at_zero, at_infinity = _certain_sign(A), B_sign
    if at_zero is None or at_zero == at_infinity:
        return None
    hi = 2.0 * np.linalg.norm(np.linalg.solve(B, A), np.inf)  # beyond every |λ|
    if not np.isfinite(hi) or np.linalg.slogdet(A - hi * B)[0] != at_infinity:
        return None
    lo = 0.0
    for _ in range(400):
        mid = np.sqrt(lo * hi) if lo > 0.0 else 1e-6 * hi
        if not lo < mid < hi or hi - lo <= 16.0 * eps * hi:
            break
        if np.linalg.slogdet(A - mid * B)[0] == at_zero:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi), hi - lo


def _certain_sign(A: np.ndarray) -> float | None:
    """The sign of det A from its LU factors, None where A's condition number (LAPACK's
    estimate) × n × eps ≥ 1/8: the factors' round-off could then change it."""
    import scipy.linalg

    lu, pivots = scipy.linalg.lu_factor(A, check_finite=False)
    rcond, info = scipy.linalg.lapack.dgecon(lu, np.linalg.norm(A, 1), norm="1")
    if info != 0 or not rcond * 0.125 > A.shape[0] * np.finfo(float).eps:
        return None
    swaps = np.count_nonzero(pivots != np.arange(A.shape[0]))
    return float(np.prod(np.sign(np.diag(lu))) * (-1.0) ** swaps)
