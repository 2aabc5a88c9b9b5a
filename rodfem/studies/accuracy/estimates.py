"""How far a measure is from its converged value, from runs refined in one direction.

Two runs that differ only in h (cells c and 2c), or only in the time step (Δt and Δt/2 with fixed
steps, tolerance τ and τ/10 with adaptive ones), differ in a measure m by d = |m_fine − m_coarse|.
If the error of m falls by a factor R ≥ 2 from one run to the next, the finer run's error is
d/(R − 1) ≤ d: the difference alone bounds it. The pair one refinement coarser gives the rate R of
this measure, observed: R = d₀/d with d₀ that pair's difference. Then

* the order is p = log(R)/log(ρ) (ρ: the refinement, 2 in h and in Δt, 10 in the tolerance);
* the measure is *in its asymptotic range* where p is within the band of the expected order q
  (:mod:`rodfem.studies.asymptotic`, as ``rodfem verify`` checks it: P1's 2 in h; the scheme's
  own in Δt, 1 for the paper's and 2 for Crank–Nicolson; q/(q + 1) of that in the tolerance of
  adaptive steps), and the finer run's error is d/(ρ^p' − 1) with p' = min(p, q) (Richardson
  with the smaller of the two orders: never below the scheme's own estimate);
* outside that band, or with one pair only, the same with R taken as at most 2: the error is at
  least the difference d itself, and where the differences do not shrink, the larger of the two
  (the measure is not converging yet: its runs are refined further).

These are estimates, not bounds: ``tests/test_accuracy_targets.py`` measures how often they cover
the true error (against runs converged in both h and Δt) and by how much they exceed it.
NumPy-free.
"""

from __future__ import annotations

import dataclasses
import math

from rodfem.studies.asymptotic import within

TOLERANCE_RATIO = 10.0  # each adaptive run's tolerance over the next one's


@dataclasses.dataclass(frozen=True)
class Estimate:
    """The estimated error of a measure in one direction: ``error`` (absolute), the difference
    it came from, the observed order (None: two runs only) and whether that order is the
    scheme's (None: no scheme order to check, or two runs only)."""

    error: float
    difference: float
    order: float | None = None
    asymptotic: bool | None = None


def estimate(differences: list[float], ratio: float, order: float | None) -> Estimate:
    """The error of the finer run of the last pair of runs refined by ``ratio`` in one
    direction, from |m_fine − m_coarse| of that pair (``differences[-1]``) and, where known,
    of the pair one refinement coarser (``differences[-2]``); the scheme's ``order`` in that
    direction (None: none)."""
    if not differences:
        raise ValueError("an estimate needs two runs at least")
    d = differences[-1]
    if len(differences) == 1:
        return Estimate(d, d)
    before = differences[-2]
    if d == 0.0:
        return Estimate(0.0, 0.0, math.inf if before > 0.0 else None, None)
    if before <= d:  # not converging (yet): the larger difference, no order
        return Estimate(d, d, None, False if order else None)
    rate = before / d
    observed = math.log(rate) / math.log(ratio)
    asymptotic = None if order is None else within(observed, order)
    rate = min(rate, ratio ** order) if asymptotic else min(rate, 2.0)
    return Estimate(d / (rate - 1.0), d, observed, asymptotic)
