"""The operators of a step as Laurent polynomials in Δt, read once per run.

Every operator a method uses (``heat.A``, ``heat.N[...]``, ``heat.b``, ``momentum.A``,
``momentum.N[...]``, ``momentum.b``, ``contact_load``: :class:`~rodfem.solver.methods.base.Method`)
is, entry by entry,

    X(Δt) = X₋₂/Δt² + X₋₁/Δt + X₀,

because Δt enters ``forms.copetti.heat_increment`` and ``momentum_increment`` only as the factors
of their terms, each of which is linear in its unknown and data:

* heat: (ΔΘ, w)/Δt and a (ΔU_x, w)/Δt are Δt⁻¹ (``A_h``'s mass, ``N_U``); (Θ_x, w_x) and
  k Θ(1) w(1) do not hold Δt (``A_h``'s stiffness and end, ``N_Θ'``); there is no load.
* momentum: b (ΔU − Dⁿ⁻¹, v)_b/(w Δt²) is Δt⁻² (``A_m``'s mass, ``N_D'``); ζ (ΔU_x, v_x)/Δt is
  Δt⁻¹; (U_x − aΘ + aθ_A r, v_x) and − aθ_O (s, v_x) do not hold Δt (``A_m``'s stiffness,
  ``N_U'``, ``N_Θ'``, ``N_ΔΘ``, ``b_m``). The dispersion-free mass's inner product weighs the
  consistent and lumped masses by β = 1/2 + (Δt/h)² and 1 − β, so that β/Δt² = 1/(2Δt²) + 1/h²:
  a Δt⁻² part and a Δt⁰ part (b/(w h²) (M_c − M_l)); a redistributed mass's density does not hold
  Δt.
* the contact load e (a unit force at x = 1) does not hold Δt.

No term holds another power, so three sizes determine the parts. With λ = Δt₀/Δt and
P_k = X₋ₖ/Δt₀ᵏ, X = P₀ + P₁ λ + P₂ λ². The parts are read off the operators assembled at
λ = 2⁻ᴱ, 1 (the run's own) and 2ᴱ, E = :data:`SPREAD` = 100 (steps of Δt₀ 2¹⁰⁰ and Δt₀ 2⁻¹⁰⁰,
which the forms evaluate without overflow):

    P₀ = X(2⁻ᴱ),   P₂ = X(2ᴱ) 2⁻²ᴱ,   P₁ = (X(1) − P₀) − P₂.

The forms' code multiplies each term by its power of 1/Δt, and a power of two scales it without
rounding; at λ = 2⁻ᴱ the terms of P₁ and P₂ fall below half an ulp of P₀'s (for
|P₁|, |P₂| < 2⁴⁶ |P₀|), so X(2⁻ᴱ) is P₀ as its own terms assemble, to |P₁| 2⁻ᴱ + |P₂| 2⁻²ᴱ
(nothing at any step used); at λ = 2ᴱ likewise P₂. So P₀ and P₂ carry only the rounding of their
own terms, as in the assembly: a structure of the stiffness (rows that sum to 0, so that a rigid
motion costs no force) is kept exactly, which parts solved from nearby sizes would lose to the
mass's rounding (a drift of 5e-13 in the velocity of the impact scene's bar by t = 1). An entry of
one power is found exactly (its three values are that power's scalings): that part is X(1), the
others 0.

**Round-off.** With A(λ) = Σ|P_k| λᵏ the size of an entry's terms (the largest of its row: an
entry whose terms cancel, P1's (u_x, w) on the diagonal, is a few eps of them), an assembled entry
carries a few eps A(λ), and so do P₀ and P₂ of their own terms; P₁ carries those of X(1), P₀ and
P₂, a few eps A(1). Recombined at λ against the operator assembled there:
|X̃(λ) − X(λ)| ≤ γ (A(λ) + λ A(1)), γ a few eps (:func:`bound`). The parts are checked at a fourth
size, λ = 8 (a step of Δt₀/8), against that bound with γ = :data:`GAMMA`; an operator that fails
it (a form that is not such a polynomial, or a size the forms do not evaluate) makes
:func:`read_parts` return None, and the run makes its methods as before.
"""

from __future__ import annotations

import numpy as np

SPREAD = 100  # the sizes assembled: λ = 2⁻ᴱ, 1, 2ᴱ
NODES = (2.0**-SPREAD, 1.0, 2.0**SPREAD)  # λ = Δt₀/Δt of the sizes assembled
CHECK = 8.0  # the size the parts are checked at
GAMMA = 16 * np.finfo(float).eps  # the assembly's rounding per unit of A (a few terms per entry)
MATRICES = (("heat", "A"), ("heat", "theta_prev"), ("heat", "du"), ("momentum", "A"),
            ("momentum", "du_prev"), ("momentum", "u_prev"), ("momentum", "theta_prev"),
            ("momentum", "dtheta"))
VECTORS = (("heat", "b"), ("momentum", "b"), ("contact", "e"))


def name(operator: tuple[str, str]) -> str:
    return ".".join(operator)


def _operators(method) -> dict[str, object]:
    """The method's operators by :func:`name`, read off the forms at their present Δt."""
    heat, momentum, contact_load = method.operators()
    found = {"contact.e": contact_load}
    for label, op in (("heat", heat), ("momentum", momentum)):
        found[f"{label}.A"] = op.A
        found[f"{label}.b"] = op.b
        for key, matrix in op.N.items():
            found[f"{label}.{key}"] = matrix
    return found


def _entries(matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ia, ja, a = matrix.getValuesCSR()
    rows = np.repeat(np.arange(len(ia) - 1), np.diff(ia))
    return rows, np.asarray(ja, dtype=np.int64), np.asarray(a, dtype=float)


def solve(samples: np.ndarray) -> np.ndarray:
    """The parts (3 × m: P₀, P₁, P₂) of the values ``samples`` (3 × m) at :data:`NODES` (the
    module's docstring)."""
    xs, xb, xl = samples
    small, large = NODES[0], NODES[2]
    p0, p2 = xs.copy(), xl * (small * small)
    parts = np.array([p0, (xb - p0) - p2, p2])
    for k, scale in enumerate((1.0, large, large * large)):  # one power: exactly that part
        pure = (xs == xb / scale) & (xl == xb * scale)
        parts[:, pure] = 0.0
        parts[k, pure] = xb[pure]
    return parts


def combine(parts: np.ndarray, lam: float) -> np.ndarray:
    """P₀ + P₁ λ + P₂ λ²."""
    return parts[0] + parts[1] * lam + parts[2] * (lam * lam)


def bound(parts: np.ndarray, lam: float, rows: np.ndarray | None = None,
          gamma: float = GAMMA) -> np.ndarray:
    """The round-off of :func:`combine` against the operator assembled at λ (the module's
    docstring): γ (A(λ) + λ A(1)), A(λ) the size of the terms an entry sums: the largest
    Σ|P_k| λᵏ of its row (of a matrix whose entries' ``rows`` are given; of the whole vector
    else)."""
    a = np.abs(parts)

    def size(x: float) -> np.ndarray:
        each = a[0] + a[1] * x + a[2] * (x * x)
        if rows is None:
            return np.full_like(each, each.max(initial=0.0))
        largest = np.zeros(int(rows.max(initial=-1)) + 1)
        np.maximum.at(largest, rows, each)
        return largest[rows]

    return gamma * (size(lam) + lam * size(1.0))


class LaurentParts:
    """The parts of a method's operators: for a matrix (by :func:`name`) its entries' rows and
    columns (node order, the union of the sizes' patterns) and parts (3 × entries); for a
    vector its parts (3 × n)."""

    def __init__(self, arrays: dict[str, np.ndarray]):
        self.arrays = arrays

    def matrix(self, key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a = self.arrays
        return a[key + "|rows"], a[key + "|cols"], a[key + "|parts"]

    def vector(self, key: str) -> np.ndarray:
        return self.arrays[key + "|parts"]


def _sampled(home, lams) -> list[dict[str, object]]:
    """The operators at each λ (1: the home method's own)."""
    disc, out = home.disc, []
    for lam in lams:
        if lam == 1.0:
            out.append(_operators_of(home))
            continue
        with disc.at_step(home.dt / lam):
            out.append(_operators(home))
    return out


def _operators_of(home) -> dict[str, object]:
    found = {"contact.e": home.contact_load}
    for label, op in (("heat", home.heat), ("momentum", home.momentum)):
        found[f"{label}.A"] = op.A
        found[f"{label}.b"] = op.b
        for key, matrix in op.N.items():
            found[f"{label}.{key}"] = matrix
    return found


def _arrays(home) -> dict[str, np.ndarray]:
    """The parts, checked at λ = :data:`CHECK`; {} where a check fails."""
    with np.errstate(all="ignore"):  # a size the forms do not evaluate fails the check
        sampled = _sampled(home, (*NODES, CHECK))
    arrays: dict[str, np.ndarray] = {}
    n = home.disc.nodes.size
    for key in sorted(sampled[1]):
        if key.endswith(".b") or key == "contact.e":
            values = np.array([s[key].array_r for s in sampled])
            rows = cols = None
        else:
            entries = [_entries(s[key]) for s in sampled]
            keys = np.unique(np.concatenate([r * n + c for r, c, _ in entries]))
            values = np.zeros((len(sampled), keys.size))
            for k, (r, c, v) in enumerate(entries):
                np.add.at(values[k], np.searchsorted(keys, r * n + c), v)
            rows, cols = keys // n, keys % n
        with np.errstate(all="ignore"):
            parts = solve(values[:3])
            if not (np.all(np.isfinite(values)) and np.all(np.isfinite(parts))) or np.any(
                    np.abs(combine(parts, CHECK) - values[3]) > bound(parts, CHECK, rows)):
                return {}
        arrays[key + "|parts"] = parts
        if rows is not None:
            arrays[key + "|rows"], arrays[key + "|cols"] = rows, cols
    return arrays


def _valid(found: dict[str, np.ndarray], n: int) -> bool:
    """Whether cached arrays are parts as :func:`_arrays` makes them, for n nodes (or its mark
    of a failed check): every operator, finite parts of 3 rows, a matrix's entries on the nodes."""
    if set(found) == {"failed|parts"}:
        return True
    names = {name(op) for op in (*MATRICES, *VECTORS)}
    expected = {f"{k}|parts" for k in names} | {f"{name(op)}|{field}" for op in MATRICES
                                                 for field in ("rows", "cols")}
    if set(found) != expected:
        return False
    for key in names:
        parts = found[key + "|parts"]
        if parts.dtype != np.float64 or parts.ndim != 2 or parts.shape[0] != 3 \
                or not np.all(np.isfinite(parts)):
            return False
        if key + "|rows" not in found:
            if parts.shape[1] != n:
                return False
            continue
        for field in ("rows", "cols"):
            index = found[f"{key}|{field}"]
            if index.dtype.kind != "i" or index.shape != (parts.shape[1],) \
                    or np.any((index < 0) | (index >= n)):
                return False
    return True


def read_parts(home) -> LaurentParts | None:
    """The parts of ``home``'s operators (the run's method, at its Δt₀), from the operator cache
    where it has them; None where a check fails (:func:`_arrays`)."""
    disc = home.disc
    key = repr(("laurent", home.time_scheme.weight, NODES, CHECK))
    n = disc.nodes.size
    arrays = disc.arrays(key, lambda: _arrays(home) or {"failed|parts": np.zeros((3, 0))},
                         lambda found: _valid(found, n))
    if "failed|parts" in arrays:
        return None
    return LaurentParts(arrays)
