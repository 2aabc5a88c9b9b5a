"""A validated scene (:func:`rodfem.scene.loading.validate` makes one): its values by section,
defaults filled in, and what the rest of rodfem asks of it."""

from __future__ import annotations

import dataclasses
from typing import Any

from rodfem.scene.expressions import Expression
from rodfem.scene.measures import Declared, toml_lines
from rodfem.scene.schema import MODEL_NAMES, SCHEMA, SOURCE_NAMES, Key
from rodfem.scene.values import _toml_value


@dataclasses.dataclass(frozen=True)
class Scene:
    """A validated scene: ``sections[section][key]`` holds every key, defaults filled in;
    ``measures``, the measures it declares (:mod:`rodfem.scene.measures`), in the file's order."""

    sections: dict[str, dict[str, Any]]
    description: str = ""
    source: str = ""
    measures: tuple[Declared, ...] = ()

    def __getitem__(self, dotted: str) -> Any:
        section, key = dotted.split(".")
        return self.sections[section][key]

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
                          if _applies(self, spec)} for section, keys in SCHEMA.items()}
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


def _is_zero(text: str) -> bool:
    try:
        return float(text) == 0.0
    except ValueError:
        return False
