"""The independent reference (tests/reference.py) with steps of any sizes, for both time schemes.

tests/reference.py solves the paper's scheme (3.1)–(3.2) at a fixed Δt. This module takes a given
sequence of steps h₁, h₂, … (an adaptive run's ``dt`` column) and solves each step exactly, with
the same hand-assembled matrices (:func:`reference.assemble`) and the same banded LU with one step
of refinement (:class:`reference.CoupledSolver`), for the scheme at weight w:

* ``paper`` (w = 1): (3.1)–(3.2) as printed, the force at tⁿ, U¹ = U⁰ + h₁ P u₁ with inertia;
* ``crank-nicolson`` (w = ½): the implicit midpoint rule on u_t = v, b v_t = σ_x,
  θ_t = θ_xx − a v_x, the contact force the discrete gradient (φ(y) − φ(c))/(y − c) of
  φ(u) = [u − g]₊²/(2ε) (docs/time-schemes.md).

**Across a change of step the velocity is kept**: the state is (Θ, V, U) with V the velocity, and
a step of size h starts from D = h V (rodfem's convention: D scaled by h_new/h_old). With
H = M + w h (K + k B), A = (b/w) Mb + (w h² + h ζ) K, a step is, for the increments ΔΘ, Δ,

    H ΔΘ + a C Δ                 = − h (K Θ + k Θ_s e)
    − w h² a Cᵀ ΔΘ + A Δ         = (b/w) Mb h V − h² K U + h² a Cᵀ Θ − h² a θ_A z − h² p e

(for w = 1 the matrix of reference.simulate's exact method), then V ← Δ/h (paper) or
V ← 2Δ/h − V (midpoint rule, with inertia). As in reference.py the step is solved for p = 0 and
for the response q to p = 1: y = s0 − p w_c at the contact node, w_c = −q_Δ there, and p is
the obstacle's: paper, p = [y − g]₊/ε, i.e. p = (s0 − g)/(ε + w_c) for s0 > g; Crank–Nicolson,
the discrete gradient, a root of the increasing y + w_c p(y) − s0 (closed form while in contact
on both sides, otherwise a bracketed root to round-off); the rigid obstacle's multiplier
p = (s0 − g)/w_c where s0 > g (paper only: Crank–Nicolson takes it with the end eliminated).

**A redistributed mass in Crank–Nicolson's scheme with ζ = 0** (a = 0, no load): the node x = 1
has neither mass nor viscosity, its equation is static, and the end is eliminated (the method of
docs/time-schemes.md, derived here again). With a = 0 its equation K_{s,s−1} U_{s−1} + K_ss U_s
+ p = 0 gives the free position y = U_{s−1} (U_s = y − h p): the obstacle is in series with the
last cell's spring of compliance h, the linear law of compliance ε + h (h for the rigid one). The
step's contact is the discrete gradient of that law between yⁿ⁻¹ and yⁿ = U_{s−1}ⁿ, solved as
above with w_c = −q_Δ at x_{s−1}; then the end is put where its equation at tⁿ holds,
U_s = g + ε ψ'(yⁿ) where ψ'(yⁿ) = [yⁿ − g]₊/(ε + h) > 0 (else yⁿ), σ(1) = −ψ'(yⁿ), and its
velocity is (U_sⁿ − U_sⁿ⁻¹)/h. The initial end is so placed too.

The history has the columns of reference.simulate (t, u(1), u(0.5), u_t(1), σ(1), energy),
the step h and the step's dissipation; u_t(1) is Vⁿ(1) and the energy ½(‖Θ‖²_M + b‖V‖²_Mb +
‖U_x‖²) + a θ_A (r, U_x) + φ(U(1)) (no φ for the rigid obstacle, whose σ(1) is −p). Without
sources, Crank–Nicolson's step changes the energy by minus its dissipation exactly
(docs/time-schemes.md), and the paper's by at most that (Remark 4.4, for n ≥ 2).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from reference import CoupledSolver, SPDSolver, Tridiagonal, assemble
from scipy.optimize import brentq

Array = np.ndarray
WEIGHTS = {"paper": 1.0, "crank-nicolson": 0.5}


def gradient_force(y: float, c: float, gap: float, compliance: float) -> float:
    """(φ(y) − φ(c))/(y − c) for φ(u) = [u − g]₊²/(2 compliance), each case written without
    the secant's cancellation (φ'(y) where y = c)."""
    if y > gap and c > gap:
        return (y + c - 2.0 * gap) / (2.0 * compliance)
    if y > gap:  # c <= g < y
        return (y - gap) ** 2 / (2.0 * compliance * (y - c))
    if c > gap:  # y <= g < c
        return (c - gap) ** 2 / (2.0 * compliance * (c - y))
    return 0.0


def solve_gradient(s0: float, c: float, gap: float, compliance: float, w: float) -> float:
    """p with y + w p(y) = s0, p the discrete gradient from c (zero if it cannot touch)."""
    if s0 <= gap and c <= gap:
        return 0.0
    y = (2.0 * compliance * s0 - w * (c - 2.0 * gap)) / (2.0 * compliance + w)
    if not (y > gap and c > gap):  # not in contact on both sides: a bracketed root

        def residual(v):
            return v + w * gradient_force(v, c, gap, compliance) - s0

        low = min(s0, gap) - w * max(c - gap, 0.0) / compliance - 1.0
        while residual(low) >= 0.0:
            low -= 2.0 * (s0 - low)
        y = s0 if residual(s0) <= 0.0 else brentq(residual, low, s0, xtol=1e-300,
                                                   rtol=4 * np.finfo(float).eps)
    return gradient_force(y, c, gap, compliance)


class Step:
    """The factored system of one step size h (kept: the steps repeat)."""

    def __init__(self, ops: dict, h: float, w: float, a: float, b: float, zeta: float, k: float,
                 contact_node: int):
        mm, mb, kk, cc = ops["M"], ops["Mb"], ops["K"], ops["C"]
        heat = mm + (w * h) * kk
        heat.diag[-1] += w * h * k
        momentum = (b / w) * mb + (w * h * h + h * zeta) * kk
        self.solver = CoupledSolver([[heat, a * cc], [(-w * h * h * a) * cc.T, momentum]])
        unit = np.zeros(kk.diag.size)
        unit[-1] = -h * h
        self.q_theta, self.q_delta = self.solver.solve(np.zeros_like(unit), unit)
        self.compliance = -self.q_delta[contact_node]
        if not self.compliance > 0.0:
            raise RuntimeError(f"compliance at the contact node is not positive: {self.compliance}")


def simulate_steps(
    *, a: float, b: float, zeta: float, k: float, theta_A: float,  # noqa: N803 - paper notation
    epsilon: float, gap: float, cells: int, steps: Array, mass: str,
    theta0: Callable[[Array], Array], u0: Callable[[Array], Array], u1: Callable[[Array], Array],
    scheme: str = "paper", obstacle: str = "elastic",
) -> dict[str, Array]:
    """The scheme over the steps ``steps`` (the module's docstring). Returns ``history``
    (len(steps) + 1 rows: t, u(1), u(0.5), u_t(1), σ(1), energy, h, the step's dissipation
    h (‖Θ_x‖² + k Θ(1)² + ζ ‖δ_x‖²) at Θ = Θⁿ⁻¹ + w ΔΘ, δ = ΔU/h; h = 0 in row 0, and the
    dissipation 0 there and at the paper's first step with inertia) and the final ``theta``, ``u``
    at the nodes x_0..x_s (first entry 0)."""
    w = WEIGHTS[scheme]
    rigid = obstacle == "rigid"
    ops = assemble(cells, k, mass)
    x, mm, mb, kk, cc, z = (ops[key] for key in ("x", "M", "Mb", "K", "C", "z"))
    massless = mass.startswith("redistributed") and w != 1.0 and b > 0.0 and zeta == 0.0
    if massless and a != 0.0:
        raise ValueError("the end is eliminated only with a = 0")
    if rigid and w != 1.0 and not massless:
        raise ValueError("Crank–Nicolson takes the rigid obstacle only with the end eliminated")
    node = -2 if massless else -1  # where the contact is read: y = U_{s-1}, or U_s
    law = (ops["h"] if massless else 0.0) + (0.0 if rigid else epsilon)  # its compliance
    xi = x[1:]
    c_robin = k / (k + 1.0)
    made: dict[float, Step] = {}

    def nodal(f):
        return np.broadcast_to(np.asarray(f(xi), dtype=float), xi.shape).astype(float)

    c = nodal(theta0) + theta_A * (c_robin * xi - 1.0)
    d = nodal(u0)
    v = nodal(u1) if b > 0.0 else np.zeros_like(d)
    penalty = 0.0 if rigid else epsilon
    pressure = settle(d, gap, law, penalty) if massless else 0.0
    history = np.zeros((len(steps) + 1, 8))
    full = np.zeros(x.size)

    def record(n: int, t: float, h: float, dissipated: float = 0.0) -> None:
        full[1:] = d
        energy = 0.5 * (c @ (mm @ c) + b * (v @ (mb @ v)) + d @ (kk @ d)) + a * theta_A * (z @ d)
        if rigid:
            sigma = -pressure + 0.0
        else:
            sigma = -max(d[-1] - gap, 0.0) / epsilon
            energy += 0.5 * max(d[-1] - gap, 0.0) ** 2 / epsilon
        history[n] = (t, d[-1], np.interp(0.5, x, full), v[-1], sigma, energy, h, dissipated)

    record(0, 0.0, 0.0)
    t = 0.0
    for n, h in enumerate(np.asarray(steps, dtype=float), start=1):
        if n == 1 and w == 1.0 and b > 0.0:  # U¹ = U⁰ + h P u₁, Θ¹ from (3.1): no contact
            heat = mm + h * kk
            heat.diag[-1] += h * k
            d_new = d + h * v
            c = _solve_spd(heat, mm @ c + a * (cc @ (d - d_new)))
            d, pressure, dissipated = d_new, 0.0, 0.0
        else:
            step = made.get(h) or made.setdefault(h, Step(ops, h, w, a, b, zeta, k, node))
            c, d, v, pressure, dissipated = _step(step, h, w, c, d, v, ops, a, b, zeta, k,
                                                  theta_A, gap, law, penalty, massless)
        t += h
        record(n, t, h, dissipated)
    return {"history": history, "theta": np.concatenate(([0.0], c)),
            "u": np.concatenate(([0.0], d)), "x": x.copy()}


def settle(d: Array, gap: float, law: float, penalty: float) -> float:
    """The eliminated end where its equation puts it, from y = U_{s−1} (changed in d): g + ε ψ'
    in contact (ε = ``penalty``, 0 for the rigid obstacle), else y; returns ψ'(y)."""
    force = max(d[-2] - gap, 0.0) / law
    d[-1] = gap + penalty * force if force > 0.0 else d[-2]
    return force


def _step(step, h, w, c, d, v, ops, a, b, zeta, k, theta_A, gap, law, penalty,  # noqa: N803
          massless):
    """One step of size h from (Θ, U, V): (Θ, U, V, p, the dissipation) after it."""
    mb, kk, cc, z = ops["Mb"], ops["K"], ops["C"], ops["z"]
    node = -2 if massless else -1
    heat_rhs = -h * (kk @ c)
    heat_rhs[-1] -= h * k * c[-1]
    mom_rhs = (b / w) * (mb @ (h * v)) - h * h * (kk @ d) + h * h * a * (cc.T @ c)
    mom_rhs -= h * h * a * theta_A * z
    dtheta, delta = step.solver.solve(heat_rhs, mom_rhs)
    start = d[node]
    s0 = start + delta[node]
    if w == 1.0:
        force = max(s0 - gap, 0.0) / (step.compliance + law)
    else:
        force = solve_gradient(s0, start, gap, law, step.compliance)
    if force != 0.0:
        dtheta = dtheta + force * step.q_theta
        delta = delta + force * step.q_delta
    d_new = d + delta
    if w == 1.0 or b == 0.0:
        v = delta / h
    else:
        v = 2.0 * delta / h - v
    pressure = settle(d_new, gap, law, penalty) if massless else force
    mid, rate = c + w * dtheta, delta / h
    dissipated = h * (mid @ (kk @ mid) + k * mid[-1] ** 2 + zeta * (rate @ (kk @ rate)))
    if mb.diag[-1] == 0.0:  # no mass at x = 1: no velocity of its own
        v[-1] = (d_new[-1] - d[-1]) / h
    return c + dtheta, d_new, v, pressure, dissipated


def _solve_spd(matrix: Tridiagonal, rhs: Array) -> Array:
    return SPDSolver(matrix).solve(rhs)
