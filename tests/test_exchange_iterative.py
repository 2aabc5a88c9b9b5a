"""Picard and Newton with a variable heat exchange (``heat_exchange.law`` = pressure | gap), and
the compiled Picard loop with it.

The scene: paper1 for t ≤ 1 (690 steps in contact) with the rod at θ_A = 0 and a hot obstacle,
θ_O = 10, so that the heat crosses the contact; k₁ = 0.5 changes θ(1) by a fifth to a third
(measured: 0.33 of max |θ(1)| with the pressure law, 0.21 with the gap law).

* Picard (tol 1e-10 in the change of an iterate, h at the previous iterate) and Newton (each step
  to round-off) agree with the exact direct method to 1e-9 per history column, as in
  tests/test_methods.py (measured: at most 4e-11; the rigid obstacle with Newton too).
* k₁ = 0 with either law is the constant law bit for bit (history.h5), through the variable
  law's code (its q is asked for, and the compiled loop is given the law).
* The compiled Picard loop takes the PETSc loop's iterations at every step, and its values
  agree to 64 eps per step (tests/test_picard_kernel.py's standard).
* Newton's Jacobian has the exchange's derivatives: from a zero first guess in contact a step
  takes at most three iterations, the first reducing ‖F‖ by 1e5 and more (1e6 measured; 1e3
  without the derivative in U(1), which then takes an iteration more).
* A stopped run resumes to the uninterrupted run, bit for bit.
* Under ``mpirun -n 2`` the runs on the world's ranks are those on one rank's, bit for bit.
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI
from test_resume import assert_same_run

import rodfem
import rodfem.scene
from conftest import COMM, history_rows, serial_only
from rodfem.discrete.discretisation import Discretisation
from rodfem.model.exchange import GapLaw, PressureLaw
from rodfem.output.history import History
from rodfem.solver.compiled import compiled_loop as compiled_loop_of
from rodfem.solver.compiled import loop as compiled_loop
from rodfem.solver.compiled import picard as picard_kernel
from rodfem.solver.methods.newton import NewtonMethod
from rodfem.solver.methods.picard import PicardMethod

EPS = np.finfo(float).eps
PICARD = 1e-9  # Picard (tol 1e-10) against a step solved to round-off
HOT = {"time.end": 1.0, "model.theta_A": 0.0, "obstacle.temperature": 10.0,
       "output.every": 100000, "output.history": ["theta_1", "heat_flux_1"]}
LAWS = {"pressure": {}, "gap": {"heat_exchange.length": 0.05}}
SCHEMES = ("paper", "crank-nicolson")


def overrides(law: str, method: str, scheme: str, k1: float = 0.5, **more) -> dict:
    values = {**HOT, "solver.method": method, "time.scheme": scheme,
              "heat_exchange.law": law, **more}
    if law != "constant":
        values.update({"heat_exchange.k1": k1, **LAWS[law]})
    return values


def history(values: dict, comm=COMM) -> np.ndarray:
    result = rodfem.simulate("paper1", values, comm=comm)
    assert result.status == "complete", result.summary
    rows = result.history
    return np.column_stack([np.asarray(rows[name], dtype=float) for name in rows.dtype.names])


def relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    scale = np.abs(b).max(axis=0)
    return np.abs(a - b).max(axis=0) / np.where(scale > 0, scale, 1.0)


@pytest.fixture(autouse=True)
def petsc_loop_unless_asked(monkeypatch):
    """The PETSc loops, unless a test asks for the compiled one."""
    monkeypatch.setenv("RODFEM_KERNEL", "0")


_direct = {}


def direct(values: dict) -> np.ndarray:
    """The exact method's history of the same scene (once per session)."""
    key = tuple(sorted((k, str(v)) for k, v in {**values, "solver.method": "direct"}.items()))
    if key not in _direct:
        _direct[key] = history({**values, "solver.method": "direct"})
    return _direct[key]


def agreement(method: str, law: str, scheme: str, **more) -> np.ndarray:
    """Per history column, the method's relative difference from the direct method's (the
    iterations column left out)."""
    values = overrides(law, method, scheme, **more)
    error = relative(history(values), direct(values))
    error[6] = 0.0
    return error


@pytest.mark.parametrize("method", ["picard", "newton"])
@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("law", LAWS)
def test_agrees_with_the_direct_method(law, scheme, method):
    values = overrides(law, method, scheme)
    run, exact = history(values), direct(values)
    constant = direct(overrides("constant", method, scheme))
    theta_1 = 7  # t, u_1, u_half, ut_1, sigma_1, energy, iterations, theta_1, heat_flux_1
    assert np.count_nonzero(exact[:, 4] < 0) > 600  # in contact for most of the run
    assert relative(exact, constant)[theta_1] > 0.1  # the exchange matters
    error = relative(run, exact)
    error[6] = 0.0  # iterations: the methods' own
    assert error.max() <= PICARD, error
    if method == "newton":
        assert run[:, 6].max() <= 3  # a few iterations a step


@pytest.mark.filterwarnings("ignore::rodfem.CoarseStepWarning")
@pytest.mark.parametrize("law", LAWS)
def test_newton_rigid_obstacle_agrees_with_the_direct_method(law):
    """The rigid obstacle: the pressure law takes Signorini's multiplier (measured: 4e-11)."""
    assert agreement("newton", law, "paper", **{"obstacle.kind": "rigid"}).max() <= PICARD


@pytest.mark.parametrize("exponent", [0.5, 1.0])
def test_newton_rigid_obstacle_off_its_bound_has_no_pressure(exponent):
    """A rod that never reaches the rigid obstacle has no multiplier, in the iterations too: the
    pressure law adds nothing, and each step is one iteration, as without the exchange (with a
    multiplier read off an unconverged residual, m = 1/2 diverged at step 47)."""
    free = {"obstacle.kind": "rigid", "mesh.cells": 20, "time.dt": 0.01, "time.end": 2.0,
            "heat_exchange.exponent": exponent}
    newton = rodfem.simulate("barber", {**free, "solver.method": "newton"}, comm=MPI.COMM_SELF)
    direct = rodfem.simulate("barber", {**free, "solver.method": "direct"}, comm=MPI.COMM_SELF)
    assert newton.status == direct.status == "complete"
    assert newton.history["u_1"].max() < 0.5 * rodfem.scene.load("barber")["obstacle.gap"]
    assert newton.history["iterations"].max() == 1
    u_1 = direct.history["u_1"]
    assert np.abs(newton.history["u_1"] - u_1).max() <= PICARD * np.abs(u_1).max()


@pytest.mark.parametrize("method", ["picard", "newton"])
@pytest.mark.parametrize("law", LAWS)
def test_uncoupled_agrees_with_the_direct_method(law, method):
    """a = 0: the heat sees the motion only through q; Picard solves it again as q changes.
    (The motion is the constant law's, whose Picard iterates stop 2e-9 from the exact step in
    σ(1): the heat's columns are compared.)"""
    error = agreement(method, law, "paper", **{"model.a": 0.0})
    assert error[[7, 8]].max() <= PICARD, error
    if method == "newton":
        assert error.max() <= PICARD, error


@pytest.mark.parametrize("method", ["picard", "newton"])
@pytest.mark.parametrize("law", LAWS)
def test_eliminated_end_agrees_with_the_direct_method(law, method):
    """Crank–Nicolson with the end without mass nor viscosity (a = 0), eliminated: q at the
    settled U(1)."""
    end = {"model.a": 0.0, "model.zeta": 0.0, "discretisation.mass": "redistributed"}
    error = agreement(method, law, "crank-nicolson", **end)
    assert error.max() <= PICARD, error


def counting(monkeypatch, law_class) -> list:
    """Count the calls of a law's q (the variable path runs)."""
    calls, extra = [], law_class.extra

    def counted(self, y, p):
        calls.append(1)
        return extra(self, y, p)

    monkeypatch.setattr(law_class, "extra", counted)
    return calls


@pytest.mark.parametrize("case", [("picard", "paper", {}), ("picard", "crank-nicolson", {}),
                                  ("picard", "paper", {"model.a": 0.0}),
                                  ("newton", "paper", {}), ("newton", "crank-nicolson", {}),
                                  ("newton", "paper", {"obstacle.kind": "rigid"}),
                                  ("compiled", "paper", {}), ("compiled", "crank-nicolson", {})],
                         ids=lambda c: "-".join([c[0], c[1], *c[2]]))
@pytest.mark.filterwarnings("ignore::rodfem.CoarseStepWarning")
def test_zero_k1_is_the_constant_law_bitwise(simulate, monkeypatch, case):
    method, scheme, more = case
    if method == "compiled":
        monkeypatch.setenv("RODFEM_KERNEL", "1")
        method = "picard"
    given = []
    set_exchange = compiled_loop.CompiledLoop.set_exchange
    monkeypatch.setattr(compiled_loop.CompiledLoop, "set_exchange",
                        staticmethod(lambda target, m: (given.append(m.exchange.name),
                                                        set_exchange(target, m))))
    settings = [f"{k}={v}" for k, v in overrides("constant", method, scheme, **more).items()
                if not k.startswith("output.")]
    _, out = simulate("paper1", *settings, "output.every=100000")
    expected = history_rows(out)
    for law, law_class in (("pressure", PressureLaw), ("gap", GapLaw)):
        calls = counting(monkeypatch, law_class)
        _, out = simulate("paper1", *settings, f"heat_exchange.law={law}", "heat_exchange.k1=0",
                          "output.every=100000")
        rows = history_rows(out)
        if case[0] == "compiled":
            assert given[-1] == law
        else:
            assert len(calls) > 1000  # the variable law's path
        assert rows.shape == expected.shape
        np.testing.assert_array_equal(rows.view(np.int64), expected.view(np.int64))


def kernel_pair(values: dict):
    """Two Picard methods of a scene, one for the PETSc loop and one for the compiled loop."""
    scene = rodfem.scene.load("paper1", [f"{k}={v}" for k, v in values.items()
                                         if not k.startswith("output.")])
    disc = Discretisation(scene, COMM)
    petsc, compiled = PicardMethod(disc), PicardMethod(disc)
    h_petsc, h_compiled = (History(disc, scene.steps + 1) for _ in range(2))
    kernel = picard_kernel.PicardKernel(compiled, h_compiled)
    for method, h in ((petsc, h_petsc), (compiled, h_compiled)):
        h.record(method)
        method.advance()  # the first step is the caller's
        h.record(method)
    return scene, petsc, h_petsc, compiled, h_compiled, kernel


@pytest.mark.parametrize("mass", ["lumped", "redistributed"])
@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("law", LAWS)
def test_compiled_picard_loop_as_petsc_loop(law, scheme, mass):
    values = overrides(law, "picard", scheme, **{"discretisation.mass": mass})
    scene, petsc, h_petsc, compiled, h_compiled, kernel = kernel_pair(values)
    assert kernel._problem.exchange.law == compiled.exchange.code
    steps = scene.steps
    for _ in range(steps - 1):
        petsc.advance()
        h_petsc.record(petsc)
    done = 1
    while done < steps:
        size = min(300, steps - done)
        kernel.advance(size, h_compiled.reserve(size))
        h_compiled.commit(size)
        done += size
    rows, rows_k = h_petsc.take(), h_compiled.take()
    np.testing.assert_array_equal(rows_k[:, 6], rows[:, 6])  # the same iterations, every step
    assert np.count_nonzero(rows[:, 4]) > 600
    tol = 64 * EPS * steps
    u = np.abs(rows[:, 1]).max()
    scales = np.abs(rows).max(axis=0)
    scales[3], scales[4] = max(scales[3], u / scene["time.dt"]), max(
        scales[4], u / scene["obstacle.epsilon"])
    error = np.abs(rows_k - rows).max(axis=0) / scales
    assert error.max() <= tol, error
    assert np.abs(compiled.values - petsc.values).max() <= tol * np.abs(petsc.values).max()


@pytest.mark.parametrize("law", LAWS)
def test_compiled_loop_takes_a_variable_exchange(monkeypatch, law):
    """A run picks the compiled Picard loop with a variable exchange: the PETSc loop's
    iterations at every step, its history to round-off."""
    values = overrides(law, "picard", "crank-nicolson")
    scene = rodfem.scene.load("paper1", [f"{k}={v}" for k, v in values.items()
                                         if not k.startswith("output.")])
    disc = Discretisation(scene, COMM)
    petsc = history(values)
    monkeypatch.setenv("RODFEM_KERNEL", "1")
    assert isinstance(compiled_loop_of(PicardMethod(disc), History(disc)),
                      picard_kernel.PicardKernel)
    compiled = history(values)
    np.testing.assert_array_equal(compiled[:, 6], petsc[:, 6])
    assert relative(compiled, petsc).max() <= 64 * EPS * scene.steps


@pytest.mark.parametrize("law", LAWS)
def test_newton_converges_quadratically(law):
    """A step in contact from a zero first guess, the pressure law with m = 2 (q = k₁ p²)."""
    more = {"heat_exchange.exponent": 2.0} if law == "pressure" else {}
    values = overrides(law, "newton", "paper", **more)
    scene = rodfem.scene.load("paper1", [f"{k}={v}" for k, v in values.items()
                                         if not k.startswith("output.")])
    method = NewtonMethod(Discretisation(scene, COMM))
    iterations = []
    while not (method.pressure > 0.0 and method.n > 300):
        method.advance()
        iterations.append(method.iterations)
    assert max(iterations) <= 3
    method.x.zeroEntries()
    method.snes.setConvergenceHistory(length=100, reset=True)
    method.advance()
    norms = method.snes.getConvergenceHistory()[0]
    assert method.pressure > 0.0 and method.iterations <= 3, norms
    assert norms[1] <= 1e-5 * norms[0], norms


@pytest.mark.skipif(COMM.size == 1, reason="compares the ranks' run with one rank's")
@pytest.mark.parametrize("method", ["picard", "newton", "compiled"])
@pytest.mark.parametrize("law", LAWS)
def test_ranks_as_serial(monkeypatch, law, method):
    if method == "compiled":
        monkeypatch.setenv("RODFEM_KERNEL", "1")
        method = "picard"
    values = overrides(law, method, "crank-nicolson", **{"time.end": 0.5})
    np.testing.assert_array_equal(history(values, COMM), history(values, MPI.COMM_SELF))


@serial_only
@pytest.mark.parametrize("method", ["picard", "newton", "compiled"])
def test_resumes_to_the_same_run(tmp_path, method):
    """A run to t = 0.5 resumed to t = 1 is the run to t = 1 (history, fields, summary)."""
    env = {**os.environ, "RODFEM_KERNEL": "1" if method == "compiled" else "0"}
    method = "picard" if method == "compiled" else method
    scene = ["paper1", "--quiet", "--set", "output.every=50", "--set", "output.checkpoint=0",
             *(f"--set={k}={v}" for k, v in overrides("pressure", method, "paper").items()
               if not k.startswith(("output.", "time.end")))]
    command = [str(Path(sys.executable).with_name("rodfem"))]

    def rodfem(*args):
        done = subprocess.run([*command, *map(str, args)], env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, done.stderr

    short, long = tmp_path / "short", tmp_path / "long"
    rodfem("run", *scene, "--set", "time.end=0.5", "--out", short)
    rodfem("resume", short, "--set", "time.end=1", "--quiet")
    rodfem("run", *scene, "--set", "time.end=1", "--out", long)
    assert_same_run(short, long)
