"""What a run will write and hold, estimated before it starts, against what the machine has
free: a run that cannot fit stops at once (exit code 2) rather than after hours, unless asked to
go on anyway (``--no-size-check``)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

NUMBER = 8  # bytes of a number of history.h5: float64
BLOCK = 1024  # rows of the history a run holds in memory before it hands them on
STATE_PER_NODE = 4000  # bytes per node of the operators, factors and vectors of a method
FRAMES = 200  # at most about this many saved steps at the default output.every = 0
STRIDE = 50  # and no more often than every STRIDE steps


def save_every(scene) -> int:
    """The steps between two field saves: ``output.every``, or for 0 (the default) every 50
    steps, or less often so that a run saves about :data:`FRAMES` frames at most (the stride a
    round 1, 2 or 5 × 10ᵏ steps, so that the saved times are round)."""
    every = scene["output.every"]
    if every:
        return every
    need = max(1, -(-scene.steps // FRAMES))
    power = 10 ** int(math.log10(need))
    stride = next(m * power for m in (1, 2, 5, 10) if m * power >= need)
    return max(STRIDE, stride)


def save_interval(scene) -> float:
    """With adaptive steps, the time between two field saves: :func:`save_every` steps of the
    first step's size, ``save_every × time.dt``. Fields are saved at the first step at or after
    each multiple of it (:func:`frame`), whatever the steps the run takes: the saves of a run of
    many small steps are as many as of one of few large ones."""
    return save_every(scene) * scene["time.dt"]


def frame(t: float, interval: float) -> int:
    """The number of the save interval the time t is in: a step whose number exceeds that of the
    last save's time is saved."""
    return math.floor(t / interval)


def scheduled(saves: list, scene) -> list:
    """The saves ``[step, t, ...]`` of a run that an uninterrupted run of ``scene`` makes: those
    off the schedule (an interrupted or finished run's last step, or steps off the stride of an
    extended run's new end) are left out."""
    every = save_every(scene)
    if not scene.adaptive:
        return [s for s in saves if s[0] % every == 0]
    interval, kept, last = save_interval(scene), [], -1
    for s in saves:
        if frame(s[1], interval) > last:
            kept.append(s)
            last = frame(s[1], interval)
    return kept


class SizeError(ValueError):
    """The run would not fit on the disk or in memory (exit code 2)."""


def estimate(scene) -> tuple[int, int]:
    """(bytes written, bytes of memory at most) of a run of ``scene``. With adaptive steps the
    fields are saved at most once per save interval (:func:`save_interval`), T/(output.every
    Δt₀) + 2 times, whatever steps the run takes; those steps are not known before it runs, and
    the history is estimated at T/Δt₀ rows (the steps of the first step's size)."""
    from rodfem.output.columns import for_scene, readings

    steps, nodes = scene.steps, scene["mesh.cells"] + 1
    saves = steps // save_every(scene) + 2  # adaptive: the save intervals in T, as many
    per_save = sum(nodes if name in ("theta", "u", "velocity") else nodes - 1
                   for name in scene["output.fields"])
    fields = saves * per_save * 8
    columns = for_scene(scene)
    history = (steps // scene["output.history_every"] + 2) * len(columns) * NUMBER
    # the raw rows of a block: the slots, then the readings
    block = BLOCK * (8 + len(readings(columns))) * 8
    # Between two checkpoints rank 0 keeps the saved fields and the history's rows; at most all.
    return fields + history, fields + history + block + nodes * STATE_PER_NODE


def _free_memory() -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"


def room_error(scene, out: Path, already: int = 0) -> str | None:
    """Why the run of ``scene`` into ``out`` would not fit, of which ``already`` bytes are
    written (a resumed run's), or None."""
    written, memory = estimate(scene)
    written -= already
    try:
        disk = shutil.disk_usage(_existing(out)).free
    except OSError:
        disk = None
    ram = _free_memory()
    advice = ("fewer steps, fields saved less often (output.every) or fewer of them "
              "(output.fields), fewer probes, or --no-size-check to run anyway")
    if disk is not None and written > disk:
        return (f"the run would write about {_size(written)} into {out}, where "
                f"{_size(disk)} is free; use {advice}")
    if ram is not None and memory > ram:
        return (f"the run would hold about {_size(memory)} in memory, and "
                f"{_size(ram)} is free; use {advice}")
    return None


def check_room(scene, out: Path, comm, allow: bool = False) -> None:
    """SizeError (on every rank, one line) if the run of ``scene`` into ``out`` would not fit."""
    error = room_error(scene, out) if comm.rank == 0 and not allow else None
    error = comm.bcast(error, root=0)
    if error:
        raise SizeError(error)
