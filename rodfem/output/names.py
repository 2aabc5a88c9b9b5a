"""What the figures call things: the paper's symbol of a scene key, the meaning and symbol of a
measure, and their units (one home, read by the run figures, the sweep figures and the quick figures
of :mod:`rodfem.quicklook` alike; it imports nothing, so a notebook's line plot loads no VTK).

The model is nondimensional (docs/outputs.md, "Units"): lengths and displacements are in units of
the rod's length L, times of t₀ = ρcL²/κ, stresses of Young's modulus E, the energy of EL per unit
cross-section. An axis names the scale a value is measured in, ``$\\sigma(1)$ [$E$]``; a number
of the model without a scale (ζ, ε, k, a fraction, a count) has none. Symbols come in mathtext
(typeset by matplotlib) and in Unicode (text drawn many times, as in the animation).
"""

from __future__ import annotations

# Scene keys: (mathtext symbol, Unicode symbol, unit in mathtext or "").
KEYS = {
    "model.zeta": (r"\zeta", "ζ", ""),
    "obstacle.epsilon": (r"\varepsilon", "ε", ""),
    "model.k": ("k", "k", ""),
    "model.a": ("a", "a", ""),
    "model.b": ("b", "b", ""),
    "model.theta_A": (r"\theta_A", "θ_A", ""),
    "obstacle.gap": ("g", "g", "L"),
    "time.dt": (r"\Delta t", "Δt", "t_0"),
    "mesh.cells": ("s", "s", ""),
    "obstacle.temperature": (r"\theta_O", "θ_O", ""),
    "obstacle.exponent": ("m", "m", ""),
    "heat_exchange.k1": ("k_1", "k₁", ""),
    "heat_exchange.exponent": ("m", "m", ""),
    "heat_exchange.length": (r"\ell", "ℓ", "L"),
    "time.end": ("T", "T", "t_0"),
    "time.tolerance": (r"\mathrm{tol}", "tol", ""),
}
# Keys that choose a law or a method: named in words where their values differ.
CHOICES = {
    "obstacle.kind": "obstacle",
    "obstacle.law": "contact law",
    "heat_exchange.law": "exchange law",
    "solver.method": "method",
    "time.scheme": "time scheme",
    "time.adaptive": "adaptive steps",
    "discretisation.mass": "mass",
}
# History columns as a measure names them: (mathtext symbol, unit).
COLUMNS = {
    "t": ("t", "t_0"),
    "u_1": ("u(1)", "L"),
    "u_half": ("u(0.5)", "L"),
    "ut_1": ("u_t(1)", "L/t_0"),
    "sigma_1": (r"\sigma(1)", "E"),
    "energy": (r"\hat{E}", "EL"),
    "iterations": (r"\mathrm{iterations}", ""),
    "dt": (r"\Delta t", "t_0"),
    "event": (r"\mathrm{event}", ""),
    "theta_1": (r"\theta(1)", ""),
    "heat_flux_1": (r"-\theta_x(1)", ""),
    "contact_force": ("p", "E"),
    "contact": (r"\mathrm{contact}", ""),
    "penetration": ("u(1) - g", "L"),
}
PROBES = {"u": ("u", "L"), "theta": (r"\theta", ""), "sigma": (r"\sigma", "E")}
# The built-in measures: (what the axis says, unit).
MEASURES = {
    "t_final": (r"time reached $t$", "t_0"),
    "u_1_final": (r"final $u(1)$", "L"),
    "sigma_1_final": (r"final contact stress $\sigma(1)$", "E"),
    "max_penetration": (r"max penetration $[u(1) - g]_+$", "L"),
    "contact_fraction": ("fraction of the steps in contact", ""),
    "contact_intervals": ("intervals of contact", ""),
    "last_contact_change": (r"last change of contact, $t$", "t_0"),
    "energy_final": (r"final energy $\hat{E}$", "EL"),
    "iterations_max": ("most iterations in a step", ""),
    "loop_seconds": ("time loop's wall time", r"\mathrm{s}"),
}
# What a declared measure's reduction makes of its column f: (the words, the unit's factor).
REDUCTIONS = {
    "max": ("max {f}", ""),
    "min": ("min {f}", ""),
    "max_abs": ("max |{f}|", ""),
    "mean": ("mean {f}", ""),
    "integral": (r"$\int$ {f} $dt$", "t_0"),
    "final": ("final {f}", ""),
    "time_of_max_abs": ("time of max |{f}|", None),
    "time_positive": ("time with {f} > 0", None),
}
# Measures that say how a run was computed, not what it computed: not drawn unless asked for.
COMPUTING = ("loop_seconds", "iterations_max")


def with_unit(text: str, unit: str) -> str:
    """``text [unit]``, the unit in mathtext; the text alone for a number without a scale."""
    return f"{text} [${unit}$]" if unit else text


def key_label(key: str) -> str:
    """A scene key for an axis or a colour bar: ``$\\zeta$ (model.zeta)``, with its unit."""
    if key in KEYS:
        math, _, unit = KEYS[key]
        return with_unit(f"${math}$ ({key})", unit)
    return CHOICES.get(key, key)


def key_symbol(key: str, math: bool = True) -> str | None:
    """The paper's symbol of a scene key (mathtext or Unicode), None if it has none."""
    if key not in KEYS:
        return None
    return KEYS[key][0] if math else KEYS[key][1]


def column_symbol(column: str) -> tuple[str, str]:
    """A history column's mathtext symbol and unit; a probe ``u@0.25`` is ``u(0.25)``."""
    if column in COLUMNS:
        return COLUMNS[column]
    field, _, x = column.partition("@")
    if field in PROBES and x:
        symbol, unit = PROBES[field]
        return f"{symbol}({x})", unit
    return r"\mathrm{" + column.replace("_", r"\_") + "}", ""


def series_label(column: str) -> str:
    """A history column drawn against t, for an axis: ``$\\sigma(1, t)$ [$E$]``."""
    symbol, unit = column_symbol(column)
    if symbol.endswith(")"):
        symbol = symbol[:-1] + ", t)"
    return with_unit(f"${symbol}$", unit)


TIME_LABEL = with_unit("$t$", "t_0")


def declared_label(name: str, column: str, reduce: str, window=None) -> str:
    """A declared measure's axis label: its name, what it reduces and its unit, e.g.
    ``peak_force: max $p$ [$E$]``."""
    symbol, unit = column_symbol(column)
    words, factor = REDUCTIONS.get(reduce, (reduce + " {f}", ""))
    if factor is None:  # a time
        unit = "t_0"
    elif factor:
        unit = f"{unit} {factor}".strip() if unit else factor
    text = f"{name}: " + words.format(f=f"${symbol}$")
    if window is not None:
        text += f" on $[{window[0]:g}, {window[1]:g}]$"
    return with_unit(text, unit)


def measure_label(name: str, declared: dict | None = None) -> str:
    """A measure's axis label: a built-in's meaning and symbol, a declared one's reduction (from
    ``declared``: name → {column, reduce, window}), or the bare name of anything else."""
    if name in MEASURES:
        return with_unit(*MEASURES[name])
    spec = (declared or {}).get(name)
    if isinstance(spec, dict) and isinstance(spec.get("column"), str):
        return declared_label(name, spec["column"], str(spec.get("reduce", "")),
                              spec.get("window"))
    return name.replace("_", " ")


def measure_title(name: str, declared: dict | None = None) -> str:
    """A measure in a title: its label without the unit."""
    label = measure_label(name, declared)
    return label.rsplit(" [$", 1)[0] if label.endswith("$]") else label
