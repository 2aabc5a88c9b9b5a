"""Sweep files: which scenes a sweep runs, read and checked before any of them runs.

A sweep file is TOML::

    scene = "paper1"                    # the base scene: a built-in name, or a TOML path
                                        # (relative to the sweep file)
    [set]                               # values every scene shares
    "time.end" = 8
    [grid]                              # a full factorial over these axes
    "model.k" = [0.1, 1, 10, 100]       # listed values
    "model.zeta" = {linspace = [0.2, 1.0, 5]}   # 5 values evenly spaced from 0.2 to 1.0
    "obstacle.epsilon" = {logspace = [1e-4, 1e-2, 3]}  # 1e-4, 1e-3, 1e-2: the ends are values
    [zip]                               # lists of one length, taken together (one axis)
    "obstacle.gap" = [0.05, 0.1, 0.2]
    "model.theta_A" = [5, 10, 20]
    [sample]                            # points drawn from ranges (one axis of `count` points)
    method = "latin-hypercube"          # or "random"
    count = 50
    seed = 1
    [sample.ranges]
    "model.a" = [0.0, 0.1]              # uniform in [0, 0.1]
    "model.k" = {log = [0.1, 100]}      # log-uniform
    [measures]                          # measures of every scene (rodfem.scene.measures)
    peak_force = { column = "contact_force", reduce = "max" }

Any scene key can be set or swept. The scenes are the product of the grid's axes (in the file's
order, the last fastest), then the zipped lists, then the samples; each scene's index is its
place in that order, which is the order of ``results.csv``. The sweep's ``[measures]`` are added
to the base scene's own; a name both declare is refused (a sweep does not silently change what
its scene measures). Samples are drawn with NumPy's PCG64
from the seed: the same file gives the same scenes on every machine.

Every mistake is a :class:`SceneError` of one line that names the file and the key (for a value
a scene refuses: the scene's number and its swept values too).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.scene import SCHEMA, Scene, SceneError, read, split_key, validate, with_values
from rodfem.scene.files import read_file
from rodfem.scene.loading import _suggest, _toml_value
from rodfem.scene.measures import merged

SECTIONS = ("scene", "description", "set", "grid", "zip", "sample", "measures")
SAMPLE_KEYS = ("method", "count", "seed", "ranges")
SAMPLERS = ("random", "latin-hypercube")
MAX_SCENES = 1_000_000


@dataclasses.dataclass(frozen=True)
class Sweep:
    """A checked sweep.

    Attributes:
        name: the file's name (or "<dict>"), for messages.
        data: the sweep as TOML data (what resume reads again).
        base: the base scene's raw data, and ``source`` its name or path.
        fixed: the ``[set]`` values.
        axes: the swept keys, in the order of results.csv's columns.
        design: per axis, "grid", "zip" or "sample".
        grid: the grid's values per grid axis (for maps).
        points: per scene, its swept values by key.
        measures: the measures of every scene, raw: the base scene's, then the sweep's.
    """

    name: str
    data: dict
    base: dict
    source: str
    fixed: dict[str, Any]
    axes: tuple[str, ...]
    design: dict[str, str]
    grid: dict[str, list]
    points: list[dict[str, Any]]
    measures: dict = dataclasses.field(default_factory=dict)

    @functools.cached_property
    def targeted(self) -> tuple[str, ...]:
        """The declared measures the scenes hold to an accuracy target (the first scene's; every
        scene's, checked as they are taken)."""
        return tuple(self.scene(0).targets) if self.points else ()

    @property
    def declared(self) -> tuple[str, ...]:
        """The names of the measures every scene declares (results.csv's columns of them)."""
        return tuple(self.measures)

    def __len__(self) -> int:
        return len(self.points)

    def scene(self, index: int, extra: dict[str, Any] | None = None) -> Scene:
        """The validated scene of ``index`` (SceneError naming it if a value is refused), with
        ``extra`` values set over its own ({"section.key": value}: ``rodfem verify``'s)."""
        point = self.points[index]
        try:
            data = with_values(self.base, {**self.fixed, **point, **(extra or {})}, self.name)
            if self.measures:
                data["measures"] = self.measures
            scene = validate(data, self.source)
            if index and tuple(scene.targets) != self.targeted:
                raise SceneError(f"it holds {_listed(scene.targets)} to accuracy targets, the "
                                 f"first scene {_listed(self.targeted)}: every scene of a sweep "
                                 "holds the same measures to targets (their results.csv columns)")
            return scene
        except SceneError as err:
            raise SceneError(f"{self.name}: scene {index + 1} of {len(self)} "
                             f"({describe(point)}): {err}") from None

    def scenes(self) -> list[Scene]:
        """Every scene, validated: the first refused raises (nothing has run)."""
        return [self.scene(i) for i in range(len(self))]


def _listed(names) -> str:
    return ", ".join(names) if names else "no measure"


def describe(point: dict[str, Any]) -> str:
    return ", ".join(f"{key} = {_toml_value(value)}" for key, value in point.items()) or "no axes"


def _kind(key: str) -> str:
    section, name = key.split(".")
    return SCHEMA[section][name].kind


def _number(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(f"{what}: must be a finite number, got {_toml_value(value)}")
    return float(value)


def _as_kind(key: str, values, what: str) -> list:
    """Generated values as the key's kind: integers rounded for integer keys."""
    kind = _kind(key)
    if kind == "integer":
        return [int(round(v)) for v in values]
    if kind != "real":
        raise SceneError(f"{what}: {key} is not a number; list its values instead")
    return [float(v) for v in values]


def _axis(key: str, spec, what: str) -> list:
    """The values of one grid or zip axis: a list, or {linspace|logspace = [start, stop, n]}."""
    if isinstance(spec, list):
        if not spec:
            raise SceneError(f"{what}: empty; list at least one value")
        return list(spec)
    if isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in ("linspace", "logspace"):
        (how, args), = spec.items()
        if not (isinstance(args, list) and len(args) == 3):
            raise SceneError(f"{what}: {how} must be [start, stop, count], got "
                             f"{_toml_value(args) if not isinstance(args, dict) else args}")
        start, stop = (_number(v, f"{what} {how}") for v in args[:2])
        count = args[2]
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_SCENES:
            raise SceneError(f"{what}: {how} count must be an integer from 1 to {MAX_SCENES}, "
                             f"got {_toml_value(count)}")
        if how == "logspace":
            if start <= 0 or stop <= 0:
                raise SceneError(f"{what}: logspace needs start and stop > 0 (they are the "
                                 f"ends, not exponents), got {start:g}, {stop:g}")
            with np.errstate(all="ignore"):
                values = np.geomspace(start, stop, count)
        else:
            with np.errstate(all="ignore"):
                values = np.linspace(start, stop, count)
        if not np.isfinite(values).all():
            raise SceneError(f"{what}: {how} from {start:g} to {stop:g} overflows")
        return _as_kind(key, values, what)
    raise SceneError(f"{what}: must be a list of values or {{linspace = [start, stop, count]}} "
                     f"or {{logspace = [start, stop, count]}}, got {_toml_value(spec)}"
                     if not isinstance(spec, dict) else
                     f"{what}: must be a list of values or {{linspace = [start, stop, count]}} "
                     f"or {{logspace = [start, stop, count]}}")


def _plain(value, what: str):
    """``value`` as TOML gives it: NumPy arrays and tuples as lists, NumPy scalars as Python's
    (a sweep from Python); SceneError for anything else a sweep cannot hold (a date, an
    object), before anything is written."""
    if isinstance(value, np.ndarray) and value.ndim > 0:
        value = list(value)
    if isinstance(value, (np.generic, np.ndarray)):
        value = value.item()
    if isinstance(value, dict):
        for key in value:
            if not isinstance(key, str):
                raise SceneError(f"{what.rstrip(':')}: {key!r} is not a name (a string)")
        return {key: _plain(v, f"{what} {key}") for key, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v, what) for v in value]
    if isinstance(value, (bool, int, float, str)):
        return value
    shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:39] + "…"
    raise SceneError(f"{what.rstrip(':')}: {type(value).__name__} {shown} is not a value of a "
                     "sweep (numbers, strings, booleans, lists of them)")


def _samples(table, name: str) -> tuple[list[str], list[list]]:
    """The keys and the columns of values of ``[sample]``."""
    if not isinstance(table, dict):
        raise SceneError(f"{name}: [sample] must be a section")
    for key in table:
        if key not in SAMPLE_KEYS:
            raise SceneError(f"{name}: unknown key 'sample.{key}': {_suggest(key, SAMPLE_KEYS)}")
    method = table.get("method", "random")
    if method not in SAMPLERS:
        raise SceneError(f"{name}: sample.method must be one of "
                         f"{' | '.join(repr(s) for s in SAMPLERS)}, got {_toml_value(method)}")
    count = table.get("count")
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_SCENES:
        raise SceneError(f"{name}: sample.count must be an integer from 1 to {MAX_SCENES}, got "
                         f"{_toml_value(count) if count is not None else 'nothing'}")
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SceneError(f"{name}: sample.seed must be an integer >= 0, got {_toml_value(seed)}")
    ranges = table.get("ranges")
    if not isinstance(ranges, dict) or not ranges:
        raise SceneError(f"{name}: [sample.ranges] must give at least one key's range, e.g. "
                         '"model.k" = [0.1, 10]')
    keys, bounds = [], []
    for key, spec in ranges.items():
        what = f"{name}: sample.ranges {key}"
        split_key(key, what)
        log = isinstance(spec, dict) and list(spec) == ["log"]
        pair = spec["log"] if log else spec
        if not (isinstance(pair, list) and len(pair) == 2):
            raise SceneError(f"{what}: must be [low, high] or {{log = [low, high]}}")
        low, high = (_number(v, what) for v in pair)
        if not low <= high:
            raise SceneError(f"{what}: low {low:g} must be <= high {high:g}")
        if log and low <= 0:
            raise SceneError(f"{what}: a log range needs low > 0, got {low:g}")
        if _kind(key) not in ("real", "integer"):
            raise SceneError(f"{what}: only numbers can be sampled; list {key}'s values in "
                             "[grid] or [zip]")
        keys.append(key)
        bounds.append((low, high, log))
    rng = np.random.Generator(np.random.PCG64(seed))
    if method == "random":
        unit = rng.random((count, len(keys)))
    else:  # one point in each of `count` equal strata per key, strata paired at random
        unit = np.empty((count, len(keys)))
        for j in range(len(keys)):
            unit[:, j] = (rng.permutation(count) + rng.random(count)) / count
    columns = []
    for j, (key, (low, high, log)) in enumerate(zip(keys, bounds, strict=True)):
        u = unit[:, j]
        with np.errstate(all="ignore"):
            values = (np.exp(np.log(low) + u * (np.log(high) - np.log(low))) if log
                      else low + u * (high - low))
        if not np.isfinite(values).all():
            raise SceneError(f"{name}: sample.ranges {key}: [{low:g}, {high:g}] overflows")
        columns.append(_as_kind(key, np.clip(values, low, high), f"{name}: sample.ranges {key}"))
    return keys, columns


def base_scene(data: dict, name: str, directory: Path | None) -> str:
    """The base scene a study file ``name`` names (``scene = "paper1"``): a built-in name, or a
    TOML path, relative to ``directory`` (the study file's) unless absolute."""
    from rodfem.scene import BUILTIN, EXTRA

    scene = data.get("scene")
    if not isinstance(scene, str) or not scene:
        raise SceneError(f'{name}: scene must name the base scene, e.g. scene = "paper1"')
    if scene not in BUILTIN + EXTRA and directory is not None and not Path(scene).is_absolute():
        scene = str(directory / scene)
    return scene


def parse(data: dict, name: str, directory: Path | None = None,
          base: tuple[dict, str] | None = None) -> Sweep:
    """Check a sweep's TOML data and expand it into its points (:meth:`Sweep.scenes` validates
    the scenes; :func:`rodfem.studies.sweep.run.run_sweep` does before any runs). The base scene is
    read from the ``scene`` it names (relative to ``directory``), or is ``base`` (its raw data
    and source, as a sweep directory keeps them).

    Raises:
        SceneError: the first mistake, on one line.
    """
    if not isinstance(data, dict):
        raise SceneError(f"{name}: a sweep must be a TOML table")
    data = _plain(data, f"{name}:")
    for key in data:
        if key not in SECTIONS:
            raise SceneError(f"{name}: unknown entry '{key}': {_suggest(key, SECTIONS)}")
    scene = base_scene(data, name, directory)
    base, source = base if base is not None else read(scene)
    measures = merged(base.get("measures"), data.get("measures"), name)
    tables = {}
    for section in ("set", "grid", "zip"):
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise SceneError(f"{name}: [{section}] must be a section of \"section.key\" = ...")
        for key in table:
            split_key(key, f"{name}: {section} {key}")
        tables[section] = table
    fixed = dict(tables["set"])
    axes: dict[str, list] = {}
    design: dict[str, str] = {}
    for key, spec in tables["grid"].items():
        axes[key] = _axis(key, spec, f"{name}: grid {key}")
        design[key] = "grid"
    zipped = {key: _axis(key, spec, f"{name}: zip {key}") for key, spec in tables["zip"].items()}
    lengths = {len(v) for v in zipped.values()}
    if len(lengths) > 1:
        sizes = ", ".join(f"{k}: {len(v)}" for k, v in zipped.items())
        raise SceneError(f"{name}: the [zip] lists must have one length, got {sizes}")
    sampled_keys, sampled = _samples(data["sample"], name) if "sample" in data else ([], [])
    for key, where in [*((k, "zip") for k in zipped), *((k, "sample") for k in sampled_keys)]:
        if key in design:
            raise SceneError(f"{name}: {key} is swept twice ([{design[key]}] and [{where}])")
        design[key] = where
    for key in design:
        if key in fixed:
            raise SceneError(f"{name}: {key} is both set (in [set]) and swept (in "
                             f"[{design[key]}]); keep one")
    factors = [[(key, v) for v in values] for key, values in axes.items()]
    if zipped:
        factors.append([tuple(zip(zipped, values, strict=True))
                        for values in zip(*zipped.values(), strict=True)])
    if sampled_keys:
        factors.append([tuple(zip(sampled_keys, values, strict=True))
                        for values in zip(*sampled, strict=True)])
    count = math.prod(len(f) for f in factors)
    if count > MAX_SCENES:
        raise SceneError(f"{name}: {count} scenes; at most {MAX_SCENES} in one sweep")
    points = []
    for combination in itertools.product(*factors):
        point = {}
        for part in combination:
            point.update(dict(part) if isinstance(part[0], tuple) else [part])
        points.append(point)
    return Sweep(name, data, base, source, fixed, tuple(design), design, axes, points, measures)


def load(path: str | Path) -> Sweep:
    """Read and check a sweep file (a path)."""
    path = Path(path)
    return parse(read_file(path, f"sweep '{path}'"), path.name, path.parent)
