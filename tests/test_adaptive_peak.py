"""Adaptive steps give the peak contact stress against a stiff obstacle without tuning.

The built-in scene ``stiff`` (paper1's rod against 1/ε = 1e4, ζ = 0.1, to T = 0.5): its peak
|σ(1)| converged in time (Crank–Nicolson's fixed steps, two refinements agreeing to 0.01 %), the
paper's fixed step missing it by 30 %, and ``time.adaptive = true`` at the default tolerance
holding it within 1 % (the requirement itself), with each scheme and with Picard's iteration,
which fails at the fixed step there. benchmarks/bench_adaptive_peak.py measures the whole grid of
ζ and 1/ε.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

import rodfem

REQUIRED = 0.01  # the peak within 1 %
CHANGE = 1e-4  # the reference: two refinements within 0.01 %


def run(**keys):
    overrides = {"output.fields": ["u"], **{k.replace("__", "."): v for k, v in keys.items()}}
    return rodfem.simulate("stiff", overrides, comm=MPI.COMM_SELF)


def peak(result) -> float:
    assert result.status == "complete", result.summary
    return float(np.max(np.abs(result.history["sigma_1"])))


@pytest.fixture(scope="module")
def reference() -> float:
    """The peak with fixed Crank–Nicolson steps of 1e-5, checked against 5e-6."""
    coarse = peak(run(time__scheme="crank-nicolson", time__dt=1e-5))
    fine = peak(run(time__scheme="crank-nicolson", time__dt=5e-6))
    assert abs(fine - coarse) < CHANGE * fine
    return fine


def test_the_paper_fixed_step_misses_the_peak(reference):
    """The paper's scheme at its Δt = 1e-3 is 30 % low (measured −29.9 %): more than 15 %."""
    assert peak(run()) < 0.85 * reference


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
def test_adaptive_holds_the_peak_within_one_percent(reference, scheme):
    result = run(time__scheme=scheme, time__adaptive=True)
    assert result.scene["time.tolerance"] == 0.0  # the default: the scheme's own
    assert abs(peak(result) / reference - 1.0) < REQUIRED
    assert result.summary["adaptive"]["events"] == 1  # the impact, located


def test_adaptive_takes_fewer_steps_than_fixed_crank_nicolson(reference):
    """Fixed Crank–Nicolson misses 1 % with 1,000 steps (Δt = 5e-4: +1.4 %); the adaptive run
    holds it with fewer."""
    fixed = peak(run(time__scheme="crank-nicolson", time__dt=5e-4))
    assert abs(fixed / reference - 1.0) > REQUIRED
    adaptive = run(time__scheme="crank-nicolson", time__adaptive=True)
    assert abs(peak(adaptive) / reference - 1.0) < REQUIRED
    assert adaptive.summary["adaptive"]["steps"] < 1000


def test_adaptive_picard_completes_where_the_fixed_step_fails(reference):
    """At Δt = 1e-3 Picard's contraction w/ε is 0.98 in contact and the iteration fails; the
    adaptive run retries the failed steps smaller and gives the peak."""
    assert run(solver__method="picard").status == "failed"
    result = run(solver__method="picard", time__adaptive=True)
    assert abs(peak(result) / reference - 1.0) < REQUIRED


def test_picard_bounds_only_steps_in_contact():
    """paper1 against 1/ε = 1e4, Crank–Nicolson: Picard fails entering the first contact, which
    bounds its steps in contact; after the release (t = 0.95) the error control alone sets the
    step, which grows well beyond that bound."""
    result = rodfem.simulate("paper1", {"obstacle.epsilon": 1e-4, "time.end": 1.5,
                                        "time.scheme": "crank-nicolson", "time.adaptive": True,
                                        "solver.method": "picard", "output.fields": ["u"]},
                             comm=MPI.COMM_SELF)
    assert result.status == "complete"
    h = result.history
    touching = h["u_1"] > result.scene["obstacle.gap"]
    assert result.summary["adaptive"]["rejected"] > 0
    free = h["t"] > h["t"][touching][-1]
    assert h["dt"][free].max() > 2.0 * h["dt"][touching].max()


@pytest.mark.parametrize("scene, overrides", [
    ("stiff", {}),
    ("impact", {"mesh.cells": 100, "time.dt": 0.01, "time.end": 1.5, "time.scheme": "paper"})],
    ids=["stiff", "impact"])
def test_the_paper_scheme_adaptive_keeps_its_energy_decay(scene, overrides):
    """Each adaptive step is the paper's step of its own size: Remark 4.4's energy does not grow
    from n = 2 on (to round-off in its sum). On the impact (a massless end, released from data
    that do not balance it) the run completes."""
    result = rodfem.simulate(scene, {**overrides, "time.adaptive": True, "output.fields": ["u"]},
                             comm=MPI.COMM_SELF)
    assert result.status == "complete" and result.summary["adaptive"]["events"] == 1
    energy = result.history["energy"]
    assert np.all(np.diff(energy[2:]) <= 8 * np.finfo(float).eps * np.abs(energy[2:-1]))
