"""What ``rodfem verify --scenes`` verifies besides the built-in scenes: a user's scene files and
the scenes of sweep files (all, or those ``--select`` names, each named <file's name>-<index>),
each with its ``--set`` values, and the ladders of runs each gets.

A scene's ladders are of its own sizes, refined by 2 from them, with the scene's own method and
time scheme:

* in h: cells c, 2c, 4c (… with more rungs) at the scene's Δt (adaptive steps: the tolerance
  ladder's finest tolerance, whose time error that ladder measures,
  :func:`rodfem.studies.verification.refine.flag_time_errors`), against a run on
  :attr:`Ladders.h_reference` times the finest rung's cells;
* in Δt: Δt, Δt/2, Δt/4 … on the scene's cells, against a run with the finest Δt over
  :attr:`Ladders.dt_reference`; with adaptive steps (``time.adaptive``) the tolerance is refined
  in its place (the scheme's default where the scene gives 0), against a run at the finest
  tolerance over the same factor.

Every run of every ladder is checked to be a valid scene before anything runs
(:func:`parse_scenes`); :mod:`rodfem.studies.verification.refine` runs them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from rodfem.scene import Scene, SceneError, load
from rodfem.scene.files import read_file
from rodfem.scene.loading import _parse_override
from rodfem.scene.schema import TOLERANCES
from rodfem.studies.sweep import design
from rodfem.studies.verification import verify


@dataclasses.dataclass(frozen=True)
class Ladders:
    """The ladders of a user's scene."""

    rungs: int  # runs per ladder, each refining the one before by 2 (3 at least: an order)
    h_reference: int  # the h reference: this many times the finest rung's cells
    dt_reference: int  # the Δt (tolerance) reference: the finest rung's over this


# The reference's own error, relative to the finest rung's, is 8⁻² (order 2 in h) and 16⁻¹ (order
# 1 in Δt): it moves the errors' slopes by 0.035 at most (Δt, three rungs; the measures' orders
# need no reference). Three rungs cost 1 + 2 + 4 runs of the scene a ladder, and the references
# 32 (h) and 64 (Δt): about 110 runs of the scene in all (paper5's file, T = 8: 13 s; four
# rungs, 26 s; docs/accuracy.md).
QUICK = Ladders(rungs=3, h_reference=8, dt_reference=16)
DEFAULT = Ladders(rungs=4, h_reference=8, dt_reference=16)


@dataclasses.dataclass(frozen=True)
class UserScene:
    """A scene file to verify (or a scene of a sweep file: ``member``, its index), its ``--set``
    values and its name in the tables."""

    key: str
    path: str
    overrides: tuple[str, ...]
    member: int | None = None

    def at(self, cells: int | None = None, dt: float | None = None,
           tolerance: float | None = None) -> Scene:
        """The scene, with other cells, Δt or tolerance where given, keeping the row of every
        step (the errors and measures are of every step, whatever rows the scene keeps)."""
        sizes = ["output.history_every=1", *([f"mesh.cells={cells}"] if cells else []),
                 *([f"time.dt={dt!r}"] if dt else []),
                 *([f"time.tolerance={tolerance!r}"] if tolerance else [])]
        if self.member is None:
            return load(self.path, [*self.overrides, *sizes])
        extra = {f"{section}.{key}": value for section, key, value
                 in map(_parse_override, [*self.overrides, *sizes])}
        return design.load(self.path).scene(self.member, extra)


# The sections only a sweep file has: a TOML file in --scenes with one of them is a sweep, each
# of its scenes (or those --select names) verified as a scene file is.
SWEEP_SECTIONS = ("set", "grid", "zip", "sample")


def is_sweep(path: str) -> bool:
    """Whether the TOML file ``path`` is a sweep file (SceneError if it cannot be read)."""
    data = read_file(path, f"scene '{path}'")
    return any(section in data for section in SWEEP_SECTIONS)


def parse_select(text: str | None) -> tuple[int, ...] | None:
    """``"1,3"`` → the indices of a sweep's scenes to verify (results.csv's index, from 0);
    None for every scene.

    Raises:
        VerifyError: an item that is not an index (one line).
    """
    if text is None:
        return None
    indices = []
    for item in (i.strip() for i in text.split(",")):
        if not item.isdigit():
            raise verify.VerifyError(f"--select: {item!r} is not the index of a scene; give "
                                     "indices of the sweep's scenes from 0 (results.csv's "
                                     "index), comma-separated, e.g. 1,3")
        indices.append(int(item))
    return tuple(sorted(set(indices)))


def members(path: str, overrides: tuple[str, ...], select: tuple[int, ...] | None
            ) -> list[UserScene]:
    """The scenes of the sweep file ``path`` to verify, each named <file's name>-<index>.

    Raises:
        VerifyError: a mistake in the sweep, a value a scene refuses, or an index it does not
            have (one line).
    """
    try:
        spec = design.load(path)
    except SceneError as err:
        raise verify.VerifyError(f"--scenes: {err}") from None
    if select is not None and select[-1] >= len(spec):
        raise verify.VerifyError(f"--select: {Path(path).name} has {len(spec)} scenes, indices "
                                 f"0 to {len(spec) - 1}; got {select[-1]}")
    chosen = select if select is not None else range(len(spec))
    users = [UserScene(f"{Path(path).stem}-{i}", path, tuple(overrides), i) for i in chosen]
    for user in users:
        try:
            user.at()
        except SceneError as err:
            raise verify.VerifyError(f"--scenes: {err}") from None
    return users


def parse_scenes(text: str | None, overrides: list[str] | tuple[str, ...] = (),
                 ladders: Ladders | None = None, select: str | None = None
                 ) -> tuple[tuple[str, ...], tuple[UserScene, ...]]:
    """``"paper1,my.toml,study.toml"`` → the built-in scenes (in their standard order) and the
    scene files and sweeps' scenes (in the given order; a sweep's, those of ``select`` or all),
    each loaded with ``overrides`` to check it, and every run of its ``ladders`` (default
    :data:`DEFAULT`).

    Raises:
        VerifyError: an unknown name, a file that cannot be read or a bad value (one line),
            ``--set`` without a scene file, or ``--select`` without a sweep file.
    """
    allowed = verify.available_scenes()
    chosen = parse_select(select)
    if text is None:
        if overrides:
            raise verify.VerifyError("--set: applies to a scene file given in --scenes; the "
                                     "built-in scenes are verified as they are")
        if chosen is not None:
            raise verify.VerifyError("--select: applies to a sweep file given in --scenes")
        return allowed, ()
    names = [item.strip() for item in text.split(",")]
    users, sweeps = [], 0
    for name in names:
        if name in allowed:
            continue
        if not name.endswith(".toml"):
            raise verify.VerifyError(f"--scenes: unknown scene {name!r}; allowed: "
                                     f"{', '.join(allowed)}, or a scene or sweep file (.toml)")
        try:
            sweep = is_sweep(name)
        except SceneError as err:
            raise verify.VerifyError(f"--scenes: {name}: {str(err).split(': ', 1)[-1]}") \
                from None
        if sweep:
            found = members(name, tuple(overrides), chosen)
            sweeps += 1
        else:
            try:
                load(name, overrides)
            except SceneError as err:
                raise verify.VerifyError(f"--scenes: {name}: {err}") from None
            found = [UserScene(Path(name).stem, name, tuple(overrides))]
        for user in found:
            if user.key in allowed or user.key in (u.key for u in users):
                raise verify.VerifyError(f"--scenes: the scene file {name!r} has the name "
                                         f"{user.key!r} of another scene; rename the file")
            users.append(user)
            _check_ladders(user, ladders or DEFAULT)
    if overrides and not users:
        raise verify.VerifyError("--set: applies to a scene file given in --scenes; the "
                                 "built-in scenes are verified as they are")
    if chosen is not None and not sweeps:
        raise verify.VerifyError("--select: applies to a sweep file given in --scenes")
    return tuple(a for a in allowed if a in names), tuple(users)


def _check_ladders(user: UserScene, ladders: Ladders) -> None:
    """Every run of a scene file's ladders is a valid scene."""
    for group in user_groups((user,)):
        for sizes in ladder(user, group.refined, ladders):
            try:
                user.at(**sizes)
            except SceneError as err:
                told = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                                 for k, v in sizes.items() if v is not None)
                where = user.path if user.member is None else f"{user.path}, scene {user.key}"
                raise verify.VerifyError(f"--scenes: {where}: its {group.refined} ladder's "
                                         f"run at {told}: {err}") from None


def tolerance(scene: Scene) -> float:
    """The adaptive steps' tolerance of a scene: its own, or its scheme's default (0)."""
    return scene["time.tolerance"] or TOLERANCES[scene["time.scheme"]]


def ladder(user: UserScene, refined: str, ladders: Ladders) -> list[dict]:
    """The sizes of each rung of a ladder (cells, dt, tolerance), then the reference's."""
    scene = user.at()
    cells, dt = scene["mesh.cells"], scene["time.dt"]
    tol = tolerance(scene) if scene.adaptive else None
    halves = [2 ** k for k in range(ladders.rungs)]
    if refined == "h":  # adaptive: at the tolerance ladder's finest (asymptotic.POLLUTION)
        tol_h = tol / halves[-1] if tol is not None else None
        rungs = [dict(cells=cells * k, dt=dt, tolerance=tol_h) for k in halves]
        return [*rungs, dict(cells=rungs[-1]["cells"] * ladders.h_reference, dt=dt,
                             tolerance=tol_h)]
    if refined == "tol":
        rungs = [dict(cells=cells, dt=dt, tolerance=tol / k) for k in halves]
        return [*rungs, dict(cells=cells, dt=dt, tolerance=tol / halves[-1] / ladders.dt_reference)]
    rungs = [dict(cells=cells, dt=dt / k, tolerance=None) for k in halves]
    return [*rungs, dict(cells=cells, dt=dt / halves[-1] / ladders.dt_reference, tolerance=None)]


@dataclasses.dataclass(frozen=True)
class UserGroup:
    """One ladder of a user's scene: in h, in Δt, or in the adaptive steps' tolerance."""

    user: UserScene
    refined: str

    @property
    def scene(self) -> str:
        return self.user.key


def user_groups(users: tuple[UserScene, ...]) -> list[UserGroup]:
    return [UserGroup(u, d) for u in users for d in ("h", "tol" if u.at().adaptive else "dt")]


def cost(group: UserGroup, ladders: Ladders) -> float:
    """The work of a ladder in cell-steps (adaptive steps counted at the first step)."""
    end = group.user.at()["time.end"]
    return sum(s["cells"] * end / s["dt"] for s in ladder(group.user, group.refined, ladders))
