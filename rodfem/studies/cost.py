"""What a study will cost, said before it starts: its runs × their steps × the time of a step,
measured here, and a study beyond :data:`BOUND_SECONDS` refused unless the user says ``--yes``.

The steps are each scene's ``time.end / time.dt`` (with adaptive steps, at the first step's
size: an estimate), averaged over up to :data:`SAMPLE` of the study's scenes, evenly spread. The
time of a step is measured: :data:`PROBE_STEPS` steps of the sampled scene with the most cells
(the costliest step, where only values differ) are run in memory, twice (the first run on a
machine may compile the scene's forms and loops), and the faster loop's µs/step taken;
setting up a scene and writing its files are left out, and iterations in contact may make its
steps dearer, so that the estimate is an order of magnitude, not a schedule. The ranks share the
runs: the time said is the wall time on them. A study that cannot reach :data:`SAY_SECONDS` even
at :data:`SLOWEST_US` µs/step (a generous bound on a step of this size) is not measured, and
nothing is said.
"""

from __future__ import annotations

import dataclasses
import tomllib

from rodfem.output import interrupts
from rodfem.scene import SceneError

BOUND_SECONDS = 86_400.0  # a day of wall time on the ranks given: beyond, --yes is needed
SAY_SECONDS = 600.0  # the estimate is said from ten minutes on
SAMPLE = 1000  # scenes whose steps are counted
PROBE_STEPS = 20
SLOWEST_US = 5000.0  # µs/step, plus a µs per cell: no step measured here came near it


@dataclasses.dataclass(frozen=True)
class Estimate:
    """``runs`` runs (``most``: at most that many) of about ``steps`` steps each, at
    ``us_per_step``, shared by ``ranks`` ranks."""

    runs: int
    steps: float
    us_per_step: float
    ranks: int
    most: bool = False

    @property
    def seconds(self) -> float:
        """The wall time on the ranks: each takes a share of the runs."""
        return self.runs * self.steps * self.us_per_step * 1e-6 / self.ranks

    def line(self) -> str:
        """In words, e.g. '524,288 runs of 500,000 steps: about 3 weeks on 2 ranks'."""
        runs = f"{'at most ' if self.most else ''}{self.runs:,} run{'s' * (self.runs != 1)}"
        ranks = f"{self.ranks} rank{'s' * (self.ranks != 1)}"
        return (f"{runs} of {round(self.steps):,} steps: about {duration(self.seconds)} on "
                f"{ranks} (at {self.us_per_step:.0f} µs/step, measured)")


def duration(seconds: float) -> str:
    """A time in the largest unit it makes at least one of, rounded: '3 weeks', '40 s'."""
    for unit, size in (("year", 365.25 * 86400), ("week", 7 * 86400), ("day", 86400),
                       ("hour", 3600), ("minute", 60)):
        if seconds >= size:
            count = round(seconds / size)
            return f"{count} {unit}{'s' * (count != 1)}"
    return f"{seconds:.0f} s"


def _sample(scene_of, count: int) -> list:
    """Up to :data:`SAMPLE` of the ``count`` scenes (``scene_of(i)``), evenly spread; a scene
    refused is left to the check of every scene, which names it."""
    step = max(1, count // SAMPLE)
    scenes = []
    for i in range(0, count, step):
        try:
            scenes.append(scene_of(i))
        except SceneError:
            continue
    return scenes


def _probe(scene) -> float | None:
    """The µs per step of :data:`PROBE_STEPS` steps of ``scene``, run in memory, or None."""
    from mpi4py import MPI

    from rodfem.run import simulate
    from rodfem.scene import validate
    from rodfem.scene.loading import with_values

    data = tomllib.loads(scene.to_toml())
    data.pop("measures", None)  # measured over the whole time; not needed for the steps
    steps = min(PROBE_STEPS, scene.steps)
    try:
        short = validate(with_values(data, {"time.end": steps * scene["time.dt"]}, "probe"))
        result = simulate(short, None, MPI.COMM_SELF, progress=False)
    except Exception as err:  # noqa: BLE001 (a probe that fails says nothing; a signal stops)
        if interrupts.signal_behind(err) is not None:
            raise
        return None
    done = result.summary.get("steps", 0)
    return float(result.summary["us_per_step"]) if done else None


def estimate(scene_of, count: int, ranks: int, runs: int | None = None) -> Estimate | None:
    """The cost of ``runs`` runs (default ``count``; more: at most that many) of the ``count``
    scenes ``scene_of(i)`` on ``ranks`` ranks, or None below :data:`SAY_SECONDS` (nothing is
    run where it cannot reach them even at the slowest step)."""
    scenes = _sample(scene_of, count)
    if not scenes:
        return None
    total = count if runs is None else runs
    steps = sum(s.steps for s in scenes) / len(scenes)
    probe = max(scenes, key=lambda s: s["mesh.cells"])
    slowest = Estimate(total, steps, SLOWEST_US + probe["mesh.cells"], ranks)
    if slowest.seconds < SAY_SECONDS:
        return None
    us = _probe(probe)
    if us is not None:  # the first run of a scene may compile its forms and loops: run it again
        again = _probe(probe)
        us = us if again is None else min(us, again)
    found = None if us is None else Estimate(total, steps, us, ranks, runs is not None)
    return found if found is not None and found.seconds >= SAY_SECONDS else None


def check(scene_of, count: int, comm, yes: bool, runs: int | None = None) -> Estimate | None:
    """The estimate (:func:`estimate`, made on rank 0 and the same on every rank); SceneError on
    every rank, one line, beyond :data:`BOUND_SECONDS` unless ``yes``."""
    import rodfem.run  # noqa: F401 (PETSc starts on every rank together: it is collective)

    found = comm.bcast(estimate(scene_of, count, comm.size, runs) if comm.rank == 0 else None,
                       root=0)
    if found is not None and found.seconds > BOUND_SECONDS and not yes:
        raise SceneError(f"{found.line()}: more than a day; give --yes to run it all the same, "
                         "or ask for fewer runs or steps")
    return found
