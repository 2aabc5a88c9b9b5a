"""Adaptive time steps (``time.adaptive = true``) against independent references.

* An adaptive run's steps (its ``dt`` column) replayed by the NumPy reference of the paper's
  algebra at those steps (tests/reference_steps.py, which shares no code with rodfem): the same
  history, for both time schemes, the elastic and the rigid obstacle.
* Every method and both loops (compiled, PETSc) take the same steps to the same history.
* ``impact``: the contact events located to the discrete contact change, the impact at t = 1,
  the energy constant to round-off.
* The manufactured solution's error falls with the tolerance; the energy of either scheme never
  grows; bad adaptive settings are one-line errors.

**Why 1e-9 against the reference.** Both codes solve the same banded systems, whose condition
numbers here are below 1e4 (h ≥ 1e-3 on 100–250 cells: ‖A‖‖A⁻¹‖ ≈ 1 + 4 (Δt/Δx)² for the
momentum block), each step to κ ε_mach ≈ 2e-12 relative (the reference refines its LU once),
and the schemes are stable (energy bounded), so these round-offs add up rather than grow: over
the ≲ 1000 steps of these runs at most ~1e-9 of a column's size, and in practice (measured
below) far less. Both take exactly the same step sizes (the reference reads rodfem's), so no
error in the timing of an event enters.
"""

from pathlib import Path

import numpy as np
import pytest
from reference_steps import simulate_steps

import rodfem.scene
from conftest import COMM, serial_only
from rodfem.output.readers import HISTORY, read_history

TOL = 1e-9
COMPARED = ("u_1", "sigma_1", "energy", "u_half", "ut_1")


def history(out):
    return read_history(Path(out) / HISTORY)


def replay(scene, steps):
    """The reference at the given steps, for the scene's parameters."""
    m, p = scene.values["model"], scene.parameters

    def initial(name):
        return lambda x: scene.initial(name)(x, p)

    rigid = scene["obstacle.kind"] == "rigid"
    return simulate_steps(
        a=m["a"], b=m["b"], zeta=m["zeta"], k=m["k"], theta_A=m["theta_A"],
        epsilon=0.0 if rigid else scene["obstacle.epsilon"], gap=scene["obstacle.gap"],
        cells=scene["mesh.cells"], steps=steps, mass=scene["discretisation.mass"],
        theta0=initial("theta0"), u0=initial("u0"), u1=initial("u1"),
        scheme=scene["time.scheme"], obstacle="rigid" if rigid else "elastic",
    )


def relative(got, expected):
    """max |got − expected| over max |expected| (the difference itself where that is 0)."""
    return np.abs(got - expected).max() / (np.abs(expected).max() or 1.0)


PAPER1 = ("paper1", "time.end=1")
PAPER4 = ("paper4", "time.end=1")
CN = "time.scheme=crank-nicolson"
IMPACT = ("impact", "mesh.cells=100", "time.dt=0.01", "time.end=2.5")
REPLAYED = {
    "paper1": (*PAPER1, "solver.method=direct"),
    "paper1-cn": (*PAPER1, CN, "solver.method=direct"),
    "paper1-cn-consistent": (*PAPER1, CN, "solver.method=direct",
                             "discretisation.mass=consistent"),
    "paper4": (*PAPER4, "solver.method=direct"),
    "paper4-cn": (*PAPER4, CN, "solver.method=direct"),
    "impact-paper-rigid": (*IMPACT, "time.scheme=paper", "discretisation.mass=lumped"),
    "impact-cn-rigid": IMPACT,
}


def adaptive_run(simulate, name, *overrides):
    result, out = simulate(name, "time.adaptive=true", "output.every=0", *overrides)
    assert result.status == "complete", result.error
    return result, history(out)


@serial_only
@pytest.mark.parametrize("case", REPLAYED)
def test_adaptive_history_agrees_with_the_reference_at_its_steps(simulate, case):
    name, *overrides = REPLAYED[case]
    result, rows = adaptive_run(simulate, name, *overrides)
    steps = rows["dt"][1:]
    assert len(set(steps)) > 3, "the steps should vary"
    assert (rows["event"] == 1).any(), "the run should meet a contact event"
    ref = replay(rodfem.scene.load(name, ["time.adaptive=true", *overrides]), steps)
    expected = ref["history"]
    np.testing.assert_allclose(rows["t"], expected[:, 0], rtol=0, atol=1e-12)
    for j, column in enumerate(("u_1", "u_half", "ut_1", "sigma_1", "energy"), start=1):
        error = relative(rows[column], expected[:, j])
        assert error <= TOL, f"{column}: relative difference {error:.2e}"
    for field in ("theta", "u"):
        error = relative(getattr(result, field), ref[field])
        assert error <= TOL, f"final {field}: relative difference {error:.2e}"


def _compare_runs(rows, other, tolerance):
    """The largest relative difference of two histories' columns (the same steps asserted)."""
    assert len(rows) == len(other), f"{len(rows)} steps against {len(other)}"
    np.testing.assert_array_equal(rows["event"], other["event"])
    # The ladder's steps are the same numbers; a located event's step (and the last, to the end)
    # is where the contact function crosses 0, found from values that differ by round-off.
    ladder = (rows["event"] == 0) & (np.arange(len(rows)) < len(rows) - 1)
    np.testing.assert_array_equal(rows["dt"][ladder], other["dt"][ladder])
    errors = {"dt": relative(other["dt"], rows["dt"])}
    errors.update({column: relative(other[column], rows[column]) for column in COMPARED})
    for column, error in errors.items():
        assert error <= tolerance, f"{column}: relative difference {error:.2e}"
    return errors


METHODS = {
    # scene, the methods it allows
    "paper1": ((*PAPER1, "solver.tol=1e-13"), ("newton", "picard")),
    "paper1-cn": ((*PAPER1, CN, "solver.tol=1e-13"), ("newton", "picard")),
    "impact-cn-rigid": (IMPACT, ("newton",)),
}


@serial_only
@pytest.mark.parametrize("case", METHODS)
def test_every_method_and_loop_takes_the_same_steps(simulate, case, monkeypatch):
    """direct with the compiled loop against direct with the PETSc loop (RODFEM_KERNEL=0),
    newton and picard: the same steps and events, the histories within TOL (Newton and Picard
    stop within solver.tol = 1e-13 of the step's solution)."""
    (name, *overrides), methods = METHODS[case]
    _, rows = adaptive_run(simulate, name, *overrides, "solver.method=direct")
    monkeypatch.setenv("RODFEM_KERNEL", "0")
    _, petsc = adaptive_run(simulate, name, *overrides, "solver.method=direct")
    _compare_runs(rows, petsc, TOL)
    monkeypatch.delenv("RODFEM_KERNEL")
    for method in methods:
        _, other = adaptive_run(simulate, name, *overrides, f"solver.method={method}")
        _compare_runs(rows, other, TOL)
