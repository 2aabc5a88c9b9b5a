"""Study files: a base scene, the values its runs share, and the parameters a study varies between
ranges, read and checked before anything runs (``rodfem fit`` and ``rodfem sensitivity``).

A study file is TOML::

    scene = "paper2"                  # the base scene: a built-in name, or a TOML path
                                      # (relative to the study file)
    [set]                             # values every run shares
    "time.end" = 2
    [parameters]                      # what the study varies, between [low, high]
    "model.zeta" = [0.5, 2.0]         # linear: the range spans less than a decade
    "obstacle.epsilon" = [1e-3, 1e-1] # a decade or more, low > 0: log-scaled
    "model.k" = {linear = [1, 100]}   # or say which
    [measures]                        # measures of every run (rodfem.scene.measures)
    peak_force = { column = "contact_force", reduce = "max" }

and the command's own keys (:data:`Study.extra`). A parameter is **log-scaled** where its range
spans a decade or more of positive values (``high >= 10 low > 0``), unless written
``{linear = [low, high]}`` (or ``{log = [low, high]}`` to ask for it): a study then works in
``log10`` of it, where a range over decades is evenly weighed. Only real-valued scene keys can be
parameters, and not one that ``[set]`` gives too.

The runs of a study are a sweep (:mod:`rodfem.studies.sweep.design`) of explicit points, one
``[zip]`` axis per parameter: :meth:`Study.sweep_data` is that sweep as TOML data, so that the sweep
engine deals them to the MPI ranks, journals and resumes them as any sweep's.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from rodfem.scene import SceneError, split_key
from rodfem.scene.files import read_file
from rodfem.scene.loading import _suggest, _toml_value
from rodfem.studies.sweep import design

COMMON = ("scene", "description", "set", "parameters", "measures")
SCALES = ("log", "linear")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One parameter: its scene key, its range and whether a study works in ``log10`` of it."""

    key: str
    low: float
    high: float
    log: bool

    def scaled(self, value: float) -> float:
        """``value`` on the study's scale: ``log10(value)`` for a log-scaled parameter."""
        return math.log10(value) if self.log else float(value)

    def value(self, scaled: float) -> float:
        """The parameter's value of a point ``scaled`` on the study's scale, within its range
        (round-off of ``10**`` clipped)."""
        value = 10.0 ** scaled if self.log else float(scaled)
        return min(max(value, self.low), self.high)

    @property
    def bounds(self) -> tuple[float, float]:
        """The range on the study's scale."""
        return self.scaled(self.low), self.scaled(self.high)

    @property
    def middle(self) -> float:
        """The range's middle on the study's scale, as a value."""
        low, high = self.bounds
        return self.value(0.5 * (low + high))


def parameters(table: Any, name: str, fixed: dict[str, Any]) -> tuple[Parameter, ...]:
    """The ``[parameters]`` of a study file (``name`` in messages), none of them in ``fixed``.

    Raises:
        SceneError: one line naming the key and what is allowed.
    """
    if not isinstance(table, dict) or not table:
        raise SceneError(f'{name}: [parameters] must give at least one range, e.g. '
                         '"model.zeta" = [0.5, 2.0]')
    found = []
    for key, spec in table.items():
        what = f"{name}: parameters {key}"
        section, entry = split_key(key, what)
        if design._kind(key) != "real":
            raise SceneError(f"{what}: only a real-valued key can be a parameter "
                             f"({key} is {design._kind(key)})")
        if key in fixed:
            raise SceneError(f"{what}: is given by [set] too; keep one")
        scale = None
        if isinstance(spec, dict):
            if len(spec) != 1 or next(iter(spec)) not in SCALES:
                raise SceneError(f"{what}: must be [low, high], {{log = [low, high]}} or "
                                 "{linear = [low, high]}")
            (scale, spec), = spec.items()
        if not (isinstance(spec, list) and len(spec) == 2):
            raise SceneError(f"{what}: must be [low, high], got "
                             f"{_toml_value(spec) if not isinstance(spec, dict) else 'a table'}")
        low, high = (design._number(v, what) for v in spec)
        if not low < high:
            raise SceneError(f"{what}: low {low:g} must be < high {high:g}")
        if scale == "log" and low <= 0:
            raise SceneError(f"{what}: a log-scaled range needs low > 0, got {low:g}")
        log = scale == "log" or (scale is None and 0 < low and high >= 10 * low)
        found.append(Parameter(key, low, high, log))
    return tuple(found)


@dataclasses.dataclass(frozen=True)
class Study:
    """A checked study file.

    Attributes:
        name: the file's name (or "<dict>"), for messages.
        data: the file as TOML data (what a study directory keeps and resume reads again).
        scene: the base scene as the sweep names it (a path made relative to the file's
            directory, where it was relative).
        fixed: the ``[set]`` values.
        parameters: the parameters, in the file's order.
        extra: the command's own keys, as given.
    """

    name: str
    data: dict
    scene: str
    fixed: dict[str, Any]
    parameters: tuple[Parameter, ...]
    extra: dict[str, Any]

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(p.key for p in self.parameters)

    def sweep_data(self, points) -> dict:
        """The sweep of the runs at ``points`` (rows of parameter values, in the order of
        :attr:`parameters`), as TOML data: one ``[zip]`` axis per parameter."""
        columns = {key: [] for key in self.keys}
        for row in points:
            for key, value in zip(self.keys, row, strict=True):
                columns[key].append(float(value))
        data = {"scene": self.scene, "zip": columns}
        for section in ("description", "set", "measures"):
            if section in self.data:
                data[section] = self.data[section]
        return data

    def sweep(self, points) -> design.Sweep:
        """:meth:`sweep_data` parsed (its scenes are validated as they are taken)."""
        return design.parse(self.sweep_data(points), self.name)


def parse(data: Any, name: str, directory: Path | None = None,
          extra: tuple[str, ...] = ()) -> Study:
    """Check a study file's TOML data: its sections, its parameters, and the scenes at the
    middle of every range and at each parameter's ends (the others at their middles), so that
    a value a scene refuses is found before anything runs. ``extra``: the command's own keys.

    Raises:
        SceneError: the first mistake, on one line.
    """
    if not isinstance(data, dict):
        raise SceneError(f"{name}: a study file must be a TOML table")
    data = design._plain(data, f"{name}:")
    allowed = (*COMMON, *extra)
    for key in data:
        if key not in allowed:
            raise SceneError(f"{name}: unknown entry '{key}': {_suggest(key, allowed)}")
    scene = design.base_scene(data, name, directory)
    fixed = data.get("set", {})
    if not isinstance(fixed, dict):
        raise SceneError(f'{name}: [set] must be a section of "section.key" = ...')
    found = parameters(data.get("parameters"), name, fixed)
    study = Study(name, data, scene, dict(fixed), found,
                  {key: data[key] for key in extra if key in data})
    middle = [p.middle for p in found]
    corners = [middle] + [[p.low if j == i else middle[j] for j, p in enumerate(found)]
                          for i in range(len(found))] \
        + [[p.high if j == i else middle[j] for j, p in enumerate(found)]
           for i in range(len(found))]
    sweep = study.sweep(corners)
    for i in range(len(sweep)):
        try:
            sweep.scene(i)
        except SceneError as err:
            where = "the middle of its ranges" if i == 0 else "an end of its ranges"
            shown = str(err).removeprefix(f"{name}: scene {i + 1} of {len(sweep)} ")
            raise SceneError(f"{name}: the scene at {where} {shown}") from None
    if sweep.targeted:
        raise SceneError(f"{name}: accuracy targets ([accuracy], a measure's target) are not held "
                         "by a study's runs, whose measures must vary smoothly with its "
                         "parameters on one mesh and step; remove them (rodfem run and rodfem "
                         "sweep hold them)")
    return study


def load(path: str | Path, extra: tuple[str, ...] = ()) -> Study:
    """Read and check a study file (a path)."""
    path = Path(path)
    return parse(read_file(path, f"study '{path}'"), path.name, path.parent, extra)
