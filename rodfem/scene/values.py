"""One scene value checked against its key's kind: a number in its range, one of the choices, an
expression, or a list of distinct such values; and the words the messages quote it with.

Every mistake is a :class:`SceneError` whose one line names the key (a list's element by its
index, ``output.probes[1]``) and what is allowed.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import re
from typing import Any

from rodfem.scene.expressions import Expression, ExpressionError, shorten
from rodfem.scene.schema import MODEL_NAMES, SOURCE_NAMES, Key, SceneError


def _toml_value(value: Any) -> str:
    """A value written as TOML: how the messages quote what a user gave, and how a resolved
    scene is written."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a TOML basic string, any character
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def quote(value: Any) -> str:
    """A value a user gave, as a one-line message quotes it: its TOML, cut short."""
    return shorten(_toml_value(value), 60)


_ITEM = re.compile(r"([a-z_]+\.[A-Za-z0-9_]+) = ")
_CLAUSE = " (with "


def _clause(description: str) -> tuple[str, dict[str, str]]:
    """A description split into its own words and the keys its closing "(with key = value,
    …)" names, with their values as written ({} where it has no such clause)."""
    bare = description.startswith("with ")
    at = 0 if bare else description.rfind(_CLAUSE)
    if not (bare or (at >= 0 and description.endswith(")"))):
        return description, {}
    items = description[5:] if bare else description[at + len(_CLAUSE):-1]
    starts = [m for m in _ITEM.finditer(items) if m.start() == 0
              or items[:m.start()].endswith(", ")]
    if not starts or starts[0].start() != 0:
        return description, {}
    named = {}
    for match, after in zip(starts, [*starts[1:], None], strict=True):
        named[match.group(1)] = items[match.end():after.start() - 2 if after else len(items)]
    return ("" if bare else description[:at]), named


def with_changes(description: str, changes: dict[str, Any]) -> str:
    """A scene's description after ``changes`` ({"model.zeta": 2}) were set over it, naming
    them: "Experiment 1 of the paper (with model.zeta = 2)". Keys set over a scene whose
    description names keys already are named in the same list, each once, at its last value."""
    if not changes:
        return description
    words, named = _clause(description)
    named.update({key: shorten(_toml_value(value)) for key, value in changes.items()})
    shown = ", ".join(f"{key} = {value}" for key, value in named.items())
    return f"{words} (with {shown})" if words else f"with {shown}"


def _suggest(name: str, allowed) -> str:
    """The closest allowed name, if one is close, and every allowed name."""
    close = difflib.get_close_matches(name, list(allowed), n=1, cutoff=0.5)
    hint = f"did you mean '{close[0]}'? " if close else ""
    return f"{hint}allowed: {', '.join(allowed)}"


def _check_list(dotted: str, spec: Key, value: Any) -> list:
    """A list key's value: a list of distinct values, each checked as the key's element kind."""
    example = spec.default or ([spec.choices[0]] if spec.choices else [0.5])
    if not isinstance(value, (list, tuple)):
        raise SceneError(f"{dotted}: must be a list, e.g. {_toml_value(list(example))}, "
                         f"got {quote(value)}")
    element = dataclasses.replace(spec, kind=spec.kind[:-1])  # "reals" -> "real"
    items = [_check_value(f"{dotted}[{i}]", element, v) for i, v in enumerate(value)]
    if spec.kind == "reals":
        items = [x + 0.0 for x in items]  # -0.0 is 0
    if spec.kind == "choices" and dotted == "output.fields" and not items:
        raise SceneError(f"{dotted}: must name at least one of {', '.join(spec.choices)}")
    seen = set()
    for item in items:
        if item in seen:
            raise SceneError(f"{dotted}: {quote(item)} is listed twice")
        seen.add(item)
    return items  # a list, as JSON holds it (a checkpoint's scene)


def _check_number(dotted: str, spec: Key, value: Any) -> int | float:
    """A real or integer key's value: a finite number of its kind within the key's range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        noun = "a number" if spec.kind == "real" else "an integer"
        raise SceneError(f"{dotted}: must be {noun}, got {quote(value)}")
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


def _check_value(dotted: str, spec: Key, value: Any) -> Any:
    """The value of the key ``dotted`` (described by ``spec``) as the scene holds it."""
    if spec.kind in ("reals", "choices"):
        return _check_list(dotted, spec, value)
    if spec.kind in ("real", "integer"):
        return _check_number(dotted, spec, value)
    if spec.kind == "boolean":
        if not isinstance(value, bool):
            raise SceneError(f"{dotted}: must be true or false, got {quote(value)}")
        return value
    if spec.kind == "choice":
        if value not in spec.choices:
            choices = " | ".join(f'"{c}"' for c in spec.choices)
            raise SceneError(f"{dotted}: must be one of {choices}, got {quote(value)}")
        return value
    assert spec.kind == "expression"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = repr(value)  # a constant is an expression too: u0 = 0
    try:
        Expression(value, SOURCE_NAMES if dotted.startswith("source.") else MODEL_NAMES)
    except ExpressionError as err:
        shown = _toml_value(shorten(value)) if isinstance(value, str) else quote(value)
        raise SceneError(f"{dotted}: {shown} {err}") from None
    return value
