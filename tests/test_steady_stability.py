"""The stability of steady states (rodfem.solver.spectrum) against the exact linear stability of
the continuous problem, derived here.

A perturbation e^{λt}(θ̃, ũ)(x) of a steady state obeys λθ̃ = θ̃'' − aλũ', bλ²ũ = σ̃',
σ̃ = (1 + ζλ)ũ' − aθ̃: for y = (θ̃, θ̃', ũ, σ̃) the linear ODE y' = A(λ) y with

    A(λ) = [[0, 1, 0, 0], [λ + a²λ/z, 0, 0, aλ/z], [a/z, 0, 0, 1/z], [0, 0, bλ², 0]],
    z = 1 + ζλ.

θ̃(0) = ũ(0) = 0 leaves the solutions expm(x A) e₂ and expm(x A) e₄; at x = 1 the exchange
−θ̃'(1) = h θ̃(1) + c_u ũ(1) and the contact σ̃(1) = −κ ũ(1) (against the rigid obstacle in
contact: ũ(1) = 0 and −θ̃'(1) = h θ̃(1) + c_p p̃, p̃ = −σ̃(1)). λ is an eigenvalue where
D(λ) = det(R expm(A(λ))[:, (e₂, e₄)]) vanishes, R the two rows of those conditions. The discrete
eigenvalue on P1 converges as h²: extrapolated from two meshes (Richardson) it must agree with the
root of D to 1e-6.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

import rodfem.scene
from conftest import representative
from rodfem.model import steady
from rodfem.solver.spectrum import Spectra

SPECTRA = Spectra()


def characteristic(lam, a, b, zeta, lin):
    z = 1.0 + zeta * lam
    A = np.array([[0, 1, 0, 0], [lam + a * a * lam / z, 0, 0, a * lam / z],
                  [a / z, 0, 0, 1 / z], [0, 0, b * lam * lam, 0]], dtype=complex)
    Y = scipy.linalg.expm(A)[:, [1, 3]]
    if lin.held:
        R = np.array([[lin.h, 1.0, 0.0, -lin.exchange_p], [0.0, 0.0, 1.0, 0.0]])
    else:
        R = np.array([[lin.h, 1.0, lin.exchange_u, 0.0], [0.0, 0.0, lin.kappa, 1.0]])
    return np.linalg.det(R @ Y)


def exact_root(guess, a, b, zeta, lin):
    return scipy.optimize.newton(lambda lam: characteristic(lam, a, b, zeta, lin), guess,
                                 tol=1e-13, maxiter=100)


def leading(values):
    """The eigenvalue of largest real part (of a complex pair, the one above the axis)."""
    top = values[0].real
    near = values[np.abs(values.real - top) <= 1e-9 * max(1.0, abs(top))]
    return near[np.argmax(near.imag)]


def compare(name, overrides, index, cells=(200, 400)):
    """(Richardson's extrapolation of the leading eigenvalue of the index-th state from two
    meshes, the exact root of D near it, the two meshes' values)."""
    scenes = [rodfem.scene.load(name, [*overrides, f"mesh.cells={n}"]) for n in cells]
    problem = steady.of_scene(scenes[0])
    lin = problem.linearise(problem.states()[index])
    found = [leading(SPECTRA.eigenvalues(scene, lin)) for scene in scenes]
    extrapolated = (4.0 * found[1] - found[0]) / 3.0
    s = scenes[0]
    exact = exact_root(extrapolated, s["model.a"], s["model.b"], s["model.zeta"], lin)
    return extrapolated, exact, found


BARBER = ["heat_exchange.k1=100"]


GROWTH = [
    (BARBER, 1, True),  # the unstable contact state: a real eigenvalue
    (BARBER, 0, False),  # the separated state: a damped oscillation
    (["heat_exchange.law=gap", "heat_exchange.k1=100", "heat_exchange.length=0.001"], 1, True),
    (["discretisation.mass=consistent", *BARBER], 1, True),
    (["model.b=0", *BARBER], 1, True),  # quasi-static: B singular, infinite eigenvalues left out
    (["obstacle.kind=rigid", "heat_exchange.k1=60"], 1, True),  # the reaction in the exchange
]


@pytest.mark.parametrize("overrides, index, real",
                         representative(GROWTH, [GROWTH[0], GROWTH[1], GROWTH[4]]))
def test_growth_rate_is_the_exact_one(overrides, index, real):
    extrapolated, exact, found = compare("barber", overrides, index)
    assert abs(exact.imag) < 1e-9 if real else exact.imag > 0.1
    assert abs(extrapolated - exact) < 1e-6, (extrapolated, exact, found)
    # the meshes' own errors are h² ones: the extrapolation is what makes it 1e-6
    assert abs(found[0] - exact) / abs(found[1] - exact) == pytest.approx(4.0, rel=0.05)


def test_barber_states_stability():
    scene = rodfem.scene.load("barber", [])
    problem = steady.of_scene(scene)
    rates = [SPECTRA.growth_rate(scene, problem.linearise(s)) for s in problem.states()]
    assert rates[0] < 0 < rates[1] and rates[2] < 0


def test_growth_rate_crosses_zero_at_a_fold():
    """Near the fold where the unstable and the pressed branches meet (θ_O from the vanishing
    discriminant of the contact states' quadratic, tests/test_steady.py), their growth rates are
    real eigenvalues of opposite signs that vanish as the square root of the distance. (With
    barber's ζ = 0.5 a complex pair makes the pressed branch unstable just above the fold; ζ = 1
    keeps it stable.)"""
    a, k, k1, gap, epsilon = 0.017, 0.1, 1000.0, 0.02, 0.01
    alpha, beta = 2.0 * (1.0 + epsilon) / a, 2.0 * gap / a

    def disc(theta_O):
        B = alpha * (1.0 + k) + beta * k1 - k1 * theta_O
        return B * B - 4.0 * alpha * k1 * (beta * (1.0 + k) - k * theta_O)

    fold = scipy.optimize.brentq(disc, 3.0, 5.0, xtol=1e-15)
    rates = []
    for delta in (1e-5, 1e-7):
        scene = rodfem.scene.load("barber", [f"obstacle.temperature={fold * (1 + delta)!r}",
                                             "model.zeta=1"])
        problem = steady.of_scene(scene)
        states = problem.states()
        assert len(states) == 3
        rates.append([SPECTRA.growth_rate(scene, problem.linearise(s)) for s in states[1:]])
    (middle_far, upper_far), (middle_near, upper_near) = rates
    assert middle_near > 0 > upper_near
    assert middle_far / middle_near == pytest.approx(10.0, rel=0.05)
    assert upper_far / upper_near == pytest.approx(10.0, rel=0.05)
