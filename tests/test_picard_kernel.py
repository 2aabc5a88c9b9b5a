"""rodfem.solver.compiled.picard: the compiled Picard loop against the PETSc loop.

Two PicardSchemes of the same discretisation take the same steps, one through
``scheme.advance()`` and ``History.record`` (the PETSc path), one through
``PicardKernel.advance`` (after the paper scheme's special first step, which is the caller's).

Iterations: the same at every step. Picard stops when the change falls below tol; the two loops
apply the same map up to round-off, so their changes differ by round-off too, and only a change
within about 1e-15 relative of tol could stop one of them an iteration earlier: a mismatch would
be a real difference (or a vanishingly rare coincidence), so it is asked exactly.

Values: the kernel sums the mat-vecs in PETSc's order but solves with other factors (normalised
L U for A_h, U L for A_m, against PETSc's L U with inverted pivots): an iteration from the same
iterate differs by a few eps (the operators are well conditioned, diagonally dominant), and over
a run the difference adds up about linearly in the steps, as in ``tests/test_kernel.py``: we ask
64 eps per step of the run relative to each column's scale (measured: at most about 7), where
the columns made of differences of numbers of the size of u, ut_1 = D(1)/Δt and
σ(1) = −[u(1) − g]₊/ε, are measured against u/Δt and u/ε.
"""

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM
from rodfem.discrete.discretisation import Discretisation
from rodfem.model.contact import RigidObstacle
from rodfem.output.history import History
from rodfem.solver.compiled import picard as picard_kernel
from rodfem.solver.methods.picard import PicardMethod, PicardNotConverged

EPS = np.finfo(float).eps
PER_STEP = 64 * EPS
CASES = [(name, scheme, mass, ()) for name in rodfem.scene.BUILTIN
         for scheme in ("paper", "crank-nicolson") for mass in ("lumped", "consistent")]
# The redistributed masses: the end without mass. (With Crank–Nicolson and ζ = 0 the end is
# eliminated, which needs a = 0, and Picard with a = 0 is the PETSc loop's.)
CASES += [(name, scheme, mass, (f"model.zeta={zeta}",)) for name in ("paper1", "paper5")
          for scheme in ("paper", "crank-nicolson")
          for mass in ("redistributed", "redistributed-lumped") for zeta in (0.2, 0)
          if not (scheme == "crank-nicolson" and zeta == 0)]


def ids(value) -> str:
    """A parameter's test id: overrides as they read."""
    return " ".join(value) or "-" if isinstance(value, tuple) else str(value)


def relative(a: np.ndarray, b: np.ndarray, scale=None) -> np.ndarray:
    scale = np.max(np.abs(b), axis=0) if scale is None else np.asarray(scale)
    return np.max(np.abs(a - b), axis=0) / np.where(scale > 0, scale, 1.0)


def column_scales(rows: np.ndarray, scheme) -> np.ndarray:
    u = np.max(np.abs(rows[:, 1]))
    own = np.max(np.abs(rows), axis=0)
    return np.array([own[0], u, own[2], max(own[3], u / scheme.dt),
                     max(own[4], u / scheme.law.epsilon), own[5], own[6]])


def pair(name: str, overrides=()):
    scene = rodfem.scene.load(name, ["solver.method=picard", *overrides])
    disc = Discretisation(scene, COMM)
    petsc, compiled = PicardMethod(disc), PicardMethod(disc)
    size = scene.steps + 1
    h_petsc, h_compiled = History(disc, size), History(disc, size)
    kernel = picard_kernel.PicardKernel(compiled, h_compiled)
    h_petsc.record(petsc)
    h_compiled.record(compiled)
    return scene, petsc, h_petsc, compiled, h_compiled, kernel


def test_available():
    assert picard_kernel.available(), picard_kernel.unavailable_reason()


@pytest.mark.parametrize("name,time_scheme,mass,extra", CASES, ids=ids)
def test_agrees_with_petsc_loop(name, time_scheme, mass, extra):
    scene, petsc, h_petsc, compiled, h_compiled, kernel = pair(
        name, ["time.end=2", f"time.scheme={time_scheme}", f"discretisation.mass={mass}",
               *extra])
    steps = scene.steps
    for _ in range(steps):
        petsc.advance()
        h_petsc.record(petsc)
    compiled.advance()  # the first step is the caller's (special in the paper scheme)
    h_compiled.record(compiled)
    done, chunks = 1, (7, 500)
    while done < steps:
        size = min(chunks[done % 2], steps - done)
        kernel.advance(size, h_compiled.reserve(size))
        assert kernel.done == size
        h_compiled.commit(size)
        done += size
    rows, rows_k = h_petsc.take(), h_compiled.take()
    assert rows_k.shape == rows.shape
    np.testing.assert_array_equal(rows_k[:, 0], rows[:, 0])  # t
    np.testing.assert_array_equal(rows_k[:, 6], rows[:, 6])  # iterations, every step
    np.testing.assert_array_equal(rows_k[:, 4] != 0, rows[:, 4] != 0)  # contact, same steps
    tol = PER_STEP * steps
    scales = column_scales(rows, petsc)
    error = relative(rows_k, rows, scales)
    assert np.all(error <= tol), f"history columns off by {error} (tol {tol:.1e})"
    n = petsc.values.size // 3
    theta, d, u = (slice(b * n, (b + 1) * n) for b in range(3))
    u_max = np.max(np.abs(petsc.values[u]))
    assert relative(compiled.values[theta], petsc.values[theta]) <= tol
    assert relative(compiled.values[u], petsc.values[u]) <= tol
    assert relative(compiled.values[d], petsc.values[d],
                    max(u_max, np.max(np.abs(petsc.values[d])))) <= tol
    assert relative(compiled.u_prev.array, petsc.u_prev.array) <= tol
    assert compiled.n == petsc.n == steps
    assert compiled.iterations == petsc.iterations
    assert abs(compiled.pressure - petsc.pressure) <= tol * scales[4]


def test_no_inertia_from_step_zero():
    """b = 0: step 1 is a step like any other, and the kernel takes it."""
    scene, petsc, h_petsc, compiled, h_compiled, kernel = pair(
        "paper1", ["time.end=0.5", "model.b=0"])
    for _ in range(scene.steps):
        petsc.advance()
        h_petsc.record(petsc)
    kernel.advance(scene.steps, h_compiled.reserve(scene.steps))
    h_compiled.commit(scene.steps)
    rows, rows_k = h_petsc.take(), h_compiled.take()
    np.testing.assert_array_equal(rows_k[:, 6], rows[:, 6])
    tol = PER_STEP * scene.steps
    assert np.all(relative(rows_k, rows, column_scales(rows, petsc))[1:3] <= tol)


def test_failure_as_petsc_loop():
    """paper1 with Δt = 0.01, ε = 0.001: Picard cycles at step 19 (t = 0.19); the kernel stops
    there with the PETSc loop's error, the state of step 18 and its rows."""
    overrides = ["time.dt=0.01", "obstacle.epsilon=0.001"]
    scene, petsc, h_petsc, compiled, h_compiled, kernel = pair("paper1", overrides)
    with pytest.raises(PicardNotConverged) as caught:
        for _ in range(scene.steps):
            petsc.advance()
            h_petsc.record(petsc)
    expected = caught.value
    assert (expected.step, expected.iterations) == (19, 100)
    compiled.advance()
    h_compiled.record(compiled)
    with pytest.raises(PicardNotConverged) as caught:
        kernel.advance(100, h_compiled.reserve(100))
    error = caught.value
    assert kernel.done == error.done == 17
    h_compiled.commit(kernel.done)
    assert str(error) == str(expected)
    assert (error.step, error.time, error.iterations) == (19, expected.time, 100)
    assert error.increment == pytest.approx(expected.increment, rel=1e-9, abs=0)
    assert f"{error.increment:.3e}" == "8.571e-03"
    assert compiled.n == petsc.n == 18
    assert compiled.iterations == petsc.iterations
    rows, rows_k = h_petsc.take(), h_compiled.take()
    assert rows_k.shape == rows.shape == (19, 7)
    np.testing.assert_array_equal(rows_k[:, 6], rows[:, 6])
    tol = PER_STEP * 18
    assert np.all(relative(rows_k, rows, column_scales(rows, petsc)) <= tol)
    assert relative(compiled.values, petsc.values) <= tol
    assert relative(compiled.u_prev.array, petsc.u_prev.array) <= tol


def test_refuses():
    disc = Discretisation(rodfem.scene.load("paper1", ["solver.method=picard", "model.a=0"]),
                          COMM)
    with pytest.raises(ValueError, match="a = 0"):
        picard_kernel.PicardKernel(PicardMethod(disc), History(disc))
    disc = Discretisation(rodfem.scene.load("manufactured", ["solver.method=picard"]), COMM)
    with pytest.raises(ValueError, match="source"):
        picard_kernel.PicardKernel(PicardMethod(disc), History(disc))
    disc = Discretisation(rodfem.scene.load("paper1", ["solver.method=picard"]), COMM)
    scheme, history = PicardMethod(disc), History(disc)
    law = scheme.law
    scheme.law = RigidObstacle(law.gap)  # the scene refuses picard with it: pretend
    with pytest.raises(ValueError, match="elastic"):
        picard_kernel.PicardKernel(scheme, history)
    scheme.law = law
    kernel = picard_kernel.PicardKernel(scheme, history)
    with pytest.raises(ValueError, match="first step"):
        kernel.advance(1, history.reserve(1))


@pytest.mark.parametrize("overrides,kind", [
    (("discretisation.mass=redistributed",), "RC_END_MASS")], ids=ids)
def test_detects_a_wrong_end(overrides, kind):
    """The comparison sees how the end is treated: the kernel told that the end has its mass
    (the midpoint rule for D(1)), or that an eliminated end is merely massless (no settling, the
    law in series taken at U(1)), is caught (paper1, Crank–Nicolson)."""
    scene, petsc, h_petsc, compiled, h_compiled, kernel = pair(
        "paper1", ["time.end=2", "time.scheme=crank-nicolson", *overrides])
    kernel._problem.end.kind = getattr(kernel._lib, kind)
    steps = scene.steps
    for _ in range(steps):
        petsc.advance()
        h_petsc.record(petsc)
    kernel.advance(steps, h_compiled.reserve(steps))
    h_compiled.commit(steps)
    rows, rows_k = h_petsc.take(), h_compiled.take()
    error = relative(rows_k, rows, column_scales(rows, petsc))
    assert np.max(error) > 100 * PER_STEP * steps


def run_kernel(name: str, overrides, compress: bool):
    """The scene's steps through the kernel (after the caller's first step): the history's raw
    rows, the state, u_prev, n, iterations, pressure, and the error raised (or None)."""
    scene = rodfem.scene.load(name, ["solver.method=picard", *overrides])
    disc = Discretisation(scene, COMM)
    scheme, history = PicardMethod(disc), History(disc, scene.steps + 1)
    kernel = picard_kernel.PicardKernel(scheme, history, compress=compress)
    history.record(scheme)
    scheme.advance()
    history.record(scheme)
    error, done = None, 1
    while done < scene.steps:
        size = min(7 if done % 2 else 300, scene.steps - done)
        try:
            kernel.advance(size, history.reserve(size))
        except PicardNotConverged as caught:
            error = caught
        history.commit(kernel.done)
        done += kernel.done
        if error is not None:
            break
    return kernel, {"rows": history.take(), "values": scheme.values.copy(),
                    "u_prev": scheme.u_prev.array.copy(), "n": scheme.n,
                    "iterations": scheme.iterations, "pressure": scheme.pressure}, error


def bits(x) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(x, dtype=float)).view(np.int64)


@pytest.mark.parametrize("name,time_scheme,mass,extra",
                         [c for c in CASES if c[0] in ("paper1", "paper5")], ids=ids)
def test_compressed_bitwise_as_uncompressed(name, time_scheme, mass, extra):
    """The coefficient rows tabled by class (compress=True) give the same numbers, in the same
    order, as a row per node (compress=False): the same history, iterations, state and pressure
    bit for bit."""
    overrides = ["time.end=2", f"time.scheme={time_scheme}", f"discretisation.mass={mass}",
                 *extra]
    tabled, a, _ = run_kernel(name, overrides, True)
    per_node, b, _ = run_kernel(name, overrides, False)
    assert set(per_node.classes.values()) == {per_node.n}
    assert all(count < per_node.n / 4 for count in tabled.classes.values()), tabled.classes
    assert a["n"] == b["n"] == round(2 / tabled.method.dt)
    for key in ("rows", "values", "u_prev", "pressure", "iterations"):
        np.testing.assert_array_equal(bits(a[key]), bits(b[key]), err_msg=key)


def test_compressed_failure_bitwise_as_uncompressed():
    overrides = ["time.dt=0.01", "obstacle.epsilon=0.001"]
    tabled, a, error_a = run_kernel("paper1", overrides, True)
    per_node, b, error_b = run_kernel("paper1", overrides, False)
    assert error_a is not None and error_b is not None
    assert str(error_a) == str(error_b)
    # steps 2 .. 8 in a call of 7, then 9 .. 18 done of a call of 300 that fails at step 19
    assert (error_a.step, error_a.iterations, error_a.done) == (19, 100, 10)
    assert bits(error_a.increment) == bits(error_b.increment)
    assert (error_a.step, error_a.time, error_a.iterations, error_a.done) == (
        error_b.step, error_b.time, error_b.iterations, error_b.done)
    assert tabled.done == per_node.done == 10
    assert a["n"] == b["n"] == 18
    for key in ("rows", "values", "u_prev", "pressure", "iterations"):
        np.testing.assert_array_equal(bits(a[key]), bits(b[key]), err_msg=key)
