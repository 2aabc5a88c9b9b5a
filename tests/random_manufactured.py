"""The manufactured scene of ``tests/test_accuracy_targets.py`` and ``benchmarks/
bench_estimates.py``: three declared measures with exact values, and random scenes of it with
accuracy targets (the model's a, b, ζ, the end time, the first mesh and step, the scheme and the
target), on which the estimates of ``[accuracy]`` are checked against the exact errors.

The manufactured solution u = (cos t + sin t) sin(πx/2), θ = e^{−t} x (1 − x)² and three of its
measures' exact values at T: u(1, T), θ(1/2, T) and ∫₀ᵀ θ(1/2, t) dt.
"""

from __future__ import annotations

import math
import random

MEASURES = """
[measures]
u_end = { column = "u_1", reduce = "final" }
theta_mid = { column = "theta@0.5", reduce = "final" }
theta_int = { column = "theta@0.5", reduce = "integral" }
"""


def exact(end: float) -> dict[str, float]:
    """The exact values of :data:`MEASURES` at the end time ``end``."""
    return {"u_end": math.cos(end) + math.sin(end), "theta_mid": math.exp(-end) / 8.0,
            "theta_int": (1.0 - math.exp(-end)) / 8.0}


def random_scene(rng: random.Random) -> tuple[str, float]:
    """A random manufactured scene with an accuracy target (its TOML text) and its end time."""
    a, b, zeta = rng.uniform(0.1, 1.0), rng.uniform(0.5, 2.0), rng.uniform(0.05, 0.5)
    end = rng.choice([0.5, 1.0, 1.5])
    scheme = rng.choice(["crank-nicolson", "paper"])
    target = rng.choice([1e-2, 1e-3]) if scheme == "crank-nicolson" else 1e-2
    text = (f'scene = "manufactured"\n[model]\na = {a!r}\nb = {b!r}\nzeta = {zeta!r}\n'
            f'[mesh]\ncells = {rng.choice([8, 16])}\n[time]\nend = {end!r}\n'
            f'dt = {end / rng.choice([10, 20])!r}\nscheme = "{scheme}"\n'
            f'[accuracy]\ntarget = {target!r}\nruns_max = 14\n' + MEASURES)
    return text, end
