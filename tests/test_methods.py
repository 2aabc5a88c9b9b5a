"""rodfem's three ways of solving a step (solver.method = picard | newton | direct) and its two
obstacles (obstacle.kind = elastic | rigid), against each other and against the oracle
tests/reference.py (``method="exact"``, ``obstacle="rigid"``).

"direct" and "newton" both solve (3.1)–(3.2) exactly, so they agree with the oracle's exact step to
round-off: 1e-10 relative. The oracle itself is within 2.3e-12 of an 80-bit extended-precision run
of paper1 and paper5 over the full 8000 steps. Picard stops at its tolerance (1e-10 in the change
of an iterate) and agrees with them to 1e-9 (the oracle's Picard and exact step differ by at most
1.6e-10 on the five paper scenes, in u_t(1) of paper3).

"Relative" is per history column: max |x − y| / max |y| over the column. Final fields: U against
max |U|; the shifted temperature Θ against max |Θ⁰|, its size during the run, because Θ decays
to 0 (max |Θ| is 4e-7 at t = 8 in paper2, where Picard's Θ differs from the exact step's by 2e-14,
5e-8 of the final max but 1e-15 of Θ⁰).
"""

import json

import numpy as np
import pytest
from reference import simulate as reference

import rodfem.scene
from conftest import COMM, history_rows
from rodfem.cli import main

EPS = np.finfo(float).eps
from rodfem.output.columns import NAMES as COLUMNS  # noqa: E402

QUIET = "output.every=100000"
EXACT = 1e-10  # direct, newton against each other and the oracle's exact step
PICARD = 1e-9  # Picard (tol 1e-10) against an exact step


def run_reference(scene, method="exact", obstacle="elastic"):
    m, p = scene.sections["model"], scene.parameters

    def initial(name):
        return lambda x: scene.initial(name)(x, p)

    return reference(
        a=m["a"], b=m["b"], zeta=m["zeta"], k=m["k"], theta_A=m["theta_A"],
        epsilon=scene["obstacle.epsilon"], gap=scene["obstacle.gap"], cells=scene["mesh.cells"],
        dt=scene["time.dt"], end=scene["time.end"], mass=scene["discretisation.mass"],
        tol=scene["solver.tol"], max_iterations=scene["solver.max_iterations"],
        theta0=initial("theta0"), u0=initial("u0"), u1=initial("u1"), increment=True,
        method=method, obstacle=obstacle,
    )


_references = {}


def cached_reference(name, overrides, method="exact", obstacle="elastic"):
    """The oracle's run of a scene, once per session (every rank computes its own)."""
    key = (name, tuple(overrides), method, obstacle)
    if key not in _references:
        _references[key] = run_reference(rodfem.scene.load(name, list(overrides)), method,
                                          obstacle)
    return _references[key]


def theta_scale(name, overrides):
    """max |Θ⁰| over the nodes, Θ⁰ = θ₀ + θ_A r interpolated."""
    scene = rodfem.scene.load(name, list(overrides))
    k, theta_a = scene["model.k"], scene["model.theta_A"]
    x = np.linspace(0.0, 1.0, scene["mesh.cells"] + 1)
    theta0 = scene.initial("theta0")(x, scene.parameters) + theta_a * (k / (k + 1) * x - 1)
    return np.abs(theta0).max()


def history_of(out):
    return history_rows(out)


def assert_histories_agree(history, expected, tol, what):
    assert history.shape == expected.shape, what
    np.testing.assert_array_equal(history[:, 0], expected[:, 0])
    for j, column in enumerate(COLUMNS[1:6], start=1):
        error = np.abs(history[:, j] - expected[:, j]).max() / np.abs(expected[:, j]).max()
        assert error <= tol, f"{what}: {column} relative difference {error:.2e}"


def assert_fields_agree(theta, u, expected_theta, expected_u, theta_size, tol, what):
    error = np.abs(u - expected_u).max() / np.abs(expected_u).max()
    assert error <= tol, f"{what}: final u relative difference {error:.2e}"
    error = np.abs(theta - expected_theta).max() / max(theta_size, np.abs(expected_theta).max())
    assert error <= tol, f"{what}: final theta relative difference {error:.2e} (of max |Θ⁰|)"


def assert_solved_steps(history, b, method):
    """The iterations column: 0 in the rows that solve nothing (0; 1 too if b > 0), 1 in every
    other row for direct, at least 1 for newton and picard."""
    first = 1 if b == 0 else 2
    assert (history[:first, 6] == 0).all()
    if method == "direct":
        assert (history[first:, 6] == 1).all()
    else:
        assert (history[first:, 6] >= 1).all()


# ---------------------------------------------------------------------------------------------
# 1. The three methods against each other.


@pytest.mark.parametrize("name", rodfem.scene.BUILTIN)
def test_methods_agree_on_the_paper_scenes(simulate, name):
    """Full length (8000 steps)."""
    runs = {}
    for method in ("direct", "newton", "picard"):
        result, out = simulate(name, QUIET, f"solver.method={method}")
        assert result.status == "complete", (method, result.summary.get("error"))
        runs[method] = (result, history_of(out))
        assert_solved_steps(runs[method][1], 1.0, method)
    size = theta_scale(name, [])
    direct, direct_history = runs["direct"]
    assert (direct_history[:, 4] < 0).any(), "the comparison should cover contact"
    for method in ("newton", "picard"):
        result, history = runs[method]
        assert_histories_agree(history, direct_history, PICARD, f"{name} {method}")
        assert_fields_agree(result.theta, result.u, direct.theta, direct.u, size, PICARD,
                            f"{name} {method}")
        np.testing.assert_array_equal(result.x, direct.x)


# ---------------------------------------------------------------------------------------------
# 2. direct and newton against the oracle's exact step.

SCENES = {
    "paper1": ("paper1", []),
    "paper5": ("paper5", []),
    "a=0": ("paper1", ["model.a=0", "time.end=1"]),
    "zeta=0": ("paper1", ["model.zeta=0", "obstacle.epsilon=1", "mesh.cells=33", "time.end=1"]),
    "b=0": ("paper1", ["model.b=0", "mesh.cells=50", "time.end=1"]),
    "consistent mass": ("paper1", ["discretisation.mass=consistent", "time.end=2"]),
}


@pytest.mark.parametrize("method", ["direct", "newton"])
@pytest.mark.parametrize("scene", SCENES)
def test_exact_methods_agree_with_the_oracle(simulate, scene, method):
    """The paper's first and fifth experiments full length, and the extra scenes of
    test_reference: no thermal coupling, no viscosity (ε = 1, 33 cells: x = 0.5 between nodes),
    the quasi-static b = 0 (50 cells; step 1 is a full step, u₁ unused), the consistent mass."""
    name, overrides = SCENES[scene]
    result, out = simulate(name, QUIET, f"solver.method={method}", *overrides)
    assert result.status == "complete", result.summary.get("error")
    history = history_of(out)
    ref = cached_reference(name, overrides)
    expected = ref["history"]
    assert (expected[:, 4] < 0).any(), "the comparison should cover contact"
    assert_histories_agree(history, expected, EXACT, f"{scene} {method}")
    b = rodfem.scene.load(name, overrides)["model.b"]
    assert_solved_steps(history, b, method)
    if method == "direct":
        np.testing.assert_array_equal(history[:, 6], expected[:, 6])
    assert_fields_agree(result.theta, result.u, ref["theta"], ref["u"],
                        theta_scale(name, overrides), EXACT, f"{scene} {method}")
    np.testing.assert_array_equal(result.x, ref["x"])


# ---------------------------------------------------------------------------------------------
# 3. The rigid obstacle.

RIGID = {
    "paper1": ("paper1", []),
    "b=0": ("paper1", ["model.b=0", "mesh.cells=50", "time.end=1"]),
}
# Over the whole of paper1 (impacts at t = 0.186, 3.035, 5.719) u_t(1) and σ(1) of the rigid
# obstacle are compared to 1e-9, from t = 2 on: at an impact u_t(1) = (g − Uⁿ⁻¹(1))/Δt and
# λⁿ = (s₀ − g)/w, w = 7.0e-5 the rod's compliance at x = 1 over one step, so an absolute drift δ
# of the state shows as δ/Δt and δ/w (1e3 and 1.4e4 times δ, against max |u_t(1)| = 1.07 and
# max λ = 14). The state drifts by round-off over the steps (the oracle's U(1) is 1.2e-12 relative
# from an 80-bit run; rodfem's direct 4.5e-12, newton 7.6e-13), so these two columns reach, against
# the 80-bit run: oracle 6.4e-11 and 7.0e-11, newton 5.2e-11 and 5.8e-11, direct 2.5e-10 and
# 2.7e-10 (at t = 5.719); direct against the oracle 3.1e-10 and 3.4e-10. Up to t = 2 (the first
# impact and release, t = 0.89) every column is within 1e-10 (direct: 4.9e-11, 5.5e-11).
RIGID_HORIZON, RIGID_AMPLIFIED = 2.0, 1e-9


@pytest.mark.parametrize("method", ["direct", "newton"])
@pytest.mark.parametrize("scene", RIGID)
def test_rigid_obstacle_agrees_with_the_oracle(simulate, scene, method):
    """Signorini's condition at x = 1, from history.h5: Uⁿ(1) ≤ g to round-off (a few ulps of g;
    the oracle and rodfem are at g exactly), σ(1) = −λⁿ ≤ 0, λⁿ(Uⁿ(1) − g) = 0: where U(1) < g,
    λ is at most the round-off of the forces at x = 1, 64 ε_mach max(max λ, a θ_A) (newton takes
    λ from its converged residual, −F_U(1), which is not exactly 0 where the bound is inactive:
    up to 1.4e-14 in paper1, 1.2e-15 with b = 0; direct writes 0); where λ exceeds that,
    U(1) = g to round-off. The energy (no penalty term) is non-increasing. Against the oracle's
    rigid run: 1e-10 over t ≤ 2, and beyond that 1e-10 for U(1), U(0.5), the energy and the
    final fields, 1e-9 for u_t(1) and σ(1) (see RIGID_HORIZON above)."""
    name, overrides = RIGID[scene]
    result, out = simulate(name, QUIET, f"solver.method={method}", "obstacle.kind=rigid",
                           *overrides)
    assert result.status == "complete", result.summary.get("error")
    assert result.summary["energy_non_increasing"] is True
    history = history_of(out)
    scene_ = rodfem.scene.load(name, overrides)
    gap, a_theta = scene_["obstacle.gap"], abs(scene_["model.a"] * scene_["model.theta_A"])
    sigma, gap_left = history[:, 4], history[:, 1] - gap
    touching = 16 * EPS * abs(gap)
    assert gap_left.max() <= touching
    assert sigma.max() <= 0.0
    force_roundoff = 64 * EPS * max(np.abs(sigma).max(), a_theta)
    pushing = -sigma > force_roundoff
    assert np.abs(gap_left[pushing]).max() <= touching
    assert (-sigma[gap_left < -touching]).max(initial=0.0) <= force_roundoff
    assert pushing.sum() > 100 and (gap_left < -1e-3).sum() > 100  # contact and separation
    energy = history[:, 5]
    assert np.diff(energy[1:]).max() <= 64 * EPS * np.abs(energy).max()
    if scene_["model.b"] > 0:
        assert (sigma[:2] == 0).all()
    assert_solved_steps(history, scene_["model.b"], method)

    ref = cached_reference(name, overrides, obstacle="rigid")
    expected = ref["history"]
    early = expected[:, 0] <= RIGID_HORIZON
    assert_histories_agree(history[early], expected[early], EXACT, f"rigid {scene} {method}")
    for j in (1, 2, 5):
        error = np.abs(history[:, j] - expected[:, j]).max() / np.abs(expected[:, j]).max()
        assert error <= EXACT, f"rigid {scene} {method}: {COLUMNS[j]} {error:.2e}"
    for j in (3, 4):
        error = np.abs(history[:, j] - expected[:, j]).max() / np.abs(expected[:, j]).max()
        assert error <= RIGID_AMPLIFIED, f"rigid {scene} {method}: {COLUMNS[j]} {error:.2e}"
    assert_fields_agree(result.theta, result.u, ref["theta"], ref["u"],
                        theta_scale(name, overrides), EXACT, f"rigid {scene} {method}")


# ---------------------------------------------------------------------------------------------
# 4. ε → 0.

EPSILONS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)


def test_elastic_tends_to_rigid_at_rate_one(simulate):
    """As tests/test_oracle.py's test of the same name, with rodfem's direct method: max_{t ≤ 1}
    |u_1^ε − u_1^rigid| on paper1 for ε = 1e-3 … 1e-7. The oracle measures 5.2e-3, 8.8e-4,
    1.23e-4, 1.38e-5, 1.398e-6: local slopes 0.77, 0.86, 0.95, 0.994, least-squares slope 0.895
    over all five (the first decades are pre-asymptotic: at ε = 1e-3 the give ε|σ| is a tenth of
    the gap), 0.971 over the last three, and error / (ε max λ^rigid) = 0.9986 at ε = 1e-7 (the
    difference is the penetration ε λ). Asserted: slope over all five in [0.85, 1.05], over the last
    three within 0.05 of 1, local slopes increasing to within 0.01 of 1, the constant within 1 %."""
    common = (QUIET, "solver.method=direct", "time.end=1")
    _, out = simulate("paper1", *common, "obstacle.kind=rigid")
    rigid = history_of(out)
    errors = []
    for eps in EPSILONS:
        _, out = simulate("paper1", *common, f"obstacle.epsilon={eps!r}")
        errors.append(np.abs(history_of(out)[:, 1] - rigid[:, 1]).max())
    log_eps, log_err = np.log(EPSILONS), np.log(errors)
    slope = np.polyfit(log_eps, log_err, 1)[0]
    tail = np.polyfit(log_eps[2:], log_err[2:], 1)[0]
    local = np.diff(log_err) / np.diff(log_eps)
    assert 0.85 <= slope <= 1.05, (slope, errors)
    assert abs(tail - 1) <= 0.05, (tail, errors)
    assert (np.diff(local) > 0).all() and abs(local[-1] - 1) <= 0.01, local
    constant = errors[-1] / (EPSILONS[-1] * np.abs(rigid[:, 4]).max())
    assert abs(constant - 1) <= 0.01, constant


# ---------------------------------------------------------------------------------------------
# 5., 6. The command line.

STIFF = ["--set", "time.dt=0.01", "--set", "obstacle.epsilon=0.001", "--set", "time.end=2"]


def test_picard_fails_where_the_exact_methods_do_not(shared_dir, capsys):
    """Δt = 0.01, ε = 0.001, ζ = 0.2: Δt = 50 εζ, far outside Picard's sufficient condition.
    Picard stops with exit code 3 and says why in one line; direct and newton, which do not
    iterate on the coupling, run to the end with a non-increasing energy."""
    code = main(["run", "paper1", "--out", str(shared_dir / "picard"), "--quiet", *STIFF,
                 "--set", "solver.method=picard"])
    err = capsys.readouterr().err
    assert code == 3
    if COMM.rank == 0:
        assert "Picard iteration" in err and "Δt/(εζ) = 50" in err, err
        assert err.count("\n") == 1 and "Traceback" not in err, err
    for method in ("direct", "newton"):
        out = shared_dir / method
        code = main(["run", "paper1", "--out", str(out), "--quiet", *STIFF,
                     "--set", f"solver.method={method}"])
        err = capsys.readouterr().err
        assert code == 0, err
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "complete" and summary["steps"] == 200
        assert summary["energy_non_increasing"] is True, summary
        history = history_rows(out)
        assert history.shape == (201, 7) and np.isfinite(history).all()
        assert (history[:, 4] < 0).any()


def test_picard_with_the_rigid_obstacle_is_rejected(shared_dir, capsys):
    """Picard has no multiplier for Signorini's condition: exit code 2, one line naming the
    method, nothing written."""
    out = shared_dir / "rejected"
    code = main(["run", "paper1", "--out", str(out), "--quiet", "--set", "obstacle.kind=rigid",
                 "--set", "solver.method=picard"])
    err = capsys.readouterr().err
    assert code == 2
    if COMM.rank == 0:
        assert "picard" in err.lower() and "rigid" in err.lower(), err
        assert err.count("\n") == 1 and "Traceback" not in err, err
    assert not out.exists()
