"""Checkpoints: what a run needs to continue exactly where it was (``rodfem resume``).

``checkpoint.npz`` holds the method's state (:meth:`rodfem.solver.methods.base.Method.saved_state`)
and, as JSON in its entry ``meta``, the step, the rows of history.h5 at that step, the saved
fields, the SHA-256 of each file it counts (the history's rows, the mesh, every segment of
fields), the energy monitor and the iteration counts, the seconds spent, and the resolved scene it
belongs to. It is written last at each checkpoint, after history.h5 and the fields it counts are
on the disk, by write-then-rename: it is whole or the previous one. Whatever the process met
afterwards (Ctrl-C, SIGKILL, a full disk, a power cut), the run continues from it to the history
it would have had.

:class:`RunFiles` is a run's files together: history.h5, the fields, the checkpoint, and when to
write them.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
import zipfile
from pathlib import Path

import numpy as np

from rodfem.output.atomic import TEMPORARY, replacing, sync_directory
from rodfem.output.columns import for_scene
from rodfem.output.directories import keep_lock
from rodfem.output.fields import DIRECTORY, MESH, SEGMENT, FieldFile, file_digest, segment_name
from rodfem.output.files import HistoryFile, rows_digest
from rodfem.output.readers import DATASET, HISTORY

NAME = "checkpoint.npz"
FORMAT = 2  # 1: an earlier rodfem's (history.csv counted in bytes, no digest): not resumed


class CheckpointError(ValueError):
    """A checkpoint that cannot be used (missing, corrupt, of another scene)."""


def write_checkpoint(out: Path, arrays: dict[str, np.ndarray], meta: dict) -> None:
    meta = json.loads(json.dumps({"format": FORMAT, **meta}))  # as it will be read back
    meta["digest"] = digest(arrays, meta)
    with replacing(out / NAME, "wb") as file:
        np.savez(file, meta=np.array(json.dumps(meta)), **arrays)


def digest(arrays: dict[str, np.ndarray], meta: dict) -> str:
    """The SHA-256 of a checkpoint's content: every array's name, type, shape and bytes, and
    the metadata but its digest. A checkpoint changed in any way (a value scaled by 1 + 1e-12,
    an array stored as float32, a number of its metadata) no longer matches it."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(json.dumps([name, a.dtype.str, list(a.shape)]).encode())
        h.update(a.tobytes())
    h.update(json.dumps({k: v for k, v in meta.items() if k != "digest"},
                        sort_keys=True).encode())
    return h.hexdigest()


def read_checkpoint(out: Path) -> tuple[dict[str, np.ndarray], dict]:
    """The arrays and the metadata of ``out``'s checkpoint, checked whole (its digest) and
    field by field; CheckpointError (one line) otherwise."""
    path = out / NAME
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(str(arrays.pop("meta")))
    except FileNotFoundError:
        raise CheckpointError(f"{path} does not exist") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"{path} is not a readable checkpoint ({err})") from None
    except RecursionError:
        raise CheckpointError(f"{path} is not a readable checkpoint") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT \
            or isinstance(meta.get("format"), bool):
        raise CheckpointError(f"{path} is not a checkpoint this version of rodfem reads")
    if meta.get("digest") != digest(arrays, meta):
        raise CheckpointError(f"{path} does not match its digest (was it edited, cut or "
                              "damaged?); the run cannot continue from it")
    why = _wrong_meta(meta) or _wrong_arrays(arrays, meta)
    if why is not None:
        raise CheckpointError(f"{path} is not a checkpoint rodfem wrote: {why}")
    return arrays, meta


def _integer(value, low: int = 0) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= low


def _sha256(value) -> bool:
    return isinstance(value, str) and len(value) == 64


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


# The metadata's fields, and what each must be (the energy monitor's and the iteration counts'
# fields are those of rodfem.output.summary's EnergyMonitor and Iterations; an adaptive run's
# counts are checked with its controller, by _wrong_adaptive).
META = {
    "step": _integer,
    "scene": lambda v: isinstance(v, dict) and all(isinstance(s, dict) or isinstance(s, str)
                                                   for s in v.values()),
    "source": lambda v: isinstance(v, str),
    "mpi_ranks": lambda v: _integer(v, 1),
    "energy": lambda v: isinstance(v, dict) and set(v) == {"last", "max_increase", "scale",
                                                            "finite"}
    and all(_number(v[k]) for k in ("last", "max_increase", "scale"))
    and isinstance(v["finite"], bool),
    "iterations": lambda v: isinstance(v, dict) and set(v) == {"total", "max", "after_first",
                                                                "rows"}
    and all(_integer(x) for x in v.values()),
    "loop_seconds": lambda v: _number(v) and v >= 0,
    "history_rows": _integer,
    "history_sha256": _sha256,
    "digests": lambda v: isinstance(v, dict) and set(v) == {"mesh", "segments"}
    and _sha256(v["mesh"]) and isinstance(v["segments"], list)
    and all(_sha256(d) for d in v["segments"]),
    "saves": lambda v: isinstance(v, list) and all(
        isinstance(s, list) and len(s) == 4 and _integer(s[0]) and _number(s[1])
        and _integer(s[2]) and _integer(s[3]) for s in v),
    "segments": _integer,
}


def _wrong_meta(meta: dict) -> str | None:
    """What is wrong with a checkpoint's metadata (a field missing or of the wrong type), or
    None."""
    for name, right in META.items():
        if name not in meta:
            return f"its metadata has no {name}"
        if not right(meta[name]):
            return f"its metadata's {name} is {json.dumps(meta[name])[:40]}"
    if any(s[0] > meta["step"] or s[2] >= meta["segments"] for s in meta["saves"]):
        return "its metadata's saves are not those of its step and segments"
    if len(meta["digests"]["segments"]) != meta["segments"]:
        return "its metadata's digests are not those of its segments"
    loops = meta.get("loops")  # which loop made the steps (rodfem.solver.compiled.loops_of)
    if loops is not None and not (isinstance(loops, list) and loops and all(
            isinstance(e, list) and len(e) == 2 and _integer(e[0]) and isinstance(e[1], str)
            for e in loops)):
        return f"its metadata's loops is {json.dumps(loops)[:40]}"
    return None


# The adaptive controller's state (rodfem.solver.adaptive.stepper.AdaptiveStepper.saved): t, the
# next step, the last error, Picard's bound and the fields' sizes; the last states and times. The
# metadata's ``adaptive`` holds the counts of rejected steps and contact events.
ADAPTIVE = {"controller": 8, "past_t": None, "past": None}
COUNTS = ("rejected", "events")


def _jumps(scene) -> bool:
    """Whether the scene data ``scene`` (Scene.data) is one whose measured contact force jumps
    at an impact, after which an adaptive run holds no past state
    (:func:`rodfem.solver.adaptive.control.force_jumps`)."""
    from rodfem.solver.adaptive.control import force_jumps

    if not isinstance(scene, dict):
        return False

    def value(key: str):
        section, name = key.split(".")
        entries = scene.get(section)
        return entries.get(name) if isinstance(entries, dict) else None

    return force_jumps(value)


def _wrong_adaptive(arrays: dict[str, np.ndarray], meta: dict) -> str | None:
    """What is wrong with the adaptive controller's arrays and counts (all or none), or None."""
    present = [name for name in ADAPTIVE if name in arrays]
    counts = meta.get("adaptive")
    if not present:
        return None if counts is None else "its metadata has adaptive counts, and no controller"
    if len(present) != len(ADAPTIVE):
        missing = next(name for name in ADAPTIVE if name not in arrays)
        return f"it has no {missing}"
    if not (isinstance(counts, dict) and set(counts) == set(COUNTS)
            and all(_integer(counts[k]) for k in COUNTS)):
        return f"its metadata's adaptive is {json.dumps(counts)[:40]}"
    controller, times, past = (arrays[name] for name in ADAPTIVE)
    state = arrays["state"].size + 1
    if any(a.dtype != np.float64 for a in (controller, times, past)):
        return "its controller's arrays are not float64"
    if controller.shape != (8,) or times.ndim != 1 or not 0 <= times.size <= 3:
        return f"its controller is of shape {controller.shape}, its times {times.shape}"
    if times.size == 0 and not _jumps(meta.get("scene")):
        return "its controller has no past state (only just after an impact the scene's " \
               "contact force jumps at has it none)"
    if past.shape != (times.size, state):
        return f"its past states are of shape {past.shape}"
    t, h, error, cap, *sizes = (float(v) for v in controller)
    finite = np.isfinite([t, h, error, *sizes]).all() and cap > 0.0  # the bound: inf for none
    if not (finite and np.isfinite(times).all() and np.isfinite(past).all()):
        return "its controller's state is not finite"
    if not (t >= 0.0 and h > 0.0 and error >= 0.0 and min(sizes) >= 0.0):
        return "its controller's time, step, error or sizes are negative"
    if (times.size and times[-1] != t) or (np.diff(times) <= 0.0).any():
        return "its controller's past times do not end at its time"
    return None


def _wrong_arrays(arrays: dict[str, np.ndarray], meta: dict) -> str | None:
    """What is wrong with a checkpoint's arrays (the method's state: see
    :meth:`rodfem.solver.methods.base.Method.saved_state`), or None."""
    shapes = {"state": 3, "u_prev": 1, "guess": 2}  # [Θ; D; U], Uⁿ⁻¹, Newton's [ΔΘ; ΔU]
    for name in ("state", "u_prev", "step", "pressure"):
        if name not in arrays:
            return f"it has no {name}"
    unknown = set(arrays) - {*shapes, "step", "pressure", *ADAPTIVE}
    if unknown:
        return f"it holds {sorted(unknown)[0]}, which is not rodfem's"
    wrong = _wrong_adaptive(arrays, meta)
    if wrong:
        return wrong
    nodes = arrays["u_prev"].shape[0] if arrays["u_prev"].ndim == 1 else 0
    for name, per_node in shapes.items():
        a = arrays.get(name)
        if a is not None and (a.dtype != np.float64 or a.shape != (per_node * nodes,)
                              or nodes < 2):
            return f"its {name} is {a.dtype} of shape {a.shape}"
    step, pressure = arrays["step"], arrays["pressure"]
    if step.dtype != np.int64 or step.shape != (2,) or int(step[1]) < 0:
        return f"its step is {step.dtype} {step.tolist() if step.size < 5 else step.shape}"
    if int(step[0]) != meta["step"]:
        return f"its state is of step {int(step[0])}, its metadata of step {meta['step']}"
    if pressure.dtype != np.float64 or pressure.shape != (1,):
        return f"its pressure is {pressure.dtype} of shape {pressure.shape}"
    return None


class RunFiles:
    """history.h5, fields.xdmf (+ fields/) and checkpoint.npz of a run in ``out`` (every rank
    calls every method; rank 0 writes).

    A checkpoint is written at a field save once ``interval`` seconds of wall time have passed
    since the last (0: at every save), and when the run ends. ``resume``: the metadata of the
    checkpoint a resumed run starts from."""

    def __init__(self, out: Path, disc, interval: float, resume: dict | None = None,
                 pointwise=None):
        self.out, self.comm, self.interval = out, disc.comm, interval
        self.history = HistoryFile(out / HISTORY, self.comm, for_scene(disc.scene),
                                   keep=resume["history_rows"] if resume else None)
        saves = resume["saves"] if resume else None
        self.fields = FieldFile(out / "fields.xdmf", disc, saves,
                                resume["segments"] if resume else 0, pointwise,
                                resume["digests"] if resume else None)
        if self.comm.rank == 0:
            self._remove_leftovers(resume["segments"] if resume else 0)
        self.last = time.perf_counter()
        self.seconds = 0.0  # spent writing checkpoints

    def _remove_leftovers(self, segments: int) -> None:
        """What a killed run of rodfem's left that is not the run's: segments written after its
        checkpoint, and its temporary files."""
        listed = {segment_name(k) for k in range(segments)}
        for entry in (self.out / DIRECTORY).iterdir():
            if entry.is_file() and not entry.is_symlink() and (
                    (SEGMENT.match(entry.name) and entry.name not in listed)
                    or TEMPORARY.match(entry.name)):
                entry.unlink()
        for entry in self.out.iterdir():
            match = TEMPORARY.match(entry.name)
            if match and entry.is_file() and not entry.is_symlink() and match["name"] in (
                    HISTORY, "fields.xdmf", "summary.json", "scene.toml", NAME,
                    "rodfem.json") and int(match["pid"]) != os.getpid():
                entry.unlink()

    def due(self) -> bool:
        """Whether a field save now should be a checkpoint (rank 0's clock decides: only rank 0
        writes)."""
        return time.perf_counter() - self.last >= self.interval

    def checkpoint(self, arrays: dict[str, np.ndarray] | None, meta: dict) -> None:
        """Write the fields and rows so far, then (given the method's state ``arrays``) the
        checkpoint that counts them. Without ``arrays`` (the state is not one to continue from:
        it is not finite) the previous checkpoint stays."""
        started = time.perf_counter()
        self.fields.checkpoint()
        self.history.checkpoint()
        if self.comm.rank == 0:  # after the ranks' collective writes: only rank 0 may raise
            keep_lock(self.out)
        if arrays is not None and self.comm.rank == 0:
            write_checkpoint(self.out, arrays, {**meta, **self.counted()})
        if self.comm.rank == 0:
            sync_directory(self.out)
        self.last = time.perf_counter()
        self.seconds += self.last - started

    def close(self) -> None:
        self.history.close()

    def counted(self) -> dict:
        """What the checkpoint counts of the files (rank 0): the history's rows and the saved
        fields, with the SHA-256 of each (:func:`check_counted` checks them on resuming)."""
        return {"history_rows": self.history.rows,
                "history_sha256": self.history.digest.hexdigest(),
                "saves": self.fields.saves, "segments": self.fields.segments,
                "digests": self.fields.digests()}


def check_counted(out: Path, meta: dict) -> None:
    """CheckpointError (one line, naming the file) unless the files a checkpoint counts are as
    it left them: the first ``history_rows`` rows of history.h5, the mesh and every segment of
    fields, each by its SHA-256. Reads only."""
    import h5py

    history, rows = out / HISTORY, meta["history_rows"]
    try:
        with h5py.File(history, "r") as file:
            kept = file[DATASET][:rows]
    except (OSError, KeyError, TypeError, ValueError) as err:
        reason = " ".join(str(err).split())
        raise CheckpointError(f"cannot read {history} ({reason}); the run cannot continue "
                              "from it") from None
    if len(kept) != rows or rows_digest(kept).hexdigest() != meta["history_sha256"]:
        raise CheckpointError(f"{history} no longer holds the rows of the run's checkpoint (was "
                              "it edited or cut?); the run cannot continue from it")
    digests = meta["digests"]
    for name, expected in ((MESH, digests["mesh"]),
                           *((segment_name(k), d) for k, d in enumerate(digests["segments"]))):
        path = out / DIRECTORY / name
        if not path.is_file():
            raise CheckpointError(f"{path} is missing: the run's fields cannot be continued")
        try:
            same = file_digest(path) == expected
        except OSError as err:
            raise CheckpointError(f"cannot read {path}: {err.strerror}") from None
        if not same:
            raise CheckpointError(f"{path} is not the file the run's checkpoint counts (was it "
                                  "edited or replaced?); the run's fields cannot be continued")
