"""A validated scene (:func:`rodfem.scene.loading.validate` makes one): its values by section,
defaults filled in, and what the rest of rodfem asks of it."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from typing import Any

from rodfem.scene.expressions import Expression, shorten
from rodfem.scene.measures import Declared, toml_lines
from rodfem.scene.schema import MODEL_NAMES, OPTIONAL_SECTIONS, SCHEMA, SOURCE_NAMES, Key
from rodfem.scene.values import _check_value, _toml_value


@dataclasses.dataclass(frozen=True)
class Scene(Mapping):
    """A validated scene: ``sections[section][key]`` holds every key, defaults filled in.

    It is a read-only mapping of the dotted keys that apply to it (those ``data()`` writes)
    to their values: ``scene["model.k"]``, ``dict(scene)``, ``scene.keys()``, ``"model.k" in
    scene``. A key that does not apply (``time.tolerance`` of a fixed-step scene) is none of its
    keys, though ``scene[key]`` still reads its default. ``measures``: the measures it declares
    (:mod:`rodfem.scene.measures`), in the file's order.
    """

    sections: dict[str, dict[str, Any]]
    description: str = ""
    source: str = ""
    measures: tuple[Declared, ...] = ()

    def __getitem__(self, dotted: str) -> Any:
        section, _, key = dotted.partition(".") if isinstance(dotted, str) else ("", "", "")
        try:
            return self.sections[section][key]
        except KeyError:
            raise KeyError(dotted) from None

    def __iter__(self) -> Iterator[str]:
        return (f"{section}.{key}" for section, keys in SCHEMA.items() if self._written(section)
                for key, spec in keys.items() if _applies(self, spec))

    def _written(self, section: str) -> bool:
        """Whether the resolved scene writes ``section``: every section but an optional one
        (:data:`~rodfem.scene.schema.OPTIONAL_SECTIONS`) whose keys all hold their defaults."""
        return section not in OPTIONAL_SECTIONS or any(
            self.sections[section][key] != spec.default for key, spec in SCHEMA[section].items())

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __contains__(self, dotted: object) -> bool:
        section, _, key = dotted.partition(".") if isinstance(dotted, str) else ("", "", "")
        spec = SCHEMA.get(section, {}).get(key)
        return spec is not None and self._written(section) and _applies(self, spec)

    def get(self, dotted: str, default: Any = None) -> Any:
        """The value of a key that applies, else ``default`` (as for a dict)."""
        return self[dotted] if dotted in self else default

    def __repr__(self) -> str:
        return _summary(self)

    @property
    def targets(self) -> dict[str, float]:
        """The relative error wanted of each declared measure ({name: target}; empty: none,
        the scene's own mesh and steps): its own ``target``, else ``accuracy.target`` (but for
        a measure set by the steps, which has no error to hold: :attr:`Declared.stepped`)."""
        common = self.sections["accuracy"]["target"]
        wanted = {m.name: m.target if m.target is not None else 0.0 if m.stepped else common
                  for m in self.measures}
        return {name: target for name, target in wanted.items() if target > 0.0}

    @property
    def steps(self) -> int:
        """N = T/Δt (with adaptive steps, the steps of the first step's size: an estimate)."""
        return int(round(self["time.end"] / self["time.dt"]))

    @property
    def adaptive(self) -> bool:
        """Whether the steps adapt (``time.adaptive``)."""
        return bool(self["time.adaptive"])

    @property
    def parameters(self) -> dict[str, float]:
        """The model's parameters, the names an initial-data expression may use."""
        return dict(self.sections["model"])

    def initial(self, name: str) -> Expression:
        return Expression(self.sections["initial"][name], MODEL_NAMES)

    def source_term(self, name: str) -> Expression | None:
        """The source of the ``heat`` or ``momentum`` equation, f(x, t; parameters), or None
        where the scene has none."""
        text = self.sections["source"][name].strip()
        return None if _is_zero(text) else Expression(text, SOURCE_NAMES)

    def data(self) -> dict[str, dict[str, Any]]:
        """The resolved scene as TOML data (a fresh copy): every key that applies, so that
        :func:`validate` of it gives this scene again; a ``measures`` table where it declares
        any."""
        data = {section: {key: self.sections[section][key] for key, spec in keys.items()
                          if _applies(self, spec)} for section, keys in SCHEMA.items()
                if self._written(section)}
        if self.measures:
            data["measures"] = {m.name: m.data() for m in self.measures}
        return data

    def to_toml(self) -> str:
        """The resolved scene as TOML: loading it gives the same scene."""
        lines = []
        if self.description:
            lines += [f"description = {_toml_value(self.description)}", ""]
        for section, keys in self.data().items():
            if section == "measures":
                continue
            lines.append(f"[{section}]")
            for key, value in keys.items():
                lines.append(f"{key} = {_toml_value(value)}")
            lines.append("")
        return "\n".join([*lines, *toml_lines(self.measures)])


def _applies(scene: Scene, spec: Key) -> bool:
    """Whether a key that applies only with another key's value (``Key.only_with``) does here."""
    return spec.only_with is None or spec.applies_with(scene[spec.only_with[0]])


def _summary(scene: Scene, width: int = 400) -> str:
    """A few lines on a scene, as ``repr`` shows it: where it comes from, its description, and
    the keys whose values are not the defaults (as many as fit in about ``width`` characters)."""
    changed = [f"{key} = {shorten(_toml_value(value), 40)}" for key, value in scene.items()
               if value != _default(key)]
    head = f"<rodfem.Scene {scene.source or '(no source)'}: {len(scene)} keys, " \
           f"{len(changed)} not the default>"
    lines = [head] + ([shorten(scene.description, 90)] if scene.description else [])
    shown, used = [], sum(map(len, lines))
    for item in changed:
        if used + len(item) > width:
            shown.append(f"… {len(changed) - len(shown)} more")
            break
        shown.append(item)
        used += len(item) + 2
    return "\n".join(lines + wrapped(shown))


def wrapped(items: list[str], lead: str = "    ", width: int = 96) -> list[str]:
    """Items joined by commas into lines of at most ``width`` characters, the first after
    ``lead``, the others indented; no item is split (one longer than a line has one to
    itself). What the reprs use for their lists of keys and measures."""
    lines: list[str] = []
    for item in items:
        if lines and len(lines[-1]) + len(item) + 2 <= width:
            lines[-1] += ", " + item
        else:
            if lines:
                lines[-1] += ","
            lines.append((lead if not lines else "    ") + item)
    return lines


def _default(dotted: str) -> Any:
    """A key's default as a scene holds it (a list as a list, say, not the schema's tuple)."""
    section, key = dotted.split(".")
    spec = SCHEMA[section][key]
    return _check_value(dotted, spec, spec.default)


def _is_zero(text: str) -> bool:
    try:
        return float(text) == 0.0
    except ValueError:
        return False
