"""Time runs of thermoelastic contact settle where the steady analysis says, at the rate it says,
and leave an unstable state as its critical eigenvalues say (direct method, paper scheme).

The paper's scheme is backward Euler on (Θ, U, δ), so about a steady state a step multiplies the
mode of an eigenvalue λ of the linearised problem by exactly 1/(1 − λΔt): the run's rate is
μ = −ln(1 − λΔt)/Δt (rodfem.studies.steady.barber.step_rate), not λ. The steady states are the
scheme's own (P1 is exact at the nodes at rest), so what is left between a run and μ is the share of
the faster modes, which shrinks as e^{(Re λ₂ − Re λ₁)t}, and the sampling of the envelope at steps.

The cold start is the scene's (θ = 0, u = 0); the hot start is the rod at the obstacle's
temperature (θ = 10 x), at rest, which expands into the obstacle.
"""

import math

import numpy as np
import pytest

import rodfem.scene
from rodfem.studies.steady import barber

COARSE = ["mesh.cells=20", "time.dt=0.001", "solver.method=direct"]
# A hot rod (θ_A = 10) against a cool obstacle (θ_O = 0) exchanging k + k₁p²: its one steady
# state loses stability to a complex pair (a Hopf bifurcation) below ζ ≈ 0.02.
HOPF = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0", "heat_exchange.k1=1000",
        "heat_exchange.exponent=2", "obstacle.gap=0.11", "obstacle.epsilon=0.1", "model.zeta=0.01",
        "mesh.cells=40", "time.dt=0.001", "solver.method=direct"]


@pytest.fixture(scope="module")
def barber_states():
    found = barber.states(rodfem.scene.load("barber", COARSE))
    assert [state.contact for state, _ in found] == [False, True, True]
    assert [eigenvalues[0].real < 0.0 for _, eigenvalues in found] == [True, False, True]
    return found


def test_cold_start_stays_separated_and_settles_at_the_predicted_rate(barber_states):
    state, eigenvalues = barber_states[0]
    mu = barber.step_rate(eigenvalues[0], 0.001)
    period = 2.0 * math.pi / abs(mu.imag)
    run = barber.run("barber", [*COARSE, "time.end=24"])
    assert run.status == "complete"
    assert np.all(run.p == 0.0) and np.all(run.sigma_1 == 0.0)  # never touches
    distance = run.u_1 - state.u_1
    # Windows one period long, a whole number of periods apart: one mode's envelope shrinks by
    # exactly e^{Re μ Δ} between them. The faster modes (Re λ₂ = −2.005) are down by
    # e^{−1.39 t} against it from t = 6 on: 1e-3 of the rate (0.6) is their share.
    for start in (6.0, 10.0):
        rate = barber.decay_rate(run.t, distance, (start, start + period),
                                 (start + 2 * period, start + 3 * period))
        assert abs(rate - mu.real) < 1e-3 * abs(mu.real) + 1e-3
    # one mode, |x(t)| ≤ A e^{Re μ t}, peaks within each period: the end is below the first
    # window's envelope times e^{Re μ (24 − 6 − period)}
    for name, target in (("u_1", state.u_1), ("theta_1", state.theta_1)):
        distance = getattr(run, name) - target
        bound = barber.envelope(run.t, distance, 6.0, 6.0 + period) * math.exp(
            mu.real * (24.0 - 6.0 - period))
        assert abs(distance[-1]) <= bound < 1e-7


def test_hot_start_settles_pressed_at_least_as_fast_as_predicted(barber_states):
    state, eigenvalues = barber_states[2]
    mu = barber.step_rate(eigenvalues[0], 0.001)
    assert mu.imag == 0.0
    run = barber.run("barber", [*COARSE, "time.end=8", "initial.theta0=10*x"])
    assert run.status == "complete"
    assert np.all(run.p[run.t >= 1.0] > 0.0)  # pressed from t = 1 on
    for name, target, scale in (("u_1", state.u_1, 1.0), ("sigma_1", state.sigma_1, 100.0),
                                ("theta_1", state.theta_1, 1000.0)):
        distance = getattr(run, name) - target
        first, last = (barber.envelope(run.t, distance, t, t + 1.0) for t in (1.0, 7.0))
        # every mode decays at least as fast as the slowest, Re μ = −2.003
        assert last <= first * math.exp(mu.real * 6.0)
        assert abs(distance[-1]) <= last <= 1e-10 * scale


@pytest.fixture(scope="module")
def hopf_run():
    (state, eigenvalues), = barber.states(rodfem.scene.load("barber", HOPF))
    run = barber.run("barber", [*HOPF, "time.end=160", *barber.at_rest(state, "1e-5*x")])
    assert run.status == "complete"
    return state, eigenvalues, run


def test_unstable_state_is_left_with_the_critical_pair_s_period_and_growth(hopf_run):
    state, eigenvalues, run = hopf_run
    critical = eigenvalues[0]
    assert critical.real > 0.1 and abs(critical.imag) > 5.0  # a complex pair, unstable
    assert eigenvalues[2].real < -0.04  # the next pair decays
    mu = barber.step_rate(critical, 0.001)
    period = 2.0 * math.pi / abs(mu.imag)
    distance = run.u_1 - state.u_1
    # In 20 ≤ t ≤ 45 the oscillation is below 1e-4, under ε p = 2.4e-3 (it stays pressed: the
    # problem is linear), and the decaying pair is down by e^{−0.156 t} < 0.05 against it: each
    # crossing moves by less than that share of a radian, the mean period of 20 by 1e-3.
    assert np.all(run.p[(run.t >= 20.0) & (run.t <= 45.0)] > 0.0)
    assert barber.envelope(run.t, distance, 20.0, 45.0) < 1e-4
    assert barber.period(run.t, distance, 20.0, 45.0) == pytest.approx(period, rel=1e-3)
    rate = barber.decay_rate(run.t, distance, (20.0, 20.0 + period),
                             (20.0 + 20 * period, 21.0 * period + 20.0))
    assert rate == pytest.approx(mu.real, abs=0.05 * 2.0 / (20 * period))


def test_unstable_state_settles_into_periodic_intermittent_contact(hopf_run):
    state, eigenvalues, run = hopf_run
    linear = 2.0 * math.pi / abs(barber.step_rate(eigenvalues[0], 0.001).imag)
    distance = run.u_1 - state.u_1
    # Two late windows of the same cycle: the end touches and leaves the obstacle once a
    # period; the periods of u(1)'s crossings (interpolated, O((ωΔt)²) = 1e-5 off) agree.
    periods = [barber.period(run.t, distance, start, start + 15.0) for start in (130.0, 145.0)]
    assert periods[0] == pytest.approx(periods[1], rel=1e-4)
    for start, cycle_period in zip((130.0, 145.0), periods, strict=True):
        window = barber.cycle(run, start, start + 15.0)
        assert abs(window.touches - 15.0 / cycle_period) <= 1.0
        assert 0.2 < window.contact_fraction < 0.8
        assert window.u_min < 0.11 < window.u_max
        # far from onset (ζ = 0.01 against ζ ≈ 0.02) the cycle's period is the linear one's
        # only roughly: it grows with the amplitude squared
        assert linear < cycle_period < 1.1 * linear


@pytest.mark.parametrize("scheme", ["paper", "crank-nicolson"])
def test_near_onset_the_step_rate_decides(scheme):
    """Just below the Hopf bifurcation (ζ = 0.018 against 0.0183) the state is unstable, Re λ =
    0.0047; the paper's scheme damps the vibration by about ω²Δt/2 = 0.0175 and its run returns
    to the state, Crank–Nicolson's leaves it, each at its Re μ and with the period 2π/Im μ."""
    scene = [*HOPF, "model.zeta=0.018", f"time.scheme={scheme}", "time.end=200"]
    (state, eigenvalues), = barber.states(rodfem.scene.load("barber", scene))
    critical = eigenvalues[0]
    assert 0.0 < critical.real < 0.01
    mu = barber.step_rate(critical, 0.001, scheme)
    assert (mu.real < 0.0) == (scheme == "paper")
    period = 2.0 * math.pi / abs(mu.imag)
    run = barber.run("barber", [*scene, *barber.at_rest(state, "1e-4*x")])
    assert run.status == "complete" and np.all(run.p > 0.0)  # pressed: the problem is linear
    distance = run.u_1 - state.u_1
    # from t = 100 the next pair (Re λ ≤ −0.05) is down by e^{−5} against the critical one: the
    # envelopes 90 periods apart and the mean of 90 periods are off by less than 1e-4 of it
    rate = barber.decay_rate(run.t, distance, (100.0, 100.0 + period),
                             (100.0 + 90 * period, 100.0 + 91 * period))
    assert rate == pytest.approx(mu.real, abs=2e-4)
    assert barber.period(run.t, distance, 100.0, 200.0) == pytest.approx(period, rel=1e-4)


def test_near_onset_the_cycle_stays_in_contact_with_the_critical_period():
    """At ζ = 0.0165, Re μ = 0.010 above the paper scheme's onset (ζ = 0.0172), the Hopf
    bifurcation's cycle is small: the end oscillates pressed against the obstacle, its amplitude
    under ε p = 2.4e-3, with nearly the critical pair's period, off by the amplitude squared
    (0.2 %); it makes and breaks contact only further from onset (ζ = 0.01 above)."""
    scene = [*HOPF, "model.zeta=0.0165", "time.end=600"]
    (state, eigenvalues), = barber.states(rodfem.scene.load("barber", scene))
    linear = 2.0 * math.pi / abs(barber.step_rate(eigenvalues[0], 0.001).imag)
    run = barber.run("barber", [*scene, *barber.at_rest(state, "1e-2*x")])
    distance = run.u_1 - state.u_1
    periods = [barber.period(run.t, distance, start, start + 50.0) for start in (500.0, 550.0)]
    assert periods[0] == pytest.approx(periods[1], rel=1e-5)  # the cycle, reached
    late = run.t >= 500.0
    assert np.all(run.p[late] > 0.2 * state.p)
    assert 1e-3 < barber.envelope(run.t, distance, 500.0, 600.0) < 0.8 * 0.1 * state.p  # ε p
    assert linear < periods[1] < 1.005 * linear
