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
* faster than that band allows, the last two runs agree by chance (the error of adaptive steps
  falls in plateaus as the tolerance is cut, a peak falls between two fixed steps): the error is
  taken as the difference before over the expected rate, d₀/ρ^q, or d where larger;
* slower than the band, or with one pair only, the same with R taken as at most 2: the error is
  at least the difference d itself, and where the differences do not shrink, the larger of the
  two (the measure is not converging yet: its runs are refined further).

An estimate in time from one pair only is not enough for a target to be met (:mod:`.ladder`
refines the step once more): the error of adaptive steps does not fall steadily with the
tolerance, and two levels alone cannot tell a plateau from convergence.

Each estimate also bounds the finer run's *signed* error m − m_exact (:attr:`Estimate.low`,
:attr:`Estimate.high`), where the refinement is a power law's (h, or a fixed Δt; not the
tolerance of adaptive steps, whose error falls in plateaus):

* in the asymptotic range, where the two differences have one sign (the errors fall as a power
  of the step), around Richardson's correction −(m_fine − m_coarse)/(ρ^p' − 1), give or take
  the spread between the observed and the expected order's corrections;
* otherwise, and for the tolerance, ± the estimate: outside the asymptotic range an error may
  still cross zero, and two runs that agree by chance say nothing of its sign.

:func:`combined` adds the two directions' errors: with both bounded with their signs, it is the
largest magnitude of their sum times a factor of safety (:data:`SAFETY`), so that errors in h
and in time of opposite signs, which cancel in the run, cancel in its estimate too; otherwise the
sum of the two estimates.

These are estimates, not bounds: ``tests/test_accuracy_targets.py`` measures how often they cover
the true error (against runs converged in both h and Δt) and by how much they exceed it.
NumPy-free.
"""

from __future__ import annotations

import dataclasses
import math

from rodfem.studies.asymptotic import BAND, within

TOLERANCE_RATIO = 10.0  # each adaptive run's tolerance over the next one's
# The factor of safety on an error combined from the two directions' signed bounds: Roache's for
# a grid convergence index from three or more grids (J. Fluids Eng. 116, 1994). Over 1,200 random
# manufactured cases (benchmarks/bench_estimates.py) the estimates covered the exact error in
# 99.9 % of them with it, 99.2 % without it (98.6 % of the paper scheme's).
SAFETY = 1.25


@dataclasses.dataclass(frozen=True)
class Estimate:
    """The estimated error of a measure in one direction: ``error`` (absolute), the difference
    it came from, the observed order (None: two runs only, or differences that do not shrink)
    and whether that order is the scheme's (None: two runs only); ``checked``: whether it rests
    on two differences (an observed rate), not on one; ``low`` and ``high``: the bounds of the
    finer run's signed error (the module's docstring)."""

    error: float
    difference: float
    order: float | None = None
    asymptotic: bool | None = None
    checked: bool = False
    low: float = -math.inf
    high: float = math.inf


def estimate(differences: list[float], ratio: float, order: float,
             power_law: bool = True) -> Estimate:
    """The error of the finer run of the last pair of runs refined by ``ratio`` in one
    direction, from m_fine − m_coarse of that pair (``differences[-1]``) and, where known, of
    the pair one refinement coarser (``differences[-2]``); ``order``: the expected order in that
    direction (:func:`rodfem.studies.asymptotic.expected`); ``power_law``: whether the error is
    a power of the refined step (h, fixed Δt), so that its sign can be bounded (not the
    tolerance of adaptive steps)."""
    if not differences:
        raise ValueError("an estimate needs two runs at least")
    signed = differences[-1]
    d = abs(signed)
    if len(differences) == 1:
        return _bounded(Estimate(d, d))
    before, expected_rate = abs(differences[-2]), ratio ** order
    if d == 0.0 or before / d > expected_rate * ratio ** BAND:
        # faster than the scheme converges: the two last runs agree by chance (a plateau of
        # the adaptive steps' error, a peak between two fixed steps), and the difference
        # before, at the expected rate, says more of the error than their agreement
        observed = math.log(before / d) / math.log(ratio) if d > 0.0 else math.inf
        return _bounded(Estimate(max(d, before / expected_rate), d, _finite(observed), False,
                                 True))
    if before <= d:  # not converging (yet): the larger difference, no order
        return _bounded(Estimate(d, d, None, False, True))
    rate = before / d
    observed = math.log(rate) / math.log(ratio)
    asymptotic = within(observed, order)
    used = min(rate, expected_rate) if asymptotic else min(rate, 2.0)
    found = Estimate(d / (used - 1.0), d, observed, asymptotic, True)
    if asymptotic and power_law and (differences[-2] > 0.0) == (signed > 0.0):
        # the errors fall as a power: the finer run's has the sign opposite to the differences',
        # and is Richardson's correction, give or take the spread between the two orders'
        spread = abs(d / (rate - 1.0) - d / (expected_rate - 1.0))
        correction = -math.copysign(found.error, signed)
        return dataclasses.replace(found, low=correction - spread, high=correction + spread)
    return _bounded(found)


def _bounded(found: Estimate) -> Estimate:
    """``found`` with its signed error bounded by its size alone: ± the estimate."""
    return dataclasses.replace(found, low=-found.error, high=found.error)


def combined(space: Estimate, time: Estimate, signed: bool) -> float:
    """The error of a run from its estimates in h and in time: with ``signed`` (both a power
    law's), :data:`SAFETY` times the largest magnitude of their signed bounds' sum; otherwise
    the sum of the two errors."""
    if not signed:
        return space.error + time.error
    return SAFETY * max(abs(space.low + time.low), abs(space.high + time.high))


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None
