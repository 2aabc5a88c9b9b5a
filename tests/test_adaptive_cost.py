"""What makes adaptive steps cheaper must not change them (rodfem/solver/adaptive).

The error norm and the extrapolation are written to allocate little; they must give what their
definitions give, bit for bit (the same operations in the same order). The methods of the
controller's step sizes are made once each and kept; a size off the ladder (tried by an event's
root-finder) gets the quicker-to-build compiled loop that reads a row per node, which takes the
same steps bit for bit (tests/test_kernel.py, tests/test_picard_kernel.py).
"""

import numpy as np
import pytest

import rodfem.scene
from conftest import COMM
from rodfem.run import simulate
from rodfem.solver.adaptive import stepper as stepper_module
from rodfem.solver.adaptive.compiled import CompiledSteps
from rodfem.solver.adaptive.control import ErrorNorm, extrapolate, rung


def norm_by_definition(norm: ErrorNorm, error, y, tolerance):
    """control.ErrorNorm's docstring, written plainly: RMS per field over the largest max-norm
    so far, the contact force over the largest stress so far, the velocity floor S/√b."""
    n = norm.nodes
    u = y[2 * n:3 * n]
    strain = float(np.max(np.abs(np.diff(u)))) / norm.cell if n > 1 else 0.0
    sizes = np.array([np.max(np.abs(y[:n])), np.max(np.abs(y[n:2 * n])), np.max(np.abs(u)),
                      max(abs(float(y[3 * n])), strain)])
    scale = np.maximum(norm.maxima, sizes)
    grown = scale.copy()
    if norm.b > 0.0:
        scale[1] = max(scale[1], norm.dt0 * scale[3] / np.sqrt(norm.b))
    parts = [np.sqrt(np.mean(error[k * n:(k + 1) * n] ** 2)) for k in range(3)]
    parts.append(abs(float(error[3 * n])))
    ratios = [p / (tolerance * s) if s > 0.0 else (0.0 if p == 0.0 else np.inf)
              for p, s in zip(parts, scale)]
    return float(max(ratios)), grown


@pytest.mark.parametrize("nodes", [1, 2, 9, 251, 1001])
@pytest.mark.parametrize("b", [0.0, 1.0])
def test_norm_is_its_definition_bit_for_bit(nodes, b):
    rng = np.random.default_rng(nodes)
    norm = ErrorNorm(nodes, 1.0 / nodes, b, 1e-3)
    for _ in range(20):
        y = rng.standard_normal(3 * nodes + 1) * 10.0 ** rng.integers(-6, 6)
        error = rng.standard_normal(3 * nodes + 1) * 10.0 ** rng.integers(-12, 0)
        expected, grown = norm_by_definition(norm, error, y, 1e-3)
        assert norm(error, y, 1e-3) == expected
        assert np.array_equal(norm.grown(y), grown)  # the sizes counted once, the same
        norm.maxima = norm.grown(y)


def test_extrapolate_is_lagrange_bit_for_bit():
    rng = np.random.default_rng(7)
    for points in (2, 3):
        times = sorted(rng.random(points).tolist())
        states = [rng.standard_normal(301) for _ in range(points)]
        t = times[-1] + rng.random()
        expected = np.zeros(301)
        for i, ti in enumerate(times):
            weight = 1.0
            for j, tj in enumerate(times):
                if j != i:
                    weight *= (t - tj) / (ti - tj)
            expected += weight * states[i]
        assert np.array_equal(extrapolate(times, states, t), expected)


@pytest.mark.parametrize("method", ["picard", "direct"])
def test_ladder_sizes_made_once(monkeypatch, method):
    """paper1 adaptive to t = 2 (three contact events), every step the stepper's: every size
    of the ladder is made once; the sizes off it are made with ``once`` (a compiled loop quick to
    build). (The compiled adaptive steps form their sizes in C, in a pool of their own.)"""
    monkeypatch.setattr(CompiledSteps, "ready", lambda self: False)
    made = []
    init = stepper_module.AdaptiveStepper.__init__

    def counting(self, home, scene, make, *args):
        def counted(h, once):
            made.append((h, once, rung(self.dt0, h) == h))
            return make(h, once)

        init(self, home, scene, counted, *args)

    monkeypatch.setattr(stepper_module.AdaptiveStepper, "__init__", counting)
    scene = rodfem.scene.load("paper1", ["time.adaptive=true", "time.end=2",
                                         f"solver.method={method}"])
    result = simulate(scene, None, COMM, progress=False)
    assert result.status == "complete" and result.summary["adaptive"]["events"] >= 2
    ladder = [h for h, _, on in made if on]
    assert ladder and len(ladder) == len(set(ladder))
    assert all(once == (not on) for _, once, on in made)
    assert any(once for _, once, _ in made)  # the events' sizes
