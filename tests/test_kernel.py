"""rodfem.solver.compiled.direct: the compiled time loop of the `direct` method against the PETSc
loop.

Two DirectSchemes of the same discretisation take the same steps, one through
``scheme.advance()`` and ``History.record`` (the PETSc path), one through
``DirectKernel.advance`` (after the paper scheme's special first step, which is the caller's);
every history column and the final state must agree.

The tolerance follows the arithmetic. Both loops solve each step to round-off, but not with the
same factorisation (PETSc's LU in reverse Cuthill–McKee order against LAPACK's band LU, blocked
by nodes): from the same state their steps differ by about 30 eps relative (measured: 7.5e-15 on
paper1, against refined solutions each is as close as the other), and the difference carries
through the steps, adding up about linearly. So: 64 eps per step of the run, relative to each
column's scale (2000 steps: 2.8e-11; measured up to 56 eps per step in D, 20 elsewhere), where
the scale of the columns made of differences, ut_1 and σ(1), is that of u they are made from
(:func:`column_scales`). A single step from a shared state, where nothing accumulates, must agree
to 256 eps.
"""

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.history import History
from rodfem.solver.compiled import direct as kernel
from rodfem.solver.methods.direct import DirectMethod

EPS = np.finfo(float).eps
PER_STEP = 64 * EPS  # accumulated over a run
ONE_STEP = 256 * EPS  # one step from a shared state
END = "time.end=2"

CASES = [(name, scheme, ()) for name in rodfem.scene.BUILTIN
         for scheme in ("paper", "crank-nicolson")]
CASES += [("paper1", "paper", ("obstacle.kind=rigid",)),
          ("paper1", "crank-nicolson", ("model.b=0",)),
          ("paper1", "paper", ("discretisation.mass=consistent",)),
          ("paper1", "crank-nicolson", ("discretisation.mass=consistent",)),
          ("paper1", "paper", ("model.a=0",)),
          ("paper1", "paper", ("model.b=0",))]
# The redistributed masses (rodfem.solver.methods.massless): the end without mass, and with
# Crank–Nicolson, ζ = 0 and a = 0 eliminated, its law in series with the last cell; the impact
# scene (the rigid obstacle or an elastic one).
REDISTRIBUTED = [(name, scheme, (f"discretisation.mass={mass}", f"model.zeta={zeta}",
                                 *(("model.a=0",) if zeta == 0 else ())))
                 for name in ("paper1", "paper5")
                 for mass in ("redistributed", "redistributed-lumped")
                 for scheme in ("paper", "crank-nicolson") for zeta in (0.2, 0)]
REDISTRIBUTED += [("impact", "crank-nicolson", (f"discretisation.mass={mass}", *obstacle))
                  for mass in ("redistributed", "redistributed-lumped")
                  for obstacle in ((), ("obstacle.kind=elastic", "obstacle.epsilon=1e-2"))]
CASES += REDISTRIBUTED


def ids(value) -> str:
    """A parameter's test id: overrides as they read."""
    return " ".join(value) or "-" if isinstance(value, tuple) else str(value)


def relative(a: np.ndarray, b: np.ndarray, scale=None) -> np.ndarray:
    """max |a − b| / scale per column; scale: max |b| per column unless given."""
    scale = np.max(np.abs(b), axis=0) if scale is None else np.asarray(scale)
    return np.max(np.abs(a - b), axis=0) / np.where(scale > 0, scale, 1.0)


def column_scales(rows: np.ndarray, scheme) -> np.ndarray:
    """What each history column's round-off is relative to. u_1, u_half, the energy: their own
    size. ut_1 = D(1)/Δt and σ(1) are differences of numbers of the size of u (D = Uⁿ − Uⁿ⁻¹, the
    increment that the right-hand side, of the size of u, leaves; p = (s − g)/(ε + w)): their
    round-off is that of u, over Δt and over ε + w (rigid: w). Without inertia (b = 0) or with the
    rigid obstacle, both are small against that, and measured against their own size they would
    be off by 300 eps per step (paper1)."""
    u = np.max(np.abs(rows[:, 1]))
    epsilon = scheme.law.epsilon  # 0 for the rigid obstacle
    own = np.max(np.abs(rows), axis=0)
    return np.array([own[0], u, own[2], max(own[3], u / scheme.dt),
                     max(own[4], u / (epsilon + scheme.compliance)), own[5], own[6]])


def pair(name: str, time_scheme: str, overrides=(), **options):
    scene = rodfem.scene.load(name, ["solver.method=direct", END, f"time.scheme={time_scheme}",
                                     *overrides])
    disc = Discretisation(scene, COMM)
    petsc, compiled = DirectMethod(disc), DirectMethod(disc)
    h_petsc, h_compiled = History(disc, scene.steps + 1), History(disc, scene.steps + 1)
    return scene, petsc, h_petsc, compiled, h_compiled, kernel.DirectKernel(compiled, h_compiled,
                                                                            **options)


def run_both(name, time_scheme, overrides=(), chunks=(7, 500), **options):
    """The whole run both ways; the kernel in calls of the sizes ``chunks`` (cycled)."""
    scene, petsc, h_petsc, compiled, h_compiled, k = pair(name, time_scheme, overrides, **options)
    steps = scene.steps
    h_petsc.record(petsc)
    h_compiled.record(compiled)
    for _ in range(steps):
        petsc.advance()
        h_petsc.record(petsc)
    compiled.advance()  # the first step is the caller's (special in the paper scheme)
    h_compiled.record(compiled)
    done, c = 1, 0
    while done < steps:
        size = min(chunks[c % len(chunks)], steps - done)
        k.advance(size, h_compiled._rows[h_compiled._count:h_compiled._count + size])
        h_compiled._count += size
        done, c = done + size, c + 1
    return steps, petsc, h_petsc.take(), compiled, h_compiled.take(), k


def test_available():
    assert kernel.available(), kernel.unavailable_reason()


@pytest.mark.parametrize("name,time_scheme,overrides", CASES, ids=ids)
def test_agrees_with_petsc_loop(name, time_scheme, overrides):
    steps, petsc, rows, compiled, rows_k, k = run_both(name, time_scheme, overrides)
    tol = PER_STEP * steps
    assert rows_k.shape == rows.shape
    np.testing.assert_array_equal(rows_k[:, 0], rows[:, 0])  # t
    np.testing.assert_array_equal(rows_k[:, 6], rows[:, 6])  # iterations
    error = relative(rows_k, rows, column_scales(rows, petsc))
    assert np.all(error <= tol), f"history columns off by {error} (tol {tol:.1e})"
    # contact in the same steps
    np.testing.assert_array_equal(rows_k[:, 4] != 0, rows[:, 4] != 0)
    n = petsc.values.size // 3
    theta, d, u = (slice(b * n, (b + 1) * n) for b in range(3))
    u_max = np.max(np.abs(petsc.values[u]))
    assert relative(compiled.values[theta], petsc.values[theta]) <= tol
    assert relative(compiled.values[u], petsc.values[u]) <= tol
    assert relative(compiled.values[d], petsc.values[d], max(u_max, np.max(
        np.abs(petsc.values[d])))) <= tol  # D = ΔU: u's round-off (column_scales)
    assert relative(compiled.u_prev.array, petsc.u_prev.array) <= tol
    assert compiled.n == petsc.n == steps
    assert compiled.iterations == petsc.iterations == 1
    assert relative(np.array([compiled.pressure]), np.array([petsc.pressure]),
                    column_scales(rows, petsc)[4]) <= tol


@pytest.mark.parametrize("name,time_scheme,overrides", [
    ("paper1", "paper", ()), ("paper1", "paper", ("discretisation.mass=consistent",)),
    ("paper1", "paper", ("obstacle.kind=rigid",)), ("paper1", "paper", ("model.a=0",)),
    ("paper1", "crank-nicolson", ("discretisation.mass=redistributed",)),
    ("paper1", "crank-nicolson", ("discretisation.mass=redistributed", "model.zeta=0",
                                  "model.a=0")),
    ("impact", "crank-nicolson", ())], ids=ids)
def test_dgbtrs_path(name, time_scheme, overrides):
    """The plain dgbtrs substitutions (what the kernel does when dgbtrf pivots)."""
    steps, petsc, rows, _, rows_k, k = run_both(name, time_scheme, overrides, blocked=False)
    assert not k.blocked
    assert np.all(relative(rows_k, rows, column_scales(rows, petsc)) <= PER_STEP * steps)
    np.testing.assert_array_equal(rows_k[:, 4] != 0, rows[:, 4] != 0)


@pytest.mark.parametrize("name,overrides,kind", [
    ("paper1", ("discretisation.mass=redistributed",), "RC_END_MASS"),
    ("paper1", ("discretisation.mass=redistributed", "model.zeta=0", "model.a=0"),
     "RC_END_MASSLESS"),
    ("impact", (), "RC_END_MASSLESS")], ids=ids)
def test_detects_a_wrong_end(name, overrides, kind):
    """The comparison sees how the end is treated: the kernel told that the end has its mass
    (the midpoint rule for D(1)), or that an eliminated end is merely massless (no settling, the
    law in series taken at U(1)), is caught."""
    scene, petsc, hp, compiled, _, k = pair(name, "crank-nicolson", overrides)
    k._problem.end.kind = getattr(k._lib, kind)
    steps = scene.steps
    rows = np.zeros((steps, 7))
    k.advance(steps, rows)
    for _ in range(steps):
        petsc.advance()
        hp.record(petsc)
    expected = hp._rows[:steps]
    assert np.max(relative(rows, expected, column_scales(expected, petsc))) > 100 * PER_STEP * steps


@pytest.mark.parametrize("overrides,loop", [
    ((), kernel.DirectKernel),
    (("discretisation.mass=redistributed-lumped", "obstacle.kind=elastic"), kernel.DirectKernel),
    (("obstacle.kind=elastic", "obstacle.law=power", "obstacle.exponent=1.5"), None)], ids=ids)
def test_compiled_loop_of_a_redistributed_mass(overrides, loop):
    """compiled_loop runs the redistributed masses in the kernel, but for the eliminated end
    with the power law (its law in series has no closed form), which the kernel refuses."""
    from rodfem.solver.compiled import compiled_loop

    scene = rodfem.scene.load("impact", ["mesh.cells=20", *overrides])
    disc = Discretisation(scene, COMM)
    method, history = DirectMethod(disc), History(disc)
    assert method.massless is not None
    chosen = compiled_loop(method, history)
    assert type(chosen) is loop if loop else chosen is None
    if loop is None:
        with pytest.raises(ValueError, match="power law"):
            kernel.DirectKernel(method, history)


@pytest.mark.parametrize("time_scheme", ["paper", "crank-nicolson"])
def test_one_step_from_the_same_state(time_scheme):
    """Steps in and out of contact, each from the PETSc loop's state."""
    scene, petsc, _, compiled, h, k = pair("paper1", time_scheme)
    petsc.advance()
    row = np.zeros((1, 7))
    contact = 0
    for _ in range(400):
        compiled.values[:] = petsc.values
        compiled.u_prev.array[:] = petsc.u_prev.array
        compiled.n = petsc.n
        petsc.advance()
        h.record(petsc)
        expected = h._rows[:1].copy()
        h._count = 0
        k.advance(1, row)
        contact += petsc.pressure != 0
        scales = column_scales(expected, petsc)
        scales[1:4] = np.maximum(scales[1:4], np.max(np.abs(petsc.values)))
        assert np.all(relative(row, expected, scales) <= ONE_STEP), (petsc.n, row, expected)
        assert relative(compiled.values, petsc.values) <= ONE_STEP
    assert 50 < contact < 400  # both kinds of step were checked


def test_first_step_is_the_callers():
    scene, petsc, _, compiled, h, k = pair("paper1", "paper")
    with pytest.raises(ValueError, match="first step"):
        k.advance(1, np.zeros((1, 7)))
    with pytest.raises(ValueError, match="rows"):
        compiled.advance()
        k.advance(3, np.zeros((2, 7)))
    k.advance(0, np.zeros((0, 7)))  # nothing
    assert compiled.n == 1


def test_detects_a_wrong_step():
    """The comparison can fail: a kernel whose compliance is off by 1e-6 is caught."""
    scene, petsc, hp, compiled, _, k = pair("paper1", "paper")
    k._problem.w = compiled.compliance * (1 + 1e-6)
    petsc.advance()
    compiled.advance()
    m = scene.steps - 1
    rows = np.zeros((m, 7))
    k.advance(m, rows)
    for _ in range(m):
        petsc.advance()
        hp.record(petsc)
    assert np.max(relative(rows, hp._rows[:m])) > 100 * PER_STEP * scene.steps


def bits(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float).view(np.int64)


@pytest.mark.parametrize("name", ["paper1", "paper5"])
@pytest.mark.parametrize("time_scheme", ["paper", "crank-nicolson"])
@pytest.mark.parametrize("mass", ["lumped", "consistent"])
@pytest.mark.parametrize("blocked", [True, False])
def test_tables_are_bit_for_bit(name, time_scheme, mass, blocked):
    """The tables of distinct rows of R, b, E and 2w (``compress=True``, the default) change no
    bit against the kernel reading a row per node (``compress=False``): history and state."""
    overrides = (f"discretisation.mass={mass}",)
    runs = [run_both(name, time_scheme, overrides, compress=compress, blocked=blocked)
            for compress in (False, True)]
    (_, _, _, plain, rows_p, k_p), (_, _, _, compressed, rows_c, k_c) = runs
    assert not k_p.compress and k_c.compress and k_c.blocked == k_p.blocked
    n = plain.values.size // 3
    assert k_p.classes == {"r": n, "e": n}
    assert k_c.classes["r"] < n and k_c.classes["e"] < n  # some rows were shared
    np.testing.assert_array_equal(bits(rows_c), bits(rows_p))
    np.testing.assert_array_equal(bits(compressed.values), bits(plain.values))
    np.testing.assert_array_equal(bits(compressed.u_prev.array), bits(plain.u_prev.array))
    assert bits([compressed.pressure]) == bits([plain.pressure])
    assert np.count_nonzero(rows_c[:, 4]) > 0  # steps in contact were compared
