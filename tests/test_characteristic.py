"""rodfem's growth rates and Hopf points against the exact characteristic equation of the
linearised continuous problem (tests/characteristic.py, independent of rodfem's discretisation).

rodfem's eigenvalues on P1 converge as h²: from three meshes h, h/2, h/4, Richardson's
R = (4λ_{h/4} − λ_{h/2})/3 and its error estimated as |R − R'|/15, R' = (4λ_{h/2} − λ_h)/3
(the h⁴ terms of the two differ by 16). The default profile checks 20/40/80 cells to 1e-4, the
full one 100/200/400 (dense QZ of 1200 unknowns, seconds a mesh) to 1e-6. Two unstable states
have eigenfunctions with a boundary layer at x = 1 (the elastic root r ≈ 107 and 466) that
400 cells do not resolve: there a P1 pencil of this file's own on 4000-16000 cells confirms the
exact root instead, and rodfem's values are checked to approach it.

Cost: the default profile about 5 s serially; the slow tests about 3 minutes (nine states'
spectra at 100, 200 and 400 cells, ten seconds each at 400).
"""

from __future__ import annotations

import math

import characteristic as ch
import numpy as np
import pytest
import scipy.sparse
import scipy.sparse.linalg

import rodfem.scene
from rodfem.model import steady
from rodfem.solver.spectrum import Spectra

SPECTRA = Spectra()

# docs/barber.md's hot rod against a cool obstacle: one steady state, a Hopf point in ζ
HOT = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
       "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
       "obstacle.epsilon=0.1", "model.zeta=0.01"]
RIGID = ["obstacle.kind=rigid"]
INVISCID = ["model.zeta=0"]
CONSISTENT = ["discretisation.mass=consistent"]


def state(overrides, index, cells=None):
    """(scene, Linearisation, Params) of the index-th steady state of barber with overrides."""
    extra = [f"mesh.cells={cells}"] if cells else []
    scene = rodfem.scene.load("barber", [*overrides, *extra])
    problem = steady.of_scene(scene)
    lin = problem.linearise(problem.states()[index])
    return scene, lin, ch.params_of(scene, lin)


_SPECTRA: dict[tuple, np.ndarray] = {}  # several cases read one state's spectrum


def spectrum(overrides, index, cells):
    """rodfem's eigenvalues of the state on ``cells`` cells."""
    key = (tuple(overrides), index, cells)
    if key not in _SPECTRA:
        scene, lin, _ = state(overrides, index, cells)
        _SPECTRA[key] = SPECTRA.eigenvalues(scene, lin)
    return _SPECTRA[key]


def discrete(overrides, index, cells, target):
    """rodfem's eigenvalue nearest ``target`` on each mesh."""
    found = []
    for n in cells:
        values = spectrum(overrides, index, n)
        found.append(values[np.argmin(np.abs(values - target))])
    return np.array(found)


def richardson(values):
    """(R, its estimated error) from the values on h, h/2, h/4."""
    coarse = (4.0 * values[1] - values[0]) / 3.0
    fine = (4.0 * values[2] - values[1]) / 3.0
    return fine, abs(fine - coarse) / 15.0


# (name, overrides, state index, the exact eigenvalue: tests/characteristic.py's FOUND)
CASES = [
    ("separated", [], 0, "barber separated"),
    ("unstable", [], 1, "barber unstable"),
    ("pressed", [], 2, "barber pressed, isolated"),
    ("pressed pair", [], 2, "barber pressed, pair"),
    ("hot rod", HOT, 0, "hot rod, ζ = 0.01"),
    ("hot rod first", HOT, 0, "hot rod, first vibration"),
    ("rigid k1=60", [*RIGID, "heat_exchange.k1=60"], 1, "rigid k1 = 60, unstable"),
    ("rigid pair", RIGID, 1, "rigid, pair"),
    ("ζ = 0 pressed", INVISCID, 2, "ζ = 0, pressed"),
    ("ζ = 0 separated", INVISCID, 0, "ζ = 0, separated"),
    ("consistent", CONSISTENT, 1, "barber unstable"),
    ("consistent hot rod", [*HOT, *CONSISTENT], 0, "hot rod, ζ = 0.01"),
]
IDS = [case[0] for case in CASES]


@pytest.mark.parametrize("name, overrides, index, key", CASES, ids=IDS)
def test_exact_roots_are_reproduced(name, overrides, index, key):
    """Newton on D from 1 % off finds the recorded root to 1e-12, and D's two forms agree."""
    _, _, p = state(overrides, index)
    exact = ch.FOUND[key]
    assert ch.root(exact * (1 + 0.01j) if exact.imag else exact * 1.01, p) == pytest.approx(
        exact, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("name, overrides, index, key", CASES, ids=IDS)
def test_rodfem_converges_to_the_exact_eigenvalues_on_coarse_meshes(name, overrides, index, key):
    """20/40/80 cells, extrapolated: 1e-4 of |λ|, within the extrapolation's own estimate."""
    exact = ch.FOUND[key]
    found = discrete(overrides, index, (20, 40, 80), exact)
    value, estimate = richardson(found)
    assert abs(value - exact) <= max(2.0 * estimate, 1e-9 * abs(exact)), (found, exact)
    assert abs(value - exact) <= 1e-4 * abs(exact), (found, exact)


@pytest.mark.slow
@pytest.mark.parametrize("name, overrides, index, key", CASES, ids=IDS)
def test_rodfem_converges_to_the_exact_eigenvalues(name, overrides, index, key):
    """100/200/400 cells, extrapolated: 1e-6 of |λ|; the meshes' own errors fall as h²."""
    exact = ch.FOUND[key]
    found = discrete(overrides, index, (100, 200, 400), exact)
    value, estimate = richardson(found)
    assert abs(value - exact) <= max(2.0 * estimate, 1e-10 * abs(exact)), (found, exact)
    assert abs(value - exact) <= 1e-6 * abs(exact), (found, exact)
    errors = np.abs(found - exact)
    assert errors[1] / errors[2] == pytest.approx(4.0, rel=0.05)


def test_the_pressed_states_growth_rate_is_the_kelvin_voigt_accumulation():
    """The pressed state's rightmost discrete eigenvalues are the mesh's shortest waves, one
    more each refinement, below the accumulation point −1/ζ of the exact spectrum (D's pole):
    their top extrapolates to −1/ζ."""
    _, _, p = state([], 2)
    tops = [spectrum([], 2, n)[0] for n in (20, 40, 80)]
    value, estimate = richardson(np.array(tops))
    assert np.all(np.array(tops).real < -1.0 / p.zeta)
    assert abs(value + 1.0 / p.zeta) <= max(2.0 * estimate, 1e-9), tops


def test_hopf_point_of_the_hot_rod():
    """The hot rod's critical pair crosses the imaginary axis at the recorded ζ and ω (an
    earlier independent check: ζ = 0.018371, ω = 5.91677, period 1.06193), whichever bracket
    Brent's method starts from; left of it the pair is unstable, right of it stable; rodfem's
    Re λ there (20/40/80 cells, extrapolated) vanishes to 1e-4 of |λ|."""
    _, _, p = state(HOT, 0)
    guess = ch.FOUND["hot rod, ζ = 0.01"]
    found = ch.hopf(p.with_zeta, 0.01, 0.03, guess)
    again = ch.hopf(p.with_zeta, 0.015, 0.02, guess)
    assert found.zeta == pytest.approx(ch.FOUND["hot rod Hopf ζ"], rel=1e-12)
    assert found.omega == pytest.approx(ch.FOUND["hot rod Hopf ω"], rel=1e-12)
    assert again.zeta == pytest.approx(found.zeta, rel=1e-12)
    assert round(found.zeta, 6) == 0.018371
    assert round(found.omega, 5) == 5.91677
    assert round(found.period, 5) == 1.06193
    below = ch.root(guess, p.with_zeta(found.zeta * (1 - 1e-3)))
    above = ch.root(guess, p.with_zeta(found.zeta * (1 + 1e-3)))
    assert below.real > 0 > above.real
    critical = ch.root(guess, p.with_zeta(found.zeta))
    values = discrete([*HOT[:-1], f"model.zeta={found.zeta!r}"], 0, (20, 40, 80), critical)
    value, estimate = richardson(values)
    assert abs(value - critical) <= max(2.0 * estimate, 1e-4 * abs(critical)), values
    assert abs(value.real) <= 1e-4 * abs(critical)


def test_no_root_is_missed_near_the_hot_rods_critical_pair():
    """The argument principle counts the roots of D in a box holding the critical pair and the
    next four: as many as Newton finds from rodfem's 80-cell eigenvalues."""
    _, _, p = state(HOT, 0)
    values = spectrum(HOT, 0, 80)
    box = (-1.0, 10.0, -16.0, 16.0)
    inside = values[(values.real > box[0]) & (np.abs(values.imag) < box[3])]
    found = ch.rightmost(p, inside)
    assert ch.count(p, box, points=600) == len(found) == 10
    assert ch.count(p, (0.0, 1.0, 5.0, 7.0), points=200) == 1  # the critical root alone
    assert found[0] == pytest.approx(ch.FOUND["hot rod, ζ = 0.01"], rel=1e-12)


def test_the_two_forms_of_d_agree():
    """The eigenbasis form and the expm form of D agree where expm's cancellation,
    e^{|Re(r₁ − r₂)|}, is small; where it is not, expm's is the one that is off."""
    _, _, p = state(HOT, 0)
    for lam in (0.3 - 0.5j, 1 + 2j, 2 + 1j, 3.0, -1 + 5j, 5 + 6j, -0.5 + 10j):
        nus, _ = ch.modes(lam, p)
        loss = math.exp(abs(abs(nus[0].real) - abs(nus[2].real)))
        assert loss < 1e4
        assert ch.D(lam, p, "modes") == pytest.approx(ch.D(lam, p, "expm"), rel=1e-13 * loss)
    lam = 50 + 30j  # r ≈ 50 and 7.6: expm's D cancels 18 digits
    exact = _mp_D(p, lam, 60)
    assert ch.D(lam, p, "modes") == pytest.approx(exact, rel=1e-12)
    assert ch.D(lam, p, "expm") != pytest.approx(exact, rel=1e-4)


def _mp_determinant(p, lam):
    """D written with no scaling at all, det[[e₁ᵀ], [e₃ᵀ], [R exp A(λ)]], in mpmath."""
    mp = pytest.importorskip("mpmath")
    R = ch.conditions(p)
    z = 1 + p.zeta * lam
    A = mp.matrix([[0, 1, 0, 0], [lam * (1 + p.a ** 2 / z), 0, 0, p.a * lam / z],
                   [p.a / z, 0, 0, 1 / z], [0, 0, p.b * lam * lam, 0]])
    Phi = mp.expm(A)
    rows = [[1, 0, 0, 0], [0, 0, 1, 0]] + [
        [sum(mp.mpc(R[i, k]) * Phi[k, j] for k in range(4)) for j in range(4)]
        for i in range(2)]
    return mp.det(mp.matrix(rows))


def _mp_D(p, lam, digits):
    """D(λ) at ``digits`` digits, unscaled, as a complex."""
    mp = pytest.importorskip("mpmath")
    with mp.workdps(digits):
        return complex(_mp_determinant(p, mp.mpc(lam)))


def _mp_root(p, guess, digits):
    """The root of the unscaled D (:func:`_mp_determinant`) in mpmath at ``digits`` digits
    (enough to carry its cancellation), from ``guess``."""
    mp = pytest.importorskip("mpmath")
    with mp.workdps(digits):
        return complex(mp.findroot(lambda lam: _mp_determinant(p, lam), mp.mpc(guess),
                                   tol=mp.mpf(10) ** (-30)))


@pytest.mark.parametrize("overrides, index, key, digits", [
    (RIGID, 1, "rigid, unstable", 80),          # D cancels e^{r₂ − r₁} = e^{31}
    (INVISCID, 1, "ζ = 0, unstable", 250),      # e^{444}
    (HOT, 0, "hot rod, ζ = 0.01", 40),
], ids=["rigid", "ζ = 0", "hot rod"])
def test_roots_against_unscaled_high_precision(overrides, index, key, digits):
    _, _, p = state(overrides, index)
    exact = ch.FOUND[key]
    assert _mp_root(p, exact, digits) == pytest.approx(exact, rel=1e-13)
    assert ch.root(exact, p) == pytest.approx(exact, rel=1e-13)


def pencil_p1(p: ch.Params, cells: int):
    """(A, B) of this file's own P1 discretisation, lumped mass, sparse (rows and columns:
    Θ, U, V at the nodes x_1 … x_N; held: U and V of x_N left out)."""
    n, h = cells, 1.0 / cells
    ones = np.ones(n)
    K = scipy.sparse.diags([-ones[1:] / h, np.r_[2 * ones[:-1], 1.0] / h, -ones[1:] / h],
                           [-1, 0, 1], format="csr")
    G = scipy.sparse.diags([-0.5 * ones[1:], np.r_[np.zeros(n - 1), 0.5], 0.5 * ones[1:]],
                           [-1, 0, 1], format="csr")  # (η_j', η_i)
    M = np.r_[h * ones[:-1], h / 2]
    E = scipy.sparse.csr_matrix(([1.0], ([n - 1], [n - 1])), shape=(n, n))
    Z, One = scipy.sparse.csr_matrix((n, n)), scipy.sparse.identity(n, format="csr")
    heat = [-K - p.h * E, -p.c_u * E, -p.a * G]
    if p.held:  # −c_p p̃ in the heat row of x_N, p̃ = −(K U + ζ K V − a Gᵀ Θ)(x_N)
        heat = [heat[0] - p.c_p * p.a * E @ G.T, heat[1] + p.c_p * E @ K,
                heat[2] + p.c_p * p.zeta * E @ K]
    A = scipy.sparse.bmat([heat, [Z, Z, One], [p.a * G.T, -K - p.kappa * E, -p.zeta * K]],
                          format="csc")
    B = np.r_[M, ones, p.b * M]
    if p.held:
        keep = np.setdiff1d(np.arange(3 * n), [2 * n - 1, 3 * n - 1])
        A, B = A[keep][:, keep], B[keep]
    return A, B


def p1_eigenvalue(p: ch.Params, cells: int, sigma: complex) -> complex:
    """The eigenvalue of pencil_p1 nearest sigma: inverse iteration with A − σB (sparse LU),
    the Rayleigh quotient of B⁻¹A (σ close: each step gains |λ − σ|/|λ' − σ|)."""
    A, B = pencil_p1(p, cells)
    sigma = complex(sigma)
    dtype = complex if sigma.imag else float
    shift = sigma if sigma.imag else sigma.real
    lu = scipy.sparse.linalg.splu((A - shift * scipy.sparse.diags(B)).astype(dtype).tocsc())
    x = np.ones(A.shape[0], dtype=dtype)
    value = sigma
    for _ in range(50):
        y = lu.solve(B * x)
        x = y / np.linalg.norm(y)
        last, value = value, complex(np.vdot(x, A @ x / B) / np.vdot(x, x))
        if abs(value - last) <= 1e-14 * abs(value):
            break
    return value


@pytest.mark.parametrize("overrides, index, key, at_100", [
    (RIGID, 1, "rigid, unstable", 4875.575),
    (INVISCID, 1, "ζ = 0, unstable", 305.369),
], ids=["rigid", "ζ = 0"])
def test_boundary_layer_states(overrides, index, key, at_100):
    """Two unstable states whose eigenfunction has a boundary layer at x = 1: a P1 pencil of
    this file's own on 4000/8000/16000 cells extrapolates to the exact root to 1e-6 (its
    100-cell value is rodfem's to 1e-9, the same scheme), while rodfem at its 100 cells is
    off by 14 % (rigid) and 34 % (ζ = 0)."""
    exact = ch.FOUND[key]
    _, _, p = state(overrides, index)
    found = np.array([p1_eigenvalue(p, n, exact) for n in (4000, 8000, 16000)])
    value, estimate = richardson(found)
    assert abs(value - exact) <= max(2.0 * estimate, 1e-10 * abs(exact)), (found, exact)
    assert abs(value - exact) <= 1e-6 * abs(exact), (found, exact)
    ours = p1_eigenvalue(p, 100, at_100)
    rodfems = spectrum(overrides, index, 100)[0]
    assert ours == pytest.approx(rodfems, rel=1e-9)
    assert rodfems.real == pytest.approx(at_100, abs=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("overrides, index, key", [
    (RIGID, 1, "rigid, unstable"), (INVISCID, 1, "ζ = 0, unstable")], ids=["rigid", "ζ = 0"])
def test_boundary_layer_states_converge_in_rodfem(overrides, index, key):
    """rodfem at 100/200/400 cells approaches the exact root from below, its error falling
    ever faster towards h²'s factor 4 as the mesh begins to resolve the layer."""
    exact = ch.FOUND[key]
    found = discrete(overrides, index, (100, 200, 400), exact)
    errors = exact - found.real
    assert np.all(errors > 0) and errors[0] > errors[1] > errors[2]
    assert 1.5 < errors[0] / errors[1] < errors[1] / errors[2] < 4.0
