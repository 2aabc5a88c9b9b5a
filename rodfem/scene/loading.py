"""Scenes: what a user asks to simulate, read from TOML and validated before anything runs.

A scene is a TOML file with the sections below; every key has a default (the paper's common data
and its first experiment), so a scene names only what differs. The built-in scenes ``paper1`` …
``paper5`` are the paper's five experiments. Every value is checked (one key's value in
:mod:`rodfem.scene.values`, the keys together here; the file is read by :mod:`rodfem.scene.files`),
and each mistake is reported as a :class:`SceneError` whose message is one line naming the key and
what is allowed.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rodfem.scene.expressions import shorten
from rodfem.scene.files import _parse_toml, read  # noqa: F401 (re-exported)
from rodfem.scene.measures import parse as parse_measures
from rodfem.scene.scene import Scene, _applies
from rodfem.scene.schema import (  # noqa: F401 (re-exported)
    BIG,
    BUILTIN,
    EXTRA,
    MAX_CELLS,
    MAX_STEPS,
    METHODS,
    MODEL_NAMES,
    REDISTRIBUTED,
    SCHEMA,
    SMALL,
    SOURCE_NAMES,
    TIME_SCHEMES,
    TOP_LEVEL,
    Key,
    SceneError,
)
from rodfem.scene.values import _check_value, _suggest, _toml_value, quote, with_changes


def validate(data: dict[str, Any], source: str = "") -> Scene:
    """Check a scene's raw TOML data and fill in the defaults.

    Raises:
        SceneError: for the first value that is wrong.
    """
    if not isinstance(data, dict):
        raise SceneError("a scene must be a TOML table")
    values: dict[str, dict[str, Any]] = {}
    for name in data:
        if name not in SCHEMA and name not in TOP_LEVEL:
            raise SceneError(f"unknown section '{shorten(str(name))}': "
                             f"{_suggest(name, [*SCHEMA, *TOP_LEVEL])}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SceneError("description: must be a string")
    for section, keys in SCHEMA.items():
        given = data.get(section, {})
        if not isinstance(given, dict):
            names = ", ".join(keys)
            raise SceneError(f"{section}: must be a section [{section}] with keys {names}")
        for key in given:
            if key not in keys:
                raise SceneError(f"unknown key '{section}.{shorten(key)}': {_suggest(key, keys)}")
        values[section] = {
            key: _check_value(f"{section}.{key}", spec, given.get(key, spec.default))
            for key, spec in keys.items()
        }
    measures = parse_measures(data.get("measures", {}), values["time"]["adaptive"],
                              values["time"]["end"])
    scene = Scene(values, description, source, measures)
    for section, keys in SCHEMA.items():
        for key, spec in keys.items():
            if key in data.get(section, {}) and not _applies(scene, spec):
                other, value = spec.only_with
                wanted = " or ".join(_toml_value(v) for v in
                                     (value if isinstance(value, tuple) else (value,)))
                raise SceneError(f"{section}.{key}: applies only with {other} = "
                                 f"{wanted}, not {_toml_value(scene[other])}")
    _check_consistency(scene)
    return scene


def _check_magnitude(key: str, values: np.ndarray, x: np.ndarray, given, t=None) -> None:
    """Data beyond ±BIG overflow the energy (a sum of their squares over the cells)."""
    big = np.flatnonzero(np.abs(values) > BIG)
    if big.size:
        at = f"x = {x[big[0]]:g}" + (f", t = {t:g}" if t is not None else "")
        raise SceneError(f"{key}: {values[big[0]]:.3g} at {at} ({_toml_value(given)}); the data "
                         f"must stay within ±{BIG:g}, beyond which the energy overflows")


def _check_consistency(scene: Scene) -> None:
    """What no single key's range says: keys that do not go together, the steps, the data."""
    _check_combinations(scene)
    _check_steps(scene)
    _check_mass(scene)
    _check_data(scene)
    _check_accuracy(scene)


def _check_combinations(scene: Scene) -> None:
    """Choices of obstacle, method, scheme and mass that do not go together."""
    if scene["obstacle.kind"] == "rigid" and scene["obstacle.law"] != "linear":
        raise SceneError(
            f'obstacle.law: "{scene["obstacle.law"]}" is a law of the elastic obstacle; '
            'obstacle.kind = "rigid" has none (Signorini\'s condition u(1) <= g)'
        )
    if scene["solver.method"] == "picard" and scene["obstacle.kind"] == "rigid":
        raise SceneError(
            'solver.method: "picard" cannot solve obstacle.kind = "rigid" (its iteration is the '
            'penalty\'s, which needs 1/epsilon); use "direct" or "newton"'
        )
    if (scene["time.scheme"] == "crank-nicolson" and scene["model.b"] == 0.0
            and scene["model.zeta"] == 0.0):
        raise SceneError(
            'time.scheme: "crank-nicolson" needs inertia or viscosity (model.b > 0 or '
            "model.zeta > 0): with b = zeta = 0 the momentum equation has no time derivative and "
            'the midpoint rule makes U oscillate from step to step; use "paper"'
        )
    redistributed = scene["discretisation.mass"] in REDISTRIBUTED
    if (scene["time.scheme"] == "crank-nicolson" and scene["obstacle.kind"] == "rigid"
            and not redistributed):
        raise SceneError(
            'time.scheme: "crank-nicolson" models obstacle.kind = "rigid" only with '
            'discretisation.mass = "redistributed", "redistributed-lumped" or "dispersion-free": '
            "with mass at x = 1 "
            "its velocity there flips sign every step while the rod rests on the obstacle (the "
            'midpoint rule with U(1) held at g), and the contact force with it; or use "paper"'
        )
    if (redistributed and scene["time.scheme"] == "crank-nicolson" and scene["model.zeta"] == 0.0
            and scene["model.b"] > 0.0):
        # the end x = 1 has neither mass nor viscosity: it is in equilibrium and is eliminated
        # (rodfem.solver.methods.massless), which takes its equation as a spring's alone
        mass = scene["discretisation.mass"]
        if scene["model.a"] != 0.0:
            raise SceneError(
                f'model.a: must be 0 with discretisation.mass = "{mass}", time.scheme = '
                '"crank-nicolson" and model.zeta = 0 (the end x = 1, without mass nor '
                "viscosity, is eliminated, and the heat coupling would tie it to its own "
                'motion); use model.zeta > 0 or time.scheme = "paper"'
            )
        if scene.source_term("momentum") is not None:
            raise SceneError(
                f'source.momentum: not with discretisation.mass = "{mass}", time.scheme = '
                '"crank-nicolson" and model.zeta = 0 (the end x = 1 is then in equilibrium and '
                "eliminated, without a source); use model.zeta > 0 or another mass"
            )


def _check_mass(scene: Scene) -> None:
    """The dispersion-free mass blends for the midpoint rule at Δt/h = ν ≤ 1: its weight
    1/2 + ν² of the consistent mass (rodfem.discrete.discretisation) leaves it positive definite
    only there (at ν = 1 just: its condition number grows as the cells squared)."""
    if scene["discretisation.mass"] != "dispersion-free":
        return
    if scene["time.scheme"] != "crank-nicolson":
        raise SceneError(
            'discretisation.mass: "dispersion-free" is blended for time.scheme = '
            f'"crank-nicolson", not "{scene["time.scheme"]}"; use "redistributed" or '
            '"redistributed-lumped"'
        )
    if scene.adaptive:
        raise SceneError(
            'discretisation.mass: "dispersion-free" is blended for one ratio of time.dt to h, '
            "not for steps that adapt (time.adaptive = true): its mass would change with every "
            'step; use "redistributed"'
        )
    ratio = scene["time.dt"] * scene["mesh.cells"]
    if ratio > 1.0 + 4 * np.finfo(float).eps:  # Δt = 1/cells, rounded, is Δt = h
        raise SceneError(
            'discretisation.mass: "dispersion-free" needs time.dt <= h = 1/mesh.cells (beyond, '
            f"its blend is not positive definite), got time.dt/h = {ratio:.6g}; use a smaller "
            'time.dt or "redistributed"'
        )


def _check_steps(scene: Scene) -> None:
    """A whole number of steps, not too many of them."""
    dt, end = scene["time.dt"], scene["time.end"]
    if dt > end:
        raise SceneError(f"time.dt: must be <= time.end = {end!r}, got {dt!r}")
    ratio = end / dt
    if ratio > MAX_STEPS:
        raise SceneError(f"time.dt: at most {MAX_STEPS:g} steps, got {ratio:.3g} (end/dt)")
    if scene.adaptive:
        _check_adaptive(scene)
    elif abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise SceneError(
            f"time.end: must be a whole number of steps of time.dt = {dt!r}, got {end!r} "
            f"({ratio:.6g} steps)"
        )


def _check_adaptive(scene: Scene) -> None:
    """The first step, the smallest and the largest in order."""
    dt, low, high = scene["time.dt"], scene["time.dt_min"], scene["time.dt_max"]
    if high and high < low:
        raise SceneError(f"time.dt_max: must be 0 or >= time.dt_min = {low!r}, got {high!r}")
    if dt < low:
        raise SceneError(f"time.dt: the first step must be >= time.dt_min = {low!r}, got {dt!r}")
    if high and dt > high:
        raise SceneError(f"time.dt: the first step must be <= time.dt_max = {high!r}, got {dt!r}")


def _check_accuracy(scene: Scene) -> None:
    """An accuracy target needs measures to hold to it, and room to refine the mesh."""
    if scene["accuracy.target"] > 0.0 and not scene.targets:
        raise SceneError("accuracy.target: holds the measures a scene declares (but those set by "
                         "the steps), and this one declares none; add them in a [measures] "
                         'table, e.g. peak = { column = "sigma_1", reduce = "max_abs" } '
                         "(docs/accuracy-targets.md)")
    for m in scene.measures:
        if m.target is not None and m.stepped:
            raise SceneError(f"measures.{shorten(m.name)}: {m.reduce} of {m.column} is set by "
                             "the steps (its value moves by whole steps as a run is refined) "
                             "and has no error to hold to a target; remove its target")
        if m.name in scene.targets and f"{m.name}_error" in {d.name for d in scene.measures}:
            name = shorten(m.name)
            raise SceneError(f"measures.{name}_error: the name of {name}'s estimated error "
                             "(a sweep's results.csv column); choose another name")
    most, cells = scene["accuracy.cells_max"], scene["mesh.cells"]
    if most and most < cells:
        raise SceneError(f"accuracy.cells_max: must be 0 or at least mesh.cells = {cells}, "
                         f"got {most}")


def _check_data(scene: Scene) -> None:
    """The initial data and the sources: finite and within bounds where the run evaluates
    them, and the initial data compatible with the boundary conditions at x = 0."""
    # The initial data are interpolated at the nodes; they must be finite there and, since the
    # rod is clamped at a temperature θ_A, compatible with the boundary conditions at x = 0.
    x = np.linspace(0.0, 1.0, scene["mesh.cells"] + 1)
    at_zero = {"theta0": scene["model.theta_A"], "u0": 0.0, "u1": 0.0}
    for name, required in at_zero.items():
        values = scene.initial(name)(x, scene.parameters)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise SceneError(
                f"initial.{name}: not finite at x = {x[bad[0]]:g} "
                f"({_toml_value(scene.sections['initial'][name])})"
            )
        _check_magnitude(f"initial.{name}", values, x, scene.sections["initial"][name])
        if abs(values[0] - required) > 1e-12 * max(1.0, abs(required)):
            raise SceneError(
                f"initial.{name}: must equal {required:g} at x = 0 (boundary condition), "
                f"got {values[0]:g}"
            )
    # Sources are evaluated from the first step's time on (t¹ = Δt, or t^½ for Crank–Nicolson):
    # checked there and at the end here, at every step as the run goes (a non-finite value stops
    # the run with exit code 3).
    first = scene["time.dt"] * (0.5 if scene["time.scheme"] == "crank-nicolson" else 1.0)
    for name in SCHEMA["source"]:
        f = scene.source_term(name)
        for t in (first, scene["time.end"]) if f is not None else ():
            values = f(x, {**scene.parameters, "t": t})
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise SceneError(
                    f"source.{name}: not finite at x = {x[bad[0]]:g}, t = {t:g} "
                    f"({_toml_value(scene.sections['source'][name])})"
                )
            _check_magnitude(f"source.{name}", values, x, scene.sections["source"][name], t)


def _parse_override(item: str) -> tuple[str, str, Any]:
    """A ``--set section.key=value`` as (section, key, value): the value as TOML, or else as a
    bare string (an expression, a choice)."""
    if "=" not in item or "." not in item.split("=", 1)[0]:
        raise SceneError(f"--set {shorten(item)}: must be section.key=value, e.g. model.zeta=1")
    dotted, text = item.split("=", 1)
    section, key = split_key(dotted, f"--set {shorten(item)}")
    try:
        value = _parse_toml(f"v = {text}", f"--set {shorten(item)}")["v"]
    except SceneError as err:
        if "invalid TOML" not in str(err):
            raise
        value = text  # a bare string, e.g. an expression or a choice
    return section, key, value


def split_key(dotted: Any, what: str) -> tuple[str, str]:
    """``"section.key"`` as (section, key), a key of the schema's, written exactly: a key with
    spaces around it would be another key to a sweep's table and the same one to the scene.

    Raises:
        SceneError: naming ``what`` (where the key was given) if it is not.
    """
    if not isinstance(dotted, str) or dotted.count(".") != 1:
        raise SceneError(f"{what}: {quote(str(dotted))} must be section.key, e.g. model.zeta")
    if any(c.isspace() for c in dotted):
        raise SceneError(f"{what}: {quote(dotted)} has a space in it; write the key alone, "
                         f"{quote(''.join(dotted.split()))}")
    section, key = dotted.split(".")
    if section == "measures":
        raise SceneError(f"{what}: measures are declared in a [measures] table of a scene or "
                         "sweep file, not set by key")
    if section not in SCHEMA:
        raise SceneError(f"{what}: unknown section '{shorten(section)}': "
                         f"{_suggest(section, SCHEMA)}")
    if key not in SCHEMA[section]:
        raise SceneError(f"{what}: unknown key '{section}.{shorten(key)}': "
                         f"{_suggest(key, SCHEMA[section])}")
    return section, key


def with_values(data: dict, values: dict[str, Any], what: str = "--set") -> dict:
    """A copy of the raw scene ``data`` with ``values`` ({"section.key": value}) set.

    Raises:
        SceneError: for a key that is not a scene key (``what`` says where it was given).
    """
    data = {name: dict(part) if isinstance(part, dict) else part for name, part in data.items()}
    for dotted, value in values.items():
        section, key = split_key(dotted, f"{what} {dotted}" if what == "--set" else what)
        data.setdefault(section, {})
        if not isinstance(data[section], dict):
            raise SceneError(f"{section}: must be a section [{section}]")
        data[section][key] = value
    return data


def load(scene: str, overrides: list[str] | tuple[str, ...] = ()) -> Scene:
    """Load a built-in scene by name or a TOML file by path, apply ``--set`` overrides, validate.
    The description names the keys set (:func:`~rodfem.scene.values.with_changes`), unless an
    override sets it: ``description=...``.

    Raises:
        SceneError: if the scene cannot be read or any value is wrong.
    """
    if isinstance(overrides, str):
        raise SceneError("overrides: a list of section.key=value, not the string "
                         f"{shorten(repr(overrides))}")
    data, source = read(scene)
    changes, described = {}, False
    for item in overrides:
        if item.startswith("description="):
            data["description"], described = item.split("=", 1)[1], True
            continue
        section, key, value = _parse_override(item)
        data.setdefault(section, {})
        if not isinstance(data[section], dict):
            raise SceneError(f"{section}: must be a section [{section}]")
        data[section][key] = changes[f"{section}.{key}"] = value
    if not described and isinstance(data.get("description", ""), str):
        data["description"] = with_changes(data.get("description", ""), changes)
    return validate(data, source)
