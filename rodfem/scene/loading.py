"""Scenes: what a user asks to simulate, read from TOML and validated before anything runs.

A scene is a TOML file with the sections below; every key has a default (the paper's common data
and its first experiment), so a scene names only what differs. The built-in scenes ``paper1`` …
``paper5`` are the paper's five experiments. Every value is checked here, and each mistake is
reported as a :class:`SceneError` whose message is one line naming the key and what is allowed.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import stat
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.scene.expressions import Expression, ExpressionError, shorten
from rodfem.scene.schema import (  # noqa: F401 (re-exported)
    BIG,
    BUILTIN,
    EXTRA,
    MAX_CELLS,
    MAX_STEPS,
    METHODS,
    MODEL_NAMES,
    SCHEMA,
    SMALL,
    SOURCE_NAMES,
    TIME_SCHEMES,
    TOP_LEVEL,
    Key,
    SceneError,
)


@dataclasses.dataclass(frozen=True)
class Scene:
    """A validated scene: ``values[section][key]`` holds every key, defaults filled in."""

    values: dict[str, dict[str, Any]]
    description: str = ""
    source: str = ""

    def __getitem__(self, dotted: str) -> Any:
        section, key = dotted.split(".")
        return self.values[section][key]

    @property
    def steps(self) -> int:
        """N = T/Δt."""
        return int(round(self["time.end"] / self["time.dt"]))

    @property
    def parameters(self) -> dict[str, float]:
        """The model's parameters, the names an initial-data expression may use."""
        return dict(self.values["model"])

    def initial(self, name: str) -> Expression:
        return Expression(self.values["initial"][name], MODEL_NAMES)

    def source_term(self, name: str) -> Expression | None:
        """The source of the ``heat`` or ``momentum`` equation, f(x, t; parameters), or None
        where the scene has none."""
        text = self.values["source"][name].strip()
        return None if _is_zero(text) else Expression(text, SOURCE_NAMES)

    def data(self) -> dict[str, dict[str, Any]]:
        """The resolved scene as TOML data (a fresh copy): every key that applies, so that
        :func:`validate` of it gives this scene again."""
        return {section: {key: self.values[section][key] for key, spec in keys.items()
                          if _applies(self, spec)} for section, keys in SCHEMA.items()}

    def to_toml(self) -> str:
        """The resolved scene as TOML: loading it gives the same scene."""
        lines = []
        if self.description:
            lines += [f"description = {_toml_value(self.description)}", ""]
        for section, keys in self.data().items():
            lines.append(f"[{section}]")
            for key, value in keys.items():
                lines.append(f"{key} = {_toml_value(value)}")
            lines.append("")
        return "\n".join(lines)


def _applies(scene: Scene, spec: Key) -> bool:
    """Whether a key that applies only with another key's value (``Key.only_with``) does here."""
    return spec.only_with is None or scene[spec.only_with[0]] == spec.only_with[1]


def _is_zero(text: str) -> bool:
    try:
        return float(text) == 0.0
    except ValueError:
        return False


def _toml_value(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a TOML basic string, any character
    return repr(value)


def _suggest(name: str, allowed) -> str:
    close = difflib.get_close_matches(name, list(allowed), n=1, cutoff=0.5)
    hint = f"did you mean '{close[0]}'? " if close else ""
    return f"{hint}allowed: {', '.join(allowed)}"


def _check_list(dotted: str, spec: Key, value: Any) -> list:
    """A list key's value: a list of distinct values, each checked as the key's element kind."""
    example = spec.default or ([spec.choices[0]] if spec.choices else [0.5])
    if not isinstance(value, (list, tuple)):
        raise SceneError(f"{dotted}: must be a list, e.g. {_toml_value(list(example))}, "
                         f"got {shorten(_toml_value(value), 60)}")
    element = dataclasses.replace(spec, kind=spec.kind[:-1])  # "reals" -> "real"
    items = [_check_value(f"{dotted}[{i}]", element, v) for i, v in enumerate(value)]
    if spec.kind == "reals":
        items = [x + 0.0 for x in items]  # -0.0 is 0
    if spec.kind == "choices" and dotted == "output.fields" and not items:
        raise SceneError(f"{dotted}: must name at least one of {', '.join(spec.choices)}")
    seen = set()
    for item in items:
        if item in seen:
            raise SceneError(f"{dotted}: {_toml_value(item)} is listed twice")
        seen.add(item)
    return items  # a list, as JSON holds it (a checkpoint's scene)


def _check_value(dotted: str, spec: Key, value: Any) -> Any:
    if spec.kind in ("reals", "choices"):
        return _check_list(dotted, spec, value)
    if spec.kind in ("real", "integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            noun = "a number" if spec.kind == "real" else "an integer"
            raise SceneError(f"{dotted}: must be {noun}, got {_toml_value(value)}")
        if spec.kind == "integer" and not isinstance(value, int):
            raise SceneError(f"{dotted}: must be an integer, got {value!r}")
        shown = shorten(repr(value), 30)
        if isinstance(value, float) and not math.isfinite(value):
            raise SceneError(f"{dotted}: must be finite, got {shown}")
        if spec.minimum is not None and value < spec.minimum:
            raise SceneError(f"{dotted}: must be >= {spec.minimum:g}, got {shown}")
        if spec.above is not None and value <= spec.above:
            raise SceneError(f"{dotted}: must be > {spec.above:g}, got {shown}")
        if spec.maximum is not None and value > spec.maximum:
            raise SceneError(f"{dotted}: must be <= {spec.maximum:g}, got {shown}")
        return float(value) if spec.kind == "real" else int(value)
    if spec.kind == "choice":
        if value not in spec.choices:
            choices = " | ".join(f'"{c}"' for c in spec.choices)
            raise SceneError(f"{dotted}: must be one of {choices}, got {_toml_value(value)}")
        return value
    assert spec.kind == "expression"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = repr(value)  # a constant is an expression too: u0 = 0
    try:
        Expression(value, SOURCE_NAMES if dotted.startswith("source.") else MODEL_NAMES)
    except ExpressionError as err:
        shown = _toml_value(shorten(value)) if isinstance(value, str) else _toml_value(value)
        raise SceneError(f"{dotted}: {shown} {err}") from None
    return value


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
            raise SceneError(f"unknown section '{name}': {_suggest(name, [*SCHEMA, *TOP_LEVEL])}")
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
                raise SceneError(f"unknown key '{section}.{key}': {_suggest(key, keys)}")
        values[section] = {
            key: _check_value(f"{section}.{key}", spec, given.get(key, spec.default))
            for key, spec in keys.items()
        }
    scene = Scene(values, description, source)
    for section, keys in SCHEMA.items():
        for key, spec in keys.items():
            if key in data.get(section, {}) and not _applies(scene, spec):
                other, value = spec.only_with
                raise SceneError(f'{section}.{key}: applies only with {other} = "{value}", '
                                 f'not "{scene[other]}"')
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
    redistributed = scene["discretisation.mass"].startswith("redistributed")
    if (scene["time.scheme"] == "crank-nicolson" and scene["obstacle.kind"] == "rigid"
            and not redistributed):
        raise SceneError(
            'time.scheme: "crank-nicolson" models obstacle.kind = "rigid" only with '
            'discretisation.mass = "redistributed" or "redistributed-lumped": with mass at x = 1 '
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
    dt, end = scene["time.dt"], scene["time.end"]
    if dt > end:
        raise SceneError(f"time.dt: must be <= time.end = {end!r}, got {dt!r}")
    ratio = end / dt
    if ratio > MAX_STEPS:
        raise SceneError(f"time.dt: at most {MAX_STEPS:g} steps, got {ratio:.3g} (end/dt)")
    if abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise SceneError(
            f"time.end: must be a whole number of steps of time.dt = {dt!r}, got {end!r} "
            f"({ratio:.6g} steps)"
        )
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
                f"({_toml_value(scene.values['initial'][name])})"
            )
        _check_magnitude(f"initial.{name}", values, x, scene.values["initial"][name])
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
                    f"({_toml_value(scene.values['source'][name])})"
                )
            _check_magnitude(f"source.{name}", values, x, scene.values["source"][name], t)


def _parse_override(item: str) -> tuple[str, str, Any]:
    if "=" not in item or "." not in item.split("=", 1)[0]:
        raise SceneError(f"--set {item}: must be section.key=value, e.g. model.zeta=1")
    dotted, text = item.split("=", 1)
    section, key = dotted.strip().split(".", 1)
    try:
        value = _parse_toml(f"v = {text}", f"--set {shorten(item)}")["v"]
    except SceneError as err:
        if "invalid TOML" not in str(err):
            raise
        value = text  # a bare string, e.g. an expression or a choice
    return section, key, value


def _parse_toml(text: str, what: str) -> dict:
    """TOML text as a dict; SceneError (one line) for anything tomllib refuses, including what
    it refuses with other errors: integers of more than 4,300 digits (ValueError), nesting
    deeper than Python's recursion limit (RecursionError)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{what}: invalid TOML ({err})") from None
    except ValueError as err:
        raise SceneError(f"{what}: a value TOML cannot hold ({err})") from None
    except RecursionError:
        raise SceneError(f"{what}: nested too deeply to read") from None


def read(scene: str | Path) -> tuple[dict, str]:
    """The raw TOML data of a built-in scene (by name) or a TOML file (by path), and its source:
    the name, or the path as given.

    Raises:
        SceneError: if the scene cannot be read.
    """
    scene = str(scene)
    if scene in BUILTIN or scene in EXTRA:
        text = resources.files("rodfem.scene").joinpath("builtin", f"{scene}.toml").read_text()
        return _parse_toml(text, f"scene '{scene}'"), scene
    path = Path(scene)
    try:
        # stat, not is_file(): since Python 3.14 is_file() says False for a name longer than
        # the system allows, where stat raises the error that says why
        is_file = stat.S_ISREG(path.stat().st_mode)
    except (FileNotFoundError, NotADirectoryError):
        is_file = False
    except (OSError, ValueError) as err:  # e.g. a name longer than the system allows
        raise SceneError(f"scene '{shorten(scene)}': cannot be read "
                         f"({getattr(err, 'strerror', None) or err})") from None
    if not is_file:
        raise SceneError(
            f"scene '{scene}': not a built-in scene ({', '.join(BUILTIN + EXTRA)}) nor a TOML "
            "file"
        )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError(f"scene '{scene}': cannot be read ({err})") from None
    return _parse_toml(text, f"scene '{shorten(scene)}'"), str(path)


def split_key(dotted: Any, what: str) -> tuple[str, str]:
    """``"section.key"`` as (section, key), the section one of the schema's.

    Raises:
        SceneError: naming ``what`` (where the key was given) if it is not.
    """
    if not isinstance(dotted, str) or dotted.count(".") != 1:
        raise SceneError(f"{what}: {_toml_value(str(dotted))} must be section.key, e.g. "
                         "model.zeta")
    section, key = dotted.strip().split(".")
    if section not in SCHEMA:
        raise SceneError(f"{what}: unknown section '{section}': {_suggest(section, SCHEMA)}")
    if key not in SCHEMA[section]:
        raise SceneError(f"{what}: unknown key '{section}.{key}': {_suggest(key, SCHEMA[section])}")
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

    Raises:
        SceneError: if the scene cannot be read or any value is wrong.
    """
    if isinstance(overrides, str):
        raise SceneError(f"overrides: a list of section.key=value, not the string {overrides!r}")
    data, source = read(scene)
    for item in overrides:
        section, key, value = _parse_override(item)
        if section not in SCHEMA:
            hint = _suggest(section, SCHEMA)
            raise SceneError(f"--set {item}: unknown section '{section}': {hint}")
        data.setdefault(section, {})
        if not isinstance(data[section], dict):
            raise SceneError(f"{section}: must be a section [{section}]")
        data[section][key] = value
    return validate(data, source)
