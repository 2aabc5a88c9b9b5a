"""Random permitted scenes (rodfem.scene.schema's ranges: exchange exponents down to 1e-3, the
obstacle's ε down to its minimum 1e-12, the gap law's length down to 1e-300): every steady state
``rodfem steady`` reports satisfies its equation to round-off, recomputed here from the laws'
formulas, or its row says it does not (trust = residual); and every verdict it calls earned
agrees with an independent spectrum: the standard eigenproblem B⁻¹A by LAPACK's dgeev (its own
balancing, Hessenberg QR, not QZ), and the parity of the positive real eigenvalues from the
signs of det A and det(−B).

A short run by default; HYPOTHESIS_PROFILE=fuzz runs 2,000 scenes (``make fuzz``).
"""

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rodfem.scene
from conftest import COMM
from rodfem.model import steady
from rodfem.scene.schema import SMALL
from rodfem.solver.spectrum import Spectra
from rodfem.studies.steady.states import analyse

EPS = np.finfo(float).eps
EXAMPLES = 2000 if os.environ.get("HYPOTHESIS_PROFILE") == "fuzz" else 25
SPECTRA = Spectra()
serial_only = pytest.mark.skipif(COMM.size > 1, reason="a dense eigenproblem: serially")


def log_uniform(lo, hi):
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0 ** e)


@st.composite
def scenes(draw):
    """Barber's rod with permitted values drawn across their ranges, on a coarse mesh."""
    law = draw(st.sampled_from(["pressure", "gap"]))
    kind = draw(st.sampled_from(["elastic", "rigid"]))
    values = {
        "model.a": draw(log_uniform(1e-3, 1.0)), "model.k": draw(log_uniform(1e-2, 10.0)),
        "model.zeta": draw(st.sampled_from([0.1, 0.5, 2.0])),
        "model.theta_A": draw(st.floats(-5.0, 5.0)),
        "obstacle.temperature": draw(st.floats(-20.0, 40.0)),
        "obstacle.kind": kind,
        "mesh.cells": draw(st.sampled_from([8, 12, 16])),
        "discretisation.mass": draw(st.sampled_from(["lumped", "consistent"])),
        "heat_exchange.law": law, "initial.theta0": "theta_A",
    }
    # the gap mostly between where the end would rest exchanging k and exchanging without
    # bound: where the contact's exchange decides, and three states are common
    a, theta_A, k = values["model.a"], values["model.theta_A"], values["model.k"]
    theta_O = values["obstacle.temperature"]
    ends = (0.5 * a * (theta_A + (theta_A + k * theta_O) / (1.0 + k)), 0.5 * a * (theta_A + theta_O))
    values["obstacle.gap"] = ends[0] + draw(st.floats(-0.5, 1.5)) * (ends[1] - ends[0])
    if kind == "elastic":
        values["obstacle.epsilon"] = draw(log_uniform(SMALL, 1.0))
        values["obstacle.law"] = draw(st.sampled_from(["linear", "power"]))
        if values["obstacle.law"] == "power":
            values["obstacle.exponent"] = draw(st.floats(1.0, 4.0))
    values["heat_exchange.k1"] = draw(log_uniform(1.0, 1e6))
    if law == "pressure":
        values["heat_exchange.exponent"] = draw(log_uniform(1e-3, 3.0))
    if law == "gap":
        values["heat_exchange.length"] = draw(log_uniform(1e-300, 1.0))
    return rodfem.scene.load("barber", [f"{k}={v!r}" if not isinstance(v, str) else
                                        f'{k}="{v}"' for k, v in values.items()])


def exchange(scene, offset, p):
    """h at u(1) = g + offset under the pressure p, from the laws' formulas written here."""
    k, law = scene["model.k"], scene["heat_exchange.law"]
    if law == "pressure":
        return k + (scene["heat_exchange.k1"] * p ** scene["heat_exchange.exponent"]
                    if p > 0 else 0.0)
    if law == "gap":
        return k + scene["heat_exchange.k1"] * math.exp(min(offset, 0.0)
                                                         / scene["heat_exchange.length"])
    return k


def residual(scene, state):
    """u(1) + p − a (θ_A + θ(1))/2 with θ(1) from h at the state (the offset u(1) − g kept),
    and its round-off: the few roundings of each term."""
    a, theta_A, theta_O = scene["model.a"], scene["model.theta_A"], scene["obstacle.temperature"]
    h = exchange(scene, state.offset, state.p)
    theta_1 = (theta_A + h * theta_O) / (1.0 + h)
    g = scene["obstacle.gap"]
    r = (state.offset + state.p) - (0.5 * a * (theta_A + theta_1) - g)
    return r, theta_1


def independent(A, B):
    """(the largest real part of eig(B⁻¹A) by dgeev, its round-off bound; whether det A and
    det(−B) differ in sign: an odd number of positive real eigenvalues)."""
    C = np.linalg.solve(B, A)
    found = np.linalg.eigvals(C)
    parity = np.linalg.slogdet(A)[0] != np.linalg.slogdet(-B)[0] \
        if np.linalg.cond(A) * A.shape[0] * EPS < 0.125 else None
    return float(found.real.max()), parity


@serial_only
@settings(max_examples=EXAMPLES, deadline=None, derandomize=EXAMPLES < 100,
          suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
def test_every_row_is_a_state_and_its_verdict_is_earned(scene):
    problem = steady.of_scene(scene)
    states = problem.states()
    rows = analyse(scene, SPECTRA)
    assert len(rows) == len(states) >= 1
    for state, row in zip(states, rows, strict=True):
        assert row["u_1"] == state.u_1 and row["residual"] == state.residual
        r, theta_1 = residual(scene, state)
        assert theta_1 == pytest.approx(state.theta_1, rel=8 * EPS, abs=8 * EPS)
        if row["trust"] == "residual":
            assert row["stable"] is None and not state.resolved
            # a jump between adjacent doubles, not a root: beyond the round-off bound
            assert abs(r) > state.tolerance / 2
            continue
        assert abs(r) <= 2 * state.tolerance, (r, state)
        if row["trust"] != "ok":
            assert row["stable"] is None and row["trust"] in ("neutral", "unresolved")
            continue
        A, B = SPECTRA.pencil(scene, problem.linearise(state))
        rate, parity = independent(A, B)
        if parity:  # an odd number of positive real eigenvalues: unstable, whatever QZ finds
            assert not row["stable"], (row, rate)
        elif row["stable"]:
            # dgeev's spectrum has no eigenvalue resolved right of the axis
            assert rate <= max(row["growth_error"], 1e-6 * abs(row["growth_rate"])) or \
                not math.isfinite(rate), (row, rate)
        if not row["stable"] and parity is False:
            # unstable by QZ alone: dgeev finds the growth too, to its own round-off
            assert rate > 0.0 or not math.isfinite(rate), (row, rate)
