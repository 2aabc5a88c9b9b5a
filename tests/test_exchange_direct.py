"""The direct method with a heat exchange that depends on the contact (``heat_exchange.law`` =
pressure or gap; rodfem.solver.methods.exchange_step), step by step: each step exact, the first
one and the eliminated end's too, k₁ = 0 the constant law bit for bit, the compiled loop the
PETSc loop's, heat_flux_1 the step's flux. Whole runs: test_exchange_runs.py. Serial and under
``mpirun -n 2``."""

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM
from rodfem.discrete.discretisation import Discretisation
from rodfem.solver.methods.direct import DirectMethod

EPS = np.finfo(float).eps
SCHEMES = ("paper", "crank-nicolson")
# A hot obstacle (θ_O = 10 > θ(1)): heat enters through the contact
LAWS = {"pressure": ("heat_exchange.law=pressure", "heat_exchange.k1=0.5"),
        "gap": ("heat_exchange.law=gap", "heat_exchange.k1=5", "heat_exchange.length=0.02")}
HOT = ("obstacle.temperature=10",)


def method_of(name: str, *overrides: str) -> DirectMethod:
    scene = rodfem.scene.load(name, ["solver.method=direct", *overrides])
    return DirectMethod(Discretisation(scene, COMM))


def _function(disc, values: np.ndarray):
    """A function of V with the node-ordered ``values``."""
    from rodfem.discrete import compat

    f = disc.function("f")
    owned = disc.nodes.owned
    compat.petsc_vector(f).array[:owned.size] = values[owned]
    f.x.scatter_forward()
    return f


def _assembled(disc, form) -> np.ndarray:
    """A linear form's vector in node order, 0 in the row of x = 0 (S_E's)."""
    from dolfinx import fem

    from rodfem.discrete import compat

    values = disc.nodes.vector(compat.assemble_vector(fem.form(form))).array_r.copy()
    values[disc.nodes.x == 0.0] = 0.0
    return values


def _abs_product(A, x: np.ndarray) -> np.ndarray:
    """|A| |x| for a sequential PETSc matrix."""
    ia, ja, a = A.getValuesCSR()
    rows = np.repeat(np.arange(len(ia) - 1), np.diff(ia))
    return np.bincount(rows, np.abs(a) * np.abs(x[ja]), minlength=len(ia) - 1)


def step_residuals(method: DirectMethod, old: np.ndarray, c: float):
    """The heat and momentum residuals of the step just taken from the state ``old`` (Θ, D, U of
    step n − 1, c = Uⁿ⁻¹(1)), assembled from forms.copetti with the exchange and contact terms
    at the step's force p and q = law.extra(exchange_place(Uⁿ(1), c), p); and each row's scale,
    |C||x| + |R||s| + |b| + the loads' sizes: what the solve's round-off is relative to."""
    import ufl
    from dolfinx import fem

    import forms.copetti as copetti

    disc, k = method.disc, method.disc.const
    n, weight = disc.nodes.size, method.time_scheme.weight
    x = method._x_values  # the step's increments [ΔΘ; ΔU]
    y = method.values[-1]
    p = method.pressure
    q = method.exchange.extra(method.time_scheme.exchange_place(y, c), p)
    Θ_prev, D_prev, U_prev = (_function(disc, old[i * n:(i + 1) * n]) for i in range(3))
    ΔΘ, ΔU = _function(disc, x[:n]), _function(disc, x[n:])
    w = ufl.TestFunction(disc.V)
    Θ = Θ_prev + weight * ΔΘ
    heat = copetti.heat_increment(ΔΘ, Θ_prev, ΔU, w, k.dt, k.a, k.k, disc.dx_m, disc.dx,
                                  disc.ds_1, weight)
    exchange = copetti.exchange(fem.Constant(disc.mesh, q),
                                copetti.temperature(Θ, disc.lifting), k.theta_O, w, disc.ds_1)
    momentum = copetti.momentum_increment(ΔU, D_prev, U_prev, Θ, w, k.dt, k.b, k.zeta, k.a,
                                          k.theta_A, disc.r, disc.dx_m, disc.dx, weight,
                                          disc.dx_b, k.theta_O, disc.s)
    contact = copetti.contact(fem.Constant(disc.mesh, p), w, disc.ds_1)
    residual = np.concatenate([_assembled(disc, heat + exchange),
                               _assembled(disc, momentum + contact)])
    loads = np.concatenate([np.abs(_assembled(disc, exchange)), np.abs(_assembled(disc, contact))])
    scale = (_abs_product(method.coupled_operator(), x) + _abs_product(method.R, old)
             + np.abs(method.b.array_r) + loads)
    return residual, scale, q, p, y


def contact_steps(method: DirectMethod, steps: int):
    """Advance ``steps`` steps; yield (state before, Uⁿ⁻¹(1)) after each step with contact."""
    for _ in range(steps):
        old, c = method.values.copy(), method.values[-1]
        first = method.first_step_special
        method.advance()
        if not first and method.pressure > 0.0:
            yield old, c


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("obstacle", [(), ("obstacle.kind=rigid",
                                           "discretisation.mass=redistributed")],
                         ids=["elastic", "rigid"])
def test_each_step_solves_the_nonlinear_step_equations(law, scheme, obstacle):
    """Θⁿ, Uⁿ put back into (3.1)–(3.2) with the exchange q (θ(1) − θ_O) and the contact force,
    q and p the laws' at the computed Uⁿ(1): the residual is the solve's round-off."""
    method = method_of("paper1", "time.end=0.6", f"time.scheme={scheme}", *LAWS[law], *HOT,
                       *obstacle)
    assert method.exchange_step is not None
    checked = exchanged = 0
    for old, c in contact_steps(method, 600):
        if checked >= 3 and method.n % 50:
            continue
        residual, scale, q, p, y = step_residuals(method, old, c)
        assert np.all(np.abs(residual) <= 64 * EPS * scale), np.max(np.abs(residual) / scale)
        if obstacle:  # Signorini: Uⁿ(1) = g where the multiplier is positive
            assert abs(y - method.law.gap) <= 4 * EPS * abs(y)
        else:  # the obstacle's force at the time scheme's rule, at the computed Uⁿ(1)
            force = method.contact_force(y, c)
            assert abs(p - force) <= 64 * EPS * (p + abs(y) / method.law.epsilon)
        checked += 1
        exchanged += q > 0.0
    assert checked >= 5 and exchanged >= 5


def test_first_step_includes_the_exchange():
    """The paper scheme's first step: Θ¹ from (3.1) with U¹ known and the gap law's q at U¹(1)
    (Sherman–Morrison): the heat residual is round-off, and without the exchange it is not."""
    method = method_of("paper1", "time.end=0.01", *LAWS["gap"], *HOT)
    old, c = method.values.copy(), method.values[-1]
    assert method.first_step_special
    method.advance()
    n = method.disc.nodes.size
    method._x_values[:n] = method.values[:n] - old[:n]  # the step's increments, for the check
    method._x_values[n:] = method.values[2 * n:] - old[2 * n:]
    residual, scale, q, _, _ = step_residuals(method, old, c)
    assert q > 0.0
    # ΔΘ recomputed from Θ¹ − Θ⁰: its round-off is that of Θ over Δt
    scale[:n] += _abs_product(method.heat.A, np.abs(method.values[:n]) + np.abs(old[:n]))
    assert np.all(np.abs(residual[:n]) <= 64 * EPS * scale[:n])
    plain = method_of("paper1", "time.end=0.01", *HOT)
    plain.advance()
    assert np.abs(plain.values[:n] - method.values[:n]).max() > 1e6 * EPS * np.abs(old).max()


def _fields(out) -> dict:
    """Every dataset of a run directory's fields, by file and name."""
    import h5py

    found = {}
    for path in sorted((out / "fields").glob("*.h5")):
        with h5py.File(path, "r") as f:
            f.visit(lambda name, f=f, path=path: found.__setitem__(
                (path.name, name), f[name][()]) if isinstance(f[name], h5py.Dataset) else None)
    return found


@pytest.mark.parametrize("kernel", ["1", "0"], ids=["compiled", "petsc"])
@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("law", LAWS)
def test_zero_k1_is_the_constant_law_bit_for_bit(simulate, monkeypatch, law, scheme, kernel):
    """k₁ = 0 with a hot obstacle: the variable law's step (its scalar equation, q = 0) gives the
    constant law's history and fields bit for bit, in the PETSc loop and the compiled one."""
    from conftest import history_rows
    from rodfem.solver.compiled import direct as compiled
    from rodfem.solver.methods import exchange_step

    monkeypatch.setenv("RODFEM_KERNEL", kernel)
    taken = []  # the variable path runs: its solves (PETSc loop), its law's code (compiled)
    solve, set_exchange = exchange_step.ExchangeStep.solve, compiled.DirectKernel.set_exchange
    monkeypatch.setattr(exchange_step.ExchangeStep, "solve",
                        lambda self, *a: taken.append("solve") or solve(self, *a))
    monkeypatch.setattr(compiled.DirectKernel, "set_exchange", staticmethod(
        lambda target, method: (set_exchange(target, method), taken.append(target.law))))
    common = ("solver.method=direct", "time.end=1", f"time.scheme={scheme}", *HOT,
              "output.every=50", 'output.fields=["theta", "u", "velocity", "sigma", "heat_flux"]',
              'output.history=["theta_1", "heat_flux_1", "contact_force"]')
    _, constant = simulate("paper1", *common)
    assert all(t == 0 for t in taken)  # RX_CONSTANT
    taken.clear()
    _, zero = simulate("paper1", *common, *LAWS[law][:1], "heat_exchange.k1=0")
    assert ("solve" in taken) if kernel == "0" else (taken == [{"pressure": 1, "gap": 2}[law]])
    np.testing.assert_array_equal(history_rows(zero), history_rows(constant))
    a, b = _fields(zero), _fields(constant)
    assert a.keys() == b.keys() and len(a) > 2
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=str(key))


# The end x = 1 without mass, eliminated (Crank–Nicolson, ζ = 0, a = 0: the exchange does not
# move the rod), and the rigid obstacle
ELIMINATED = ("discretisation.mass=redistributed", "model.zeta=0", "model.a=0")
RIGID = ("obstacle.kind=rigid",)
KERNEL_CASES = [(law, scheme, ()) for law in LAWS for scheme in SCHEMES]
KERNEL_CASES += [(law, "crank-nicolson", ELIMINATED) for law in LAWS]
KERNEL_CASES += [(law, "paper", RIGID) for law in LAWS]


@pytest.mark.parametrize("law,scheme,overrides", KERNEL_CASES,
                         ids=lambda v: " ".join(v) or "-" if isinstance(v, tuple) else v)
def test_compiled_loop_takes_the_petsc_loops_steps(law, scheme, overrides):
    """The compiled loop with the exchange against the PETSc loop: tests/test_kernel.py's bound,
    64 eps per step relative to each column's scale; and the exchange changed the run."""
    from test_kernel import PER_STEP, column_scales, relative, run_both

    steps, petsc, rows, compiled, rows_k, _ = run_both("paper1", scheme,
                                                       (*LAWS[law], *HOT, *overrides))
    assert petsc.exchange_step is not None
    tol = PER_STEP * steps
    assert np.all(relative(rows_k, rows, column_scales(rows, petsc)) <= tol)
    scale = np.abs(petsc.values).max()
    assert np.abs(compiled.values - petsc.values).max() <= tol * scale
    constant = run_both("paper1", scheme, (*HOT, *overrides))[3]
    n = petsc.disc.nodes.size
    assert np.abs(constant.values[:n] - petsc.values[:n]).max() > 1e-6  # the exchange heated


def test_eliminated_end_takes_the_heat_through_its_settled_place():
    """The eliminated end (a = 0): the heat rows of each step hold with the gap law's q at the
    settled Uⁿ(1) (Crank–Nicolson's midpoint with Uⁿ⁻¹(1)); and k₁ = 0 is the constant law."""
    method = method_of("paper1", "time.end=0.6", "time.scheme=crank-nicolson", *LAWS["gap"],
                       *HOT, *ELIMINATED)
    assert method.massless is not None
    n, checked = method.disc.nodes.size, 0
    for step in range(600):
        old, c = method.values.copy(), method.values[-1]
        method.advance()
        if step % 60 == 0:
            method._x_values[:n] = method.values[:n] - old[:n]  # the heat increment taken
            residual, scale, q, _, _ = step_residuals(method, old, c)
            scale[:n] += _abs_product(method.heat.A, np.abs(method.values[:n]) + np.abs(old[:n]))
            assert q > 0.0 and np.all(np.abs(residual[:n]) <= 64 * EPS * scale[:n])
            checked += 1
    assert checked == 10
    zero, constant = (method_of("paper1", "time.end=0.2", "time.scheme=crank-nicolson", *HOT,
                                *ELIMINATED, *extra)
                      for extra in (("heat_exchange.law=gap", "heat_exchange.k1=0"), ()))
    for _ in range(200):
        zero.advance()
        constant.advance()
    np.testing.assert_array_equal(zero.values, constant.values)
    zero, constant = (rodfem.simulate(rodfem.scene.load("paper1", [
        "solver.method=direct", "time.end=1", "time.scheme=crank-nicolson", *HOT, *ELIMINATED,
        'output.history=["theta_1", "heat_flux_1"]', *extra])).history
        for extra in (("heat_exchange.law=pressure", "heat_exchange.k1=0"), ()))
    np.testing.assert_array_equal(zero, constant)  # the compiled loop's eliminated end too


def test_heat_flux_column_is_the_steps_flux(monkeypatch):
    """heat_flux_1 = h (θ(1) − θ_O), h = k + q: in the paper's scheme, the step's own flux at x = 1
    is q (θⁿ(1) − θ_O) with q at Uⁿ(1) and pⁿ, so heat_flux_1 − k (θ(1) − θ_O) is the flux φ that
    the step put in its heat row (the PETSc loop's, recorded as it solves)."""
    from rodfem.solver.methods import exchange_step

    fluxes = []
    solve = exchange_step.ExchangeStep.solve

    def recorded(self, *args):
        p, phi = solve(self, *args)
        fluxes.append(phi)
        return p, phi

    monkeypatch.setattr(exchange_step.ExchangeStep, "solve", recorded)
    monkeypatch.setenv("RODFEM_KERNEL", "0")
    scene = rodfem.scene.load("paper1", ["solver.method=direct", "time.end=0.5", *LAWS["gap"],
                                         *HOT, 'output.history=["theta_1", "heat_flux_1"]'])
    rows = rodfem.simulate(scene).history
    theta_1, flux = rows["theta_1"][2:], rows["heat_flux_1"][2:]
    phi = np.array(fluxes)  # steps 2 .. N (step 1 is the paper's first, Method._first_step)
    assert phi.size == theta_1.size
    k, theta_O = scene["model.k"], scene["obstacle.temperature"]
    extra = flux - k * (theta_1 - theta_O)
    assert np.all(phi < 0.0)  # heat enters from the hot obstacle
    assert np.all(np.abs(extra - phi) <= 64 * EPS * np.abs(flux).max())


@pytest.mark.parametrize("law", sorted(LAWS))
def test_the_responses_solve_their_loads(law):
    """C q_c = [0; −e] and C q_h = [−e; 0], each computed from a vector that held the other's
    load: the responses are to their own loads alone (PETSc ≥ 3.20 skips zeroing a vector whose
    state says it is zero, and the loads are written through its parts)."""
    method = method_of("paper1", *LAWS[law], *HOT)
    C = method.coupled_operator()
    n = method.disc.nodes.size
    for response, part in ((method.response, 1), (method.heat_response, 0)):
        load = C.createVecLeft()
        C.mult(response, load)
        expected = np.zeros(2 * n)
        expected[part * n + n - 1] = -1.0
        scale = np.abs(load.array_r).max() + 1.0
        assert np.abs(load.array_r - expected).max() < 64 * np.finfo(float).eps * scale * n
