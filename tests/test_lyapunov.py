"""The first Lyapunov coefficient at a Hopf point (rodfem.solver.lyapunov): a textbook system's
value to round-off, the rod's second and third derivatives against differences of its laws, and
Barber's hot rod's supercritical Hopf point against the periodic orbits shooting finds."""

import math

import numpy as np
import pytest
from mpi4py import MPI

import rodfem
import rodfem.scene
from rodfem.model import steady as ms
from rodfem.model.expansion import expand
from rodfem.solver import lyapunov as ly
from rodfem.solver.spectrum import Spectra
from rodfem.studies.steady import continuation as ct
from rodfem.studies.steady import points as pt

EPS = np.finfo(float).eps
HOT = ["model.theta_A=10", "initial.theta0=10", "obstacle.temperature=0",
       "heat_exchange.k1=1000", "heat_exchange.exponent=2", "obstacle.gap=0.11",
       "obstacle.epsilon=0.1"]


# -- a textbook system --------------------------------------------------------------------------

def _polynomial(c):
    """f = c0 x² + c1 xy + c2 y² + c3 x³ + c4 x²y + c5 xy² + c6 y³: its second derivatives
    (xx, xy, yy) and third (xxx, xxy, xyy, yyy)."""
    return (2 * c[0], c[1], 2 * c[2]), (6 * c[3], 2 * c[4], 2 * c[5], 6 * c[6])


def _forms(c):
    (xx, xy, yy), (xxx, xxy, xyy, yyy) = _polynomial(c)

    def B(x, y):
        return xx * x[0] * y[0] + xy * (x[0] * y[1] + x[1] * y[0]) + yy * x[1] * y[1]

    def C(x, y, z):
        return (xxx * x[0] * y[0] * z[0]
                + xxy * (x[0] * y[0] * z[1] + x[0] * y[1] * z[0] + x[1] * y[0] * z[0])
                + xyy * (x[0] * y[1] * z[1] + x[1] * y[0] * z[1] + x[1] * y[1] * z[0])
                + yyy * x[1] * y[1] * z[1])
    return B, C


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_planar_system_has_the_textbook_coefficient(seed):
    """ẋ = −ωy + f(x, y), ẏ = ωx + g(x, y): Guckenheimer and Holmes's (3.4.11) gives the cubic
    coefficient a of ṙ = a r³ for the amplitude r of x; q normalised by x (x's component 1/2)
    makes l₁ = a/ω. The same system multiplied by a regular M, M ẋ = M F(x), has the same l₁."""
    rng = np.random.default_rng(seed)
    omega = 0.5 + 2.0 * rng.random()
    cf, cg = rng.standard_normal(7), rng.standard_normal(7)
    (fxx, fxy, fyy), (fxxx, _, fxyy, _) = _polynomial(cf)
    (gxx, gxy, gyy), (_, gxxy, _, gyyy) = _polynomial(cg)
    a = ((fxxx + fxyy + gxxy + gyyy) / 16.0
         + (fxy * (fxx + fyy) - gxy * (gxx + gyy) - fxx * gxx + fyy * gyy) / (16.0 * omega))
    Bf, Cf = _forms(cf)
    Bg, Cg = _forms(cg)

    def B(x, y):
        return np.array([Bf(x, y), Bg(x, y)])

    def C(x, y, z):
        return np.array([Cf(x, y, z), Cg(x, y, z)])

    A = np.array([[0.0, -omega], [omega, 0.0]])
    found = ly.coefficient(A, np.eye(2), 1j * omega, B, C, 0)
    assert abs(found.value - a / omega) <= found.error
    assert 0.0 < found.error < 1e3 * EPS * abs(found.value)
    M = rng.standard_normal((2, 2)) + 3.0 * np.eye(2)
    again = ly.coefficient(M @ A, M, 1j * omega, lambda x, y: M @ B(x, y),
                           lambda x, y, z: M @ C(x, y, z), 0)
    assert abs(again.value - a / omega) <= again.error
    assert again.criticality == ("supercritical" if a < 0.0 else "subcritical")


def test_the_normal_form_has_its_own_coefficient():
    """ż = iω z + c |z|² z in x = Re z, y = Im z: l₁ = Re c/ω, with the third derivatives
    alone (no quadratic terms); Re c = 0 is degenerate."""
    omega = 1.3
    for c in (-0.7 + 0.4j, 0.25 - 2.0j, 0.0 + 1.0j):
        # c |z|² z = (cr + i ci)(x² + y²)(x + i y): f = (x² + y²)(cr x − ci y), g = (…)(ci x + cr y)
        cf = [0, 0, 0, c.real, -c.imag, c.real, -c.imag]
        cg = [0, 0, 0, c.imag, c.real, c.imag, c.real]
        Bf, Cf = _forms(cf)
        Bg, Cg = _forms(cg)
        found = ly.coefficient(np.array([[0.0, -omega], [omega, 0.0]]), np.eye(2), 1j * omega,
                               lambda x, y: np.array([Bf(x, y), Bg(x, y)]),
                               lambda x, y, z: np.array([Cf(x, y, z), Cg(x, y, z)]), 0)
        assert abs(found.value - c.real / omega) <= found.error
        if c.real == 0.0:
            assert found.criticality == "degenerate"


# -- the rod's derivatives ----------------------------------------------------------------------

ENDS = {  # scenes whose end expands through each law's derivatives, and which of their states
    "pressure m=2, linear": ([*HOT], 0),
    "pressure m=1.5, power m=1.7": ([*HOT, "heat_exchange.exponent=1.5", "obstacle.law=power",
                                     "obstacle.exponent=1.7", "obstacle.epsilon=0.5"], 0),
    "gap, separated": (["heat_exchange.law=gap", "heat_exchange.k1=2",
                        "heat_exchange.length=0.01", "obstacle.gap=0.05"], 1),
}


def _end_laws(problem, state):
    """The heat row's −h(u)(θ − θ_O) and the momentum row's −P(u) at x = 1, from the laws'
    values alone (no derivative of them)."""
    obstacle, exchange, g = problem.obstacle, problem.exchange, problem.gap

    def force(u):
        return obstacle.pressure(u - g) if not obstacle.rigid else 0.0

    def heat(theta, u):
        return -(exchange.k + exchange.extra_at(g, u - g, force(u))) * (
            theta - exchange.temperature)
    return heat, force


@pytest.mark.parametrize("name", list(ENDS))
def test_the_ends_derivatives_are_differences_of_its_laws(name):
    """B and C of the rod's f (rodfem.solver.lyapunov.end_forms) against central differences of
    f = A₀ x + the end's laws (A₀ the pencil without the end's linear terms), on 4 cells: the
    first differences give the pencil's A back (the laws sit in the rows the spectra linearise),
    the second and third B and C. Richardson's extrapolation of steps δ = e/50 and δ/2 (e the
    penetration or gap, the laws' scale) leaves O((δ/e)⁴) ≈ 1e-7 of truncation; measured:
    1e-13–1e-10 for B, 1e-8 for C (its round-off eps |f|/δ³ dominates)."""
    overrides, which = ENDS[name]
    scene = rodfem.scene.load("barber", [*overrides, "mesh.cells=4"])
    problem = ms.of_scene(scene)
    state = problem.states()[which]
    lin = problem.linearise(state)
    expansion = expand(problem, state)
    assert not expansion.held
    A, M = Spectra(MPI.COMM_SELF).pencil(scene, lin)
    n = A.shape[0] // 3
    theta, u, heat_row, force_row = ly.end_indices(n, False)
    A0 = A.copy()
    A0[heat_row, theta] += lin.h
    A0[heat_row, u] += lin.exchange_u
    A0[force_row, u] += lin.kappa
    heat, force = _end_laws(problem, state)
    x_theta, x_u = state.theta_1, state.u_1
    base_h, base_m = heat(x_theta, x_u), -force(x_u)

    def f(xi):  # f(x* + ξ) − f(x*)
        out = A0 @ xi
        out[heat_row] += heat(x_theta + xi[theta], x_u + xi[u]) - base_h
        out[force_row] += -force(x_u + xi[u]) - base_m
        return out

    e = abs(state.offset) if state.offset != 0.0 else abs(state.p)
    rng = np.random.default_rng(5)
    x, y, z = (rng.standard_normal(A.shape[0]) for _ in range(3))
    for v in (x, y, z):
        v[theta] *= 100.0  # θ varies as 100 × u does about these states

    def differences(d):
        jac = (f(d * x) - f(-d * x)) / (2 * d)
        second = sum(s * t * f(d * (s * x + t * y)) for s in (1, -1) for t in (1, -1)) / (4 * d * d)
        third = sum(s * t * r * f(d * (s * x + t * y + r * z)) for s in (1, -1) for t in (1, -1)
                    for r in (1, -1)) / (8 * d ** 3)
        return jac, second, third

    d = e / 50.0
    coarse, fine = differences(d), differences(d / 2)
    jac, second, third = ((4 * b - a) / 3 for a, b in zip(coarse, fine))
    B, C = ly.end_forms(expansion, theta, u, heat_row, force_row, A.shape[0])
    scale = np.linalg.norm(A @ x, np.inf)
    assert np.linalg.norm(jac - A @ x, np.inf) <= 1e-7 * scale
    expect_B, expect_C = B(x, y).real, C(x, y, z).real
    assert np.linalg.norm(expect_B) > 0.0 and np.linalg.norm(expect_C) > 0.0
    assert np.allclose(second, expect_B, rtol=0.0, atol=1e-7 * np.abs(expect_B).max())
    assert np.allclose(third, expect_C, rtol=0.0, atol=1e-7 * np.abs(expect_C).max())
    # the expansion's first order is the linearisation's
    assert expansion.h[0] == pytest.approx(lin.h, rel=4 * EPS)
    assert expansion.jump * expansion.h[1] == pytest.approx(lin.exchange_u, rel=4 * EPS)
    assert expansion.force[1] == pytest.approx(lin.kappa, rel=4 * EPS)


def test_a_separated_end_under_the_pressure_law_is_degenerate():
    """Separated, the pressure law adds nothing and the contact pushes nothing: f is linear
    about the state, so B = C = 0 and l₁ = 0, degenerate whatever q and p are."""
    scene = rodfem.scene.load("barber", ["mesh.cells=4"])
    problem = ms.of_scene(scene)
    state = problem.states()[0]
    assert not state.contact
    expansion = expand(problem, state)
    assert expansion.h[1:] == (0.0, 0.0, 0.0) and expansion.force == (0.0, 0.0, 0.0, 0.0)
    A, M = Spectra(MPI.COMM_SELF).pencil(scene, problem.linearise(state))
    top = pt.eigenvalues(Spectra(MPI.COMM_SELF), scene, problem.linearise(state))
    pair = top[np.argmax(top.imag > 0)]
    found = ly.of_rod(A, M, complex(0.0, pair.imag), expansion, A.shape[0] // 3, False)
    assert found.value == 0.0 and found.criticality == "degenerate"


# -- Barber's hot rod: the orbits born at its Hopf point -------------------------------------------

def _hopf(overrides, key: str, lo: float, hi: float, which: int = 0):
    """A scene's ``which``-th Hopf point over ``key`` in [lo, hi], its Spectral and its l₁."""
    scene = rodfem.scene.load("barber", overrides)
    curve = ct.Curve(scene, key, lo, hi)
    spectral = pt.Spectral(curve, Spectra(MPI.COMM_SELF))
    found = []
    for branch in ct.branches(scene, key, lo, hi):
        tests = [spectral.test(p) for p in branch]
        found += [spectral.hopf(branch[i], branch[i + 1]) for i in range(len(branch) - 1)
                  if (tests[i] < 0.0) != (tests[i + 1] < 0.0)]
    hopf = [h for h in found if h is not None][which]
    return scene, spectral, hopf, spectral.lyapunov(hopf)


def test_the_diagram_gives_each_hopf_point_its_criticality():
    """points.csv's rows: the hot rod's Hopf point supercritical with l₁ and its error, the
    barber diagram's other kinds without."""
    scene = rodfem.scene.load("barber", [*HOT, "mesh.cells=20"])
    found = rodfem.bifurcation(scene, "model.zeta", 0.005, 0.04)
    (row,) = [p for p in found["points"] if p["kind"] == "hopf"]
    assert row["criticality"] == "supercritical"
    assert row["lyapunov"] < -row["lyapunov_error"] < 0.0
    scene = rodfem.scene.load("barber", ["mesh.cells=10"])
    found = rodfem.bifurcation(scene, "obstacle.temperature", 0.0, 30.0)
    for row in found["points"]:
        if row["kind"] != "hopf":
            assert row["criticality"] == "" and math.isnan(row["lyapunov"])


def _orbit_near(overrides, spectral, hopf, lyap, key: str, delta: float, dt: float):
    """The orbit of the Crank–Nicolson scheme (whose onset is the flow's: it grows exactly where
    Re λ > 0) at ``key`` = λ_H + delta, Newton started from the prediction x* + z q + c.c. with
    |z|² = |Re λ′ (λ − λ_H)/(ω l₁)| (NoOrbit where it finds none), its first harmonic of u(1),
    the prediction |z| and the slope Re λ′."""
    import scipy.linalg

    from rodfem.studies.steady import orbit as po
    from rodfem.studies.steady import periodic as pd
    from rodfem.studies.steady.barber import at_rest

    scene = rodfem.scene.load("barber", overrides)
    spectra, value_H, omega = spectral.spectra, hopf.point.value, hopf.omega
    u_H = spectral.state(hopf.point)[1].u_1

    def pair(value):
        at = ct.at(scene, key, value)
        problem = ms.of_scene(at)
        state = min(problem.states(), key=lambda s: abs(s.u_1 - u_H))
        A, M = spectra.pencil(at, problem.linearise(state))
        values, vectors = scipy.linalg.eig(A, M)
        k = int(np.argmin(np.abs(values - 1j * omega)))
        return at, state, values[k], vectors[:, k]

    step = 1e-6 * max(abs(value_H), 1.0) * 0.1
    slope = (pair(value_H + step)[2].real - pair(value_H - step)[2].real) / (2 * step)
    at, state, value, q = pair(value_H + delta)
    n = q.size // 3
    q = q * (0.5 / q[2 * n - 1])
    predicted = math.sqrt(abs(slope * delta / (omega * lyap.value)))
    rest = rodfem.scene.load("barber", [*overrides, f"{key}={value_H + delta!r}",
                                        "time.scheme=crank-nicolson", "solver.method=direct",
                                        f"time.dt={dt}", *at_rest(state, "0")])
    flow = pd.flow_of(rest, MPI.COMM_SELF)
    assert flow.nodes == n + 1 and flow.method.disc.nodes.x[0] == 0.0
    # the pencil's (Θ, U, V) off x = 0 into the flow's [Θ; V; U] with x = 0 first
    kick = 2.0 * (-1j * predicted * q).real  # u(1) = u* at the start, rising
    x = flow.initial()
    x[1:n + 1] += kick[:n]
    x[n + 2:2 * n + 2] += kick[2 * n:]
    x[2 * n + 3:] += kick[n:2 * n]
    orbit = po.find(flow, rest, float(state.u_1), x, 2 * math.pi / value.imag, MPI.COMM_SELF)
    record = po.trace(flow, rest, orbit)
    u, t = record["u_1"][:-1] - state.u_1, record["t"][:-1]
    harmonic = abs(2.0 * np.mean(u * np.exp(-2j * math.pi * t / orbit.period)))
    return orbit, harmonic, predicted, slope


HOT_ZETA = ("model.zeta", 0.005, 0.04)


def test_the_hot_rods_orbits_are_born_supercritical():
    """20 cells, Δt = 0.002: l₁ < 0, and on the unstable side (ζ_H − 1e-5, Re λ > 0)
    Crank–Nicolson's orbit is stable with the first harmonic of u(1) the prediction
    √(−Re λ′ Δζ/(ω l₁)) (squared: 0.997 of it, its O(Δζ) correction measured as −0.3 % at
    1e-5 and −1.2 % at 4e-5); on the stable side (ζ_H + 1e-5) Newton from the same prediction
    finds no orbit, the state itself."""
    from rodfem.studies.steady.orbit import NoOrbit

    overrides = [*HOT, "mesh.cells=20"]
    _, spectral, hopf, lyap = _hopf(overrides, *HOT_ZETA)
    assert lyap.criticality == "supercritical"
    orbit, harmonic, predicted, slope = _orbit_near(overrides, spectral, hopf, lyap, "model.zeta",
                                                    -1e-5, 0.002)
    assert slope < 0.0  # damping stabilises: the state is unstable below ζ_H
    assert orbit.stable is True
    assert (harmonic / predicted) ** 2 == pytest.approx(1.0, abs=0.01)
    with pytest.raises(NoOrbit, match="steady state"):
        _orbit_near(overrides, spectral, hopf, lyap, "model.zeta", 1e-5, 0.002)


@pytest.mark.slow
def test_the_amplitudes_leading_coefficient_is_l1s():
    """80 cells (the docs' mesh): (a/a_predicted)² at Δζ = 4e-5 and 1e-5, linear in Δζ,
    extrapolates to 1 within 0.2 %; and the sparse path's l₁ is the dense one's."""
    overrides = [*HOT, "mesh.cells=80"]
    _, spectral, hopf, lyap = _hopf(overrides, *HOT_ZETA)
    ratios = []
    for delta in (-4e-5, -1e-5):
        orbit, harmonic, predicted, _ = _orbit_near(overrides, spectral, hopf, lyap, "model.zeta",
                                                    delta, 0.001)
        assert orbit.stable is True
        ratios.append((harmonic / predicted) ** 2)
    limit = ratios[1] + (ratios[1] - ratios[0]) / 3.0
    assert limit == pytest.approx(1.0, abs=2e-3)
    sparse = pt.Spectral(spectral.curve, Spectra(MPI.COMM_SELF, dense_cells=0)).lyapunov(hopf)
    assert abs(sparse.value - lyap.value) <= sparse.error + lyap.error


@pytest.mark.slow
def test_barbers_pressed_branch_loses_stability_subcritically():
    """The built-in barber (10 cells) over θ_O: its pressed branch's Hopf point near the fold
    is subcritical, l₁ > 0. Its orbits lie on the stable side (θ_O = θ_H + 1e-4, Re λ < 0),
    unstable (a Floquet multiplier 1.034 outside the unit circle), with the first harmonic of
    u(1) the prediction (squared: 0.9994 of it); on the unstable side Newton finds none."""
    from rodfem.studies.steady.orbit import NoOrbit

    overrides = ["mesh.cells=10"]
    _, spectral, hopf, lyap = _hopf(overrides, "obstacle.temperature", 0.0, 30.0, which=1)
    assert hopf.point.value == pytest.approx(3.51689748, abs=1e-8)
    assert lyap.criticality == "subcritical"
    orbit, harmonic, predicted, slope = _orbit_near(overrides, spectral, hopf, lyap,
                                                    "obstacle.temperature", 1e-4, 0.002)
    assert slope < 0.0  # the state is stable above θ_H
    assert orbit.stable is False
    assert (harmonic / predicted) ** 2 == pytest.approx(1.0, abs=0.01)
    with pytest.raises(NoOrbit):
        _orbit_near(overrides, spectral, hopf, lyap, "obstacle.temperature", -1e-4, 0.002)
