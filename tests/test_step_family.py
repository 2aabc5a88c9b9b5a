"""The compiled loops of any step size formed from the operators' Laurent parts
(rodfem.solver.compiled.laurent, rodfem.solver.compiled.family).

* **The parts recombine to the assembly.** At λ = Δt₀/Δt the recombined operator differs from the
  one assembled at Δt by at most γ (A(λ) + λ A(1)), γ = 16 eps (laurent.bound: the assembly's
  rounding of the terms at λ, and P₁'s of the terms at Δt₀; A the size of an entry's terms).
  Measured: at most 13 % of it. Entries of one power are exact at λ = 2ᵏ: the forms' terms scale
  by powers of two without rounding.
* **Steps agree with a method made for the size.** From the same state, a family's loop of a step
  h and ``compiled_loop(make_method(disc, h))`` differ only by the operators' rounding (and the
  factorisation's): as tests/test_kernel.py bounds two loops of one scheme, 64 eps per step,
  relative to each part's scale (Θ's own; D's and U's that of U, whose round-off D's increments
  carry). Both in and out of contact, loops of two sizes alternating on one state.
* **Adaptive runs take the same decisions** with the family as with a method made per size: the
  same steps, rejections and events, the same times and step sizes (to the event bracket), the
  columns to 1e-9 (tests/test_adaptive.py's tolerance against an independent reference).
* **Where there is no family** (no compiled loop, parts that fail their check) runs make methods
  as before. The parts are kept in the operator cache: a warm adaptive run assembles nothing.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

import rodfem
import rodfem.scene
import rodfem.solver.compiled.families as families
from conftest import COMM, serial_only
from rodfem.discrete.discretisation import Discretisation
from rodfem.output.history import History
from rodfem.solver.adaptive.compiled import CompiledSteps
from rodfem.solver.adaptive.events import EVENT_WIDTH
from rodfem.solver.compiled import compiled_loop, laurent
from rodfem.solver.compiled.families import step_family
from rodfem.solver.methods import make_method

EPS = np.finfo(float).eps
PER_STEP = 64 * EPS
LAMBDAS = (1 / 3, 3.0, 100.0, 1e4)
PARTS_SCENES = [("paper1", ()),
                ("paper1", ("discretisation.mass=dispersion-free", "time.scheme=crank-nicolson")),
                ("paper1", ("discretisation.mass=redistributed",)),
                ("stiff", ("time.scheme=crank-nicolson",)),
                ("impact", ())]


def made_home(name, overrides):
    scene = rodfem.scene.load(name, list(overrides))
    disc = Discretisation(scene, COMM)
    home = make_method(disc)
    history = History(disc, 4)
    return disc, home, history


def assembled(disc, home, parts, lam):
    """The operators assembled at Δt₀/λ, on the parts' entries."""
    with disc.at_step(home.dt / lam):
        operators = laurent._operators(home)
    n = disc.nodes.size
    out = {}
    for key, op in operators.items():
        if key.endswith(".b") or key == "contact.e":
            out[key] = op.array_r.copy()
            continue
        r, c, v = laurent._entries(op)
        rows, cols, _ = parts.matrix(key)
        values = np.zeros(rows.size)
        np.add.at(values, np.searchsorted(rows * n + cols, r * n + c), v)
        out[key] = values
    return out


@pytest.mark.parametrize("name, overrides", PARTS_SCENES)
def test_parts_recombine_to_the_assembly(name, overrides):
    disc, home, _ = made_home(name, overrides)
    parts = laurent.read_parts(home)
    assert parts is not None
    for lam in (*LAMBDAS, 4.0):
        for key, values in assembled(disc, home, parts, lam).items():
            P = parts.arrays[key + "|parts"]
            rows = None if key.endswith(".b") or key == "contact.e" else parts.matrix(key)[0]
            error = np.abs(laurent.combine(P, lam) - values)
            assert np.all(error <= laurent.bound(P, lam, rows)), (key, lam)
            if lam == 4.0:  # a power of two: an entry of one power is exact
                one = np.count_nonzero(P, axis=0) == 1
                assert np.array_equal(laurent.combine(P, lam)[one], values[one]), key
    # every power is there: the mass Δt⁻¹ (heat), the inertia Δt⁻² (momentum)
    assert np.any(parts.arrays["heat.A|parts"][1] != 0.0)
    assert np.any(parts.arrays["momentum.A|parts"][2] != 0.0)


def test_the_bound_is_not_vacuous():
    """Parts read with the wrong λ for one sample fail the check at the fourth size."""
    disc, home, _ = made_home("paper1", ())
    parts = laurent.read_parts(home)
    values = assembled(disc, home, parts, 3.0)["momentum.A"]
    P = parts.arrays["momentum.A|parts"]
    wrong = P.copy()
    wrong[2] *= 1.0 + 1e-12  # the inertia's part a trillionth off
    rows = parts.matrix("momentum.A")[0]
    assert np.any(np.abs(laurent.combine(wrong, 3.0) - values) > laurent.bound(wrong, 3.0, rows))


def state_scales(method) -> np.ndarray:
    """Θ's scale, and for D and U that of the stress's terms, u_x and aΘ (the shifted Θ, whose
    aΘ and aθ_A r cancel to the small thermal stress: their round-off is of their size), in
    displacements over the rod's length 1: D's round-off is U's (tests/test_kernel.py's
    column_scales)."""
    theta, _, u = np.abs(method.values.reshape(3, -1)).max(axis=1)
    u = u + abs(method.disc.scene["model.a"]) * theta
    return np.array([theta or 1.0, u or 1.0, u or 1.0])


STEP_CASES = [("paper1", ()), ("paper1", ("solver.method=direct",)),
              ("stiff", ("solver.method=direct", "time.scheme=paper")),
              ("stiff", ("solver.method=direct", "time.scheme=crank-nicolson")),
              ("stiff", ("time.scheme=crank-nicolson",)),
              ("impact", ()),
              ("paper1", ("solver.method=direct", "discretisation.mass=dispersion-free",
                          "time.scheme=crank-nicolson")),
              ("paper1", ("solver.method=direct", "discretisation.mass=redistributed")),
              ("paper1", ("discretisation.mass=redistributed-lumped",)),
              ("paper1", ("solver.method=direct", "discretisation.mass=redistributed",
                          "time.scheme=crank-nicolson", "model.zeta=0", "model.a=0")),
              ("paper1", ("solver.method=direct", "heat_exchange.law=pressure")),
              ("paper1", ("heat_exchange.law=gap", "heat_exchange.length=0.1"))]


def in_contact(home, kernel, history, touching: bool, limit: int = 4000):
    """Advance home by its own loop until the obstacle pushes (or not): its state."""
    rows = np.zeros((10, history.width))
    if home.first_step_special:
        home.advance()
    for _ in range(limit // 10):
        if (home.pressure > 0.0) == touching:
            return home.saved_state()
        kernel.advance(10, rows)
    pytest.skip("the state sought was not reached")


@pytest.mark.parametrize("name, overrides", STEP_CASES)
@pytest.mark.parametrize("touching", [False, True])
def test_steps_agree_with_a_method_made_for_the_size(name, overrides, touching):
    disc, home, history = made_home(name, overrides)
    kernel = compiled_loop(home, history)
    family = step_family(home, history, kernel)
    assert family is not None
    start = in_contact(home, kernel, history, touching)
    n = home.values.size // 3
    sizes = (home.dt * 2**0.25, home.dt / 3, home.dt * 4)
    made = {}
    for h in sizes:
        with disc.at_step(h):
            method = make_method(disc, h)
        made[h] = (method, compiled_loop(method, history, compress=False), family.loop(h))
    reference = made[sizes[0]][0]
    reference.restore(start)
    home.restore(start)
    rows = np.zeros((1, history.width))
    steps = 0
    for k in range(12):  # the sizes in turn, each on the one state
        h = sizes[k % len(sizes)]
        method, loop, bound = made[h]
        method.restore(reference.saved_state())
        method.values[n:2 * n] *= h / home.dt
        loop.advance(1, rows)
        reference.take_state(method)
        reference.values[n:2 * n] *= home.dt / h
        home.values[n:2 * n] *= h / home.dt
        bound.advance(1, rows)
        home.values[n:2 * n] *= home.dt / h
        steps += 1
        difference = np.abs(home.values - reference.values).reshape(3, -1).max(axis=1)
        assert np.all(difference <= PER_STEP * steps * state_scales(reference)), (k, h)
        assert home.n == reference.n and home.iterations == reference.iterations
        # p's round-off is U's over ε + w (tests/test_kernel.py's column_scales)
        spring = home.law.epsilon + getattr(method, "compliance", 0.0)
        assert abs(home.pressure - reference.pressure) <= PER_STEP * steps * (
            abs(reference.pressure) + state_scales(reference)[2] / spring)
    if touching:
        assert reference.pressure > 0.0 or home.law.rigid


@pytest.mark.parametrize("overrides", [(), ("solver.method=direct",),
                                       ("discretisation.mass=redistributed",),
                                       ("heat_exchange.law=gap", "heat_exchange.length=10")])
def test_the_paper_schemes_first_step_of_any_size(overrides):
    disc, home, history = made_home("paper1", overrides)
    family = step_family(home, history, compiled_loop(home, history))
    n = home.values.size // 3
    for h in (home.dt / 2, home.dt * 1.5):
        with disc.at_step(h):
            method = make_method(disc, h)
        assert method.first_step_special
        method.advance()
        fresh = make_method(disc)
        fresh.values[n:2 * n] *= h / fresh.dt
        loop = family.loop(h)
        loop.method = fresh
        loop.first_step()
        assert fresh.n == 1 and fresh.pressure == 0.0
        scales = state_scales(method)
        difference = np.abs(fresh.values - method.values).reshape(3, -1).max(axis=1)
        assert np.all(difference <= PER_STEP * scales)
        assert np.max(np.abs(fresh.u_prev.array_r - method.u_prev.array_r)) == 0.0


ADAPTIVE = [("paper1", {"time.end": 10.0}),
            ("paper1", {"time.end": 10.0, "solver.method": "direct"}),
            ("stiff", {"time.end": 0.6}),
            ("stiff", {"time.end": 0.6, "time.scheme": "crank-nicolson"}),
            ("impact", {"mesh.cells": 200, "time.end": 3.0})]


def adaptive_run(name, overrides, monkeypatch, with_family: bool):
    """The run, and [its family], the family followed by the sizes its compiled adaptive steps
    formed in C."""
    made, calls = [], []

    def counted(*args):
        family = step_family(*args) if with_family else None
        made.append(family)
        return family

    advance = CompiledSteps.advance

    def kept(self, *args):
        calls.append(self)
        return advance(self, *args)

    monkeypatch.setattr(families, "step_family", counted)
    monkeypatch.setattr(CompiledSteps, "advance", kept)
    result = rodfem.simulate(name, {**overrides, "time.adaptive": True})
    assert result.status == "complete"
    formed = calls[-1].formed if calls and calls[-1].R.pool else 0
    return result, made + [formed]


@pytest.mark.parametrize("name, overrides", ADAPTIVE)
def test_adaptive_runs_take_the_same_decisions(name, overrides, monkeypatch):
    before, none = adaptive_run(name, overrides, monkeypatch, False)
    after, made = adaptive_run(name, overrides, monkeypatch, True)
    # the ladder's sizes are formed here, or by the compiled adaptive steps in C (an event's
    # tries too)
    assert none == [None, 0] and made[0] is not None and made[0].made + made[1] > 5
    assert after.summary["adaptive"] == before.summary["adaptive"]
    assert after.summary["adaptive"]["events"] >= 1
    a, b = after.history, before.history
    assert a.shape == b.shape
    assert np.array_equal(a["event"], b["event"])
    assert np.array_equal(a["iterations"], b["iterations"])
    # times and sizes: the same, but for where an event's bracket (its tries' round-off) ends
    assert np.max(np.abs(a["t"] - b["t"])) <= 2 * EVENT_WIDTH
    assert np.max(np.abs(a["dt"] - b["dt"])) <= 2 * EVENT_WIDTH
    for column in ("u_1", "u_half", "ut_1", "sigma_1", "energy"):
        scale = np.max(np.abs(b[column])) or 1.0
        assert np.max(np.abs(a[column] - b[column])) <= 1e-9 * scale, column


@pytest.mark.parametrize("name, overrides", [("paper1", ("solver.method=newton",)),
                                             ("manufactured", ())])
def test_no_family_without_a_compiled_loop(name, overrides):
    disc, home, history = made_home(name, overrides)
    kernel = compiled_loop(home, history)
    assert kernel is None and step_family(home, history, kernel) is None


def test_no_family_where_the_parts_fail_their_check(monkeypatch):
    """Parts that do not recombine to the fourth size's assembly: methods made per size. (The
    operator cache is not used: the failure it would keep is this test's.)"""
    monkeypatch.setenv("RODFEM_CACHE", "0")
    monkeypatch.setattr(laurent, "solve", lambda samples: np.array(
        [samples[1], np.zeros_like(samples[1]), np.zeros_like(samples[1])]))
    disc, home, history = made_home("paper1", ())
    assert step_family(home, history, compiled_loop(home, history)) is None
    result = rodfem.simulate("stiff", {"time.adaptive": True, "time.end": 0.05})
    assert result.status == "complete"


def test_a_loop_of_another_size_is_told_apart():
    """The bound of the agreement test fails for a loop of a size a millionth off."""
    disc, home, history = made_home("paper1", ("solver.method=direct",))
    family = step_family(home, history, compiled_loop(home, history))
    home.advance()
    start = home.saved_state()
    h = home.dt / 3
    with disc.at_step(h):
        method = make_method(disc, h)
    loop = compiled_loop(method, history, compress=False)
    rows = np.zeros((4, history.width))
    method.restore(start)
    loop.advance(4, rows)
    home.restore(start)
    family.loop(h * (1.0 + 1e-6)).advance(4, rows)
    difference = np.abs(home.values - method.values).reshape(3, -1).max(axis=1)
    assert np.any(difference > 100 * PER_STEP * 4 * state_scales(method))


@serial_only
def test_a_warm_adaptive_run_assembles_nothing(tmp_path):
    """The parts are kept in the operator cache: the second adaptive run of a scene imports no
    dolfinx, UFL or FFCx, and writes the first's history bit for bit."""
    code = ("import sys; from rodfem.__main__ import main; code = main(); "
            "print(sorted(m for m in ('dolfinx', 'ufl', 'ffcx') if m in sys.modules)); "
            "sys.exit(code)")
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"))
    loaded, histories = [], []
    for i in range(2):
        out = tmp_path / f"run{i}"
        done = subprocess.run([sys.executable, "-c", code, "run", "stiff", "--set",
                               "time.end=0.3", "--set", "time.adaptive=true", "--out", str(out),
                               "--quiet"], env=env, capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        loaded.append(done.stdout.strip().splitlines()[-1])
        histories.append(rodfem.load(out).history)
    assert loaded == ["['dolfinx', 'ffcx', 'ufl']", "[]"]
    assert len(np.unique(histories[0]["dt"])) > 10  # the steps did adapt
    assert histories[0].tobytes() == histories[1].tobytes()


@pytest.mark.parametrize("name, overrides", [("paper1", ("solver.method=direct",)),
                                             ("impact", ())])
def test_rk_form_lays_out_the_factors_as_the_kernel_does(name, overrides):
    """rk_form's factors are LAPACK's dgbtrf's of the same band (to round-off, a BLAS may fuse
    dger's products; measured: bit for bit, the same pivots), and laid out from them as
    direct.py's band_factors does, bit for bit: the factoring in the family's work, the layout in
    the size's memory."""
    from scipy.linalg import lapack

    from rodfem.solver.compiled.direct import band_factors

    disc, home, history = made_home(name, overrides)
    family = step_family(home, history, compiled_loop(home, history))
    lam = 0.7
    loop = family.loop(home.dt / lam)
    P, ffi, n = loop._problem, loop._ffi, family.n
    N, ldab = 2 * n, family.ldab
    lu = family._kept["work"][:ldab * N].reshape((ldab, N), order="F")  # the last size formed
    ipiv = np.frombuffer(ffi.buffer(P.ipiv, 4 * N), dtype=np.intc)
    band, arrays = band_factors(lu, ipiv, 0, family.kl, family.ku, n)
    assert (P.kl, P.ku, bool(P.pivoting)) == (band["kl_kept"], band["ku_kept"], band["pivoting"])
    blocked = P.fwd != ffi.NULL
    assert blocked == (arrays["fwd"] is not None)
    # the steps read the node-blocked recurrences where there are any, else the kept bands
    for field in ("rdiag", *(("fwd", "bwd") if blocked else ("lower", "upper"))):
        expected = arrays[field]
        got = np.frombuffer(ffi.buffer(getattr(P, field), 8 * expected.size), dtype=float)
        assert np.array_equal(got, expected.ravel()), field
    ab = np.zeros(ldab * N)
    ab[family.c_place] = laurent.combine(family.c_parts, lam)
    lapack_lu, lapack_ipiv, info = lapack.dgbtrf(ab.reshape((ldab, N), order="F"), family.kl,
                                                family.ku)
    assert info == 0 and np.array_equal(lapack_ipiv, ipiv)
    assert np.max(np.abs(lapack_lu - lu)) <= 16 * EPS * np.max(np.abs(lu))
