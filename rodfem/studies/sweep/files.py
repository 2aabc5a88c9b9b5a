"""What a sweep directory holds, written and read: ``sweep.json`` (the sweep, resolved: what
resume reads), ``results.csv`` and ``summary.json`` written from the journals, ``histories.h5``,
and the table of a directory read back as a :class:`SweepResult`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.output import journal
from rodfem.output import results as table
from rodfem.output.atomic import replacing
from rodfem.output.columns import NAMES as HISTORY_COLUMNS
from rodfem.output.columns import for_scene, named
from rodfem.scene import SceneError
from rodfem.scene.expressions import shorten
from rodfem.studies.sweep import design
from rodfem.studies.sweep.design import Sweep

HISTORIES = table.HISTORIES
FORMAT = 2  # 2: with the digest of the sweep, which tags its journal's records


@dataclasses.dataclass(frozen=True)
class SweepResult:
    """A sweep's table: ``result["model.k"]``, ``result["u_1_final"]`` are its columns (arrays
    in the sweep's order); ``axes`` are the swept keys; :meth:`history` reads a scene's history
    from ``histories.h5`` (a sweep run with ``--histories``).

    Attributes:
        columns: every column of results.csv by name.
        axes: the swept keys.
        status: complete, or interrupted (a sweep that was stopped; resume continues it), or
            failed (a file could not be written: ``error`` says which).
        path: the sweep directory, or None for a sweep run in memory.
        coarse_steps: the warnings of its scenes that touched the obstacle with a fixed step
            coarse for it (:mod:`rodfem.model.timescales`), one line for each kind.
        accuracy_missed: the warning naming its scenes whose accuracy targets were not met
            (None: every one was, or none has a target).
    """

    columns: dict[str, np.ndarray]
    axes: tuple[str, ...]
    status: str
    path: Path | None = None
    _histories: dict[int, tuple] | None = None  # in memory: the rows and their columns
    error: str | None = None  # a file that could not be written, which stopped the sweep
    coarse_steps: tuple[str, ...] = ()
    accuracy_missed: str | None = None  # the line naming the scenes whose targets were not met
    # the declared measures (name → column, reduce, window), for the axes' words and units
    measure_specs: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)
    figure_format: str | None = None  # the base scene's output.figure_format

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["index"])

    def to_pandas(self):
        """The table as a ``pandas.DataFrame`` indexed by the scenes' ``index``: the swept keys,
        status, the measures and error as columns, in results.csv's order, with its values
        (``frame.attrs["axes"]``: the swept keys). Needs pandas."""
        from rodfem.output.frames import results_frame

        return results_frame(self.columns, self.axes)

    def plot(self, measure: str, x: str | None = None, ax=None, path=None, format=None):
        """The measure against a swept key ``x`` (default: the first) with matplotlib's pyplot,
        a line for each combination of the other swept keys, over the complete scenes; a log
        axis where the key's values span two decades or more; the axes labelled as ``rodfem
        plot`` labels them (units included). ``path``: also write the figure there, as PNG,
        PDF or SVG (``format``, else the path's suffix, else the base scene's
        ``output.figure_format``). Returns the Axes."""
        from rodfem import quicklook

        axes = quicklook.measure(self.columns, self.axes, measure, x, ax, self.measure_specs)
        if path is not None or format is not None:
            quicklook.save(axes, path, format, {"output.figure_format": self.figure_format})
        return axes

    def __repr__(self) -> str:
        from rodfem.output.frames import span

        counts = ", ".join(f"{n} {status}"
                           for status, n in Counter(self.columns["status"].tolist()).items())
        lines = [f"<rodfem.SweepResult {self.status}: {len(self)} scenes"
                 f"{' (' + counts + ')' if counts else ''}>"]
        lines += [f"    {key}: {span(self.columns[key])}" for key in self.axes[:6]]
        if len(self.axes) > 6:
            lines.append(f"    … {len(self.axes) - 6} more swept keys")
        measures = list(table.measure_names(tuple(self.columns)))
        lines.append(f"    {len(measures)} measures: {', '.join(measures[:4])}"
                     f"{', …' if len(measures) > 4 else ''}")
        if self.coarse_steps:
            lines.append(f"    steps coarse for the obstacle in some scenes: "
                         f"{len(self.coarse_steps)} warning(s) in .coarse_steps")
        if self.error:
            lines.append(f"    error: {shorten(self.error, 120)}")
        if self.path is not None:
            lines.append(f"    path: {self.path}")
        return "\n".join(lines)

    def history(self, index: int) -> np.ndarray:
        """The history of scene ``index`` as a structured array (as :attr:`rodfem.Result.history`).

        Raises:
            KeyError: the sweep kept no histories, or none for that scene.
        """
        from rodfem.output.result import named_history

        if self._histories is not None:
            return named_history(*self._histories[index])
        if self.path is None or not (self.path / HISTORIES).is_file():
            raise KeyError(f"no histories kept (run the sweep with --histories): scene {index}")
        kept = table.kept_histories(self.path / HISTORIES, [index])
        if index not in kept:
            raise KeyError(f"{self.path / HISTORIES} has no history of scene {index}")
        rows, names = kept[index]
        return named_history(rows, named(names))


def result_from(lines: dict[int, str], axes, status, path=None, histories=None,
                declared: tuple[str, ...] = (), sweep=None) -> SweepResult:
    """The result of a sweep's results lines by index (from journals, or in memory);
    ``declared``: the names of the measures its scenes declare; ``sweep``: the sweep, whose
    declared measures and figure format its figures use."""
    targeted = sweep.targeted if sweep is not None else ()
    _, columns = table.parse(table.text(axes, [lines[i] for i in sorted(lines)], declared,
                                        targeted))
    return SweepResult(columns, tuple(axes), status, path, histories, **_drawing(sweep))


def _drawing(sweep) -> dict:
    """What a sweep's figures need of it: its declared measures and its base scene's figure
    format."""
    if sweep is None:
        return {}
    output = sweep.base.get("output", {}) if isinstance(sweep.base, dict) else {}
    return {"measure_specs": dict(sweep.measures),
            "figure_format": output.get("figure_format") if isinstance(output, dict) else None}


def write_table(out: Path, sweep: Sweep, histories: bool, ran: int, seconds: float,
                ranks: int, failed_write: bool, tag: bytes) -> str:
    """results.csv (and histories.h5, summary.json) from the journals of the sweep ``tag``
    (rank 0). Returns the sweep's status."""
    records = journal.read(out, tag)
    lines = [records[i].line for i in sorted(records)]
    counts = {s: 0 for s in table.STATUSES}
    for record in records.values():
        counts[table.status(record.line, sweep.axes)] += 1
    complete = (len(records) == len(sweep) and counts["interrupted"] == 0 and not failed_write)
    text = table.text(sweep.axes, lines, sweep.declared, sweep.targeted).encode("utf-8")
    with replacing(out / table.NAME, "wb") as file:
        file.write(text)
    if complete and histories:
        write_histories(out / HISTORIES, records, sweep)
    status = "complete" if complete else "interrupted"
    summary = {"status": status, "scenes": len(sweep), "recorded": len(records),
               **{f"scenes_{s}": n for s, n in counts.items()},
               "ran_this_time": ran, "seconds": seconds,
               "scenes_per_second": ran / seconds if seconds > 0 else None,
               "mpi_ranks": ranks, "results_sha256": hashlib.sha256(text).hexdigest()}
    with replacing(out / "summary.json") as file:
        json.dump(summary, file, indent=2)
        file.write("\n")
    if complete:
        journal.remove(out)  # all of it is in the table
    return status


def check_complete(out: Path) -> None:
    """That a complete sweep's files are as it wrote them: its sweep.json (by its digest) and
    results.csv (by the digest summary.json keeps). SceneError, one line, if not."""
    read_meta(out)
    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        written = (out / table.NAME).read_bytes()
    except (OSError, ValueError) as err:
        raise SceneError(f"{out} is a complete sweep without a readable summary.json and "
                         f"{table.NAME} ({getattr(err, 'strerror', None) or err})") from None
    if not isinstance(summary, dict) \
            or summary.get("results_sha256") != hashlib.sha256(written).hexdigest():
        raise SceneError(f"{out / table.NAME} is not the table the sweep wrote (was it edited, "
                         "or its summary.json?); run the sweep again with --force")


def write_histories(path: Path, records: dict[int, journal.Record], sweep) -> None:
    """histories.h5, whole or not at all. HDF5 closing a file on a full disk can crash the
    process (h5py 3.7: a segmentation fault in H5F__close_cb), so the room is checked first and
    a disk without it is the OSError any full disk is."""
    import errno

    import h5py

    need = sum(8 * r.rows * r.columns + 4096 for r in records.values()) + 2**20
    if shutil.disk_usage(path.parent).free < need:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    part = path.with_name(f".{path.name}.{os.getpid()}")
    try:
        with h5py.File(part, "w") as file:
            file.attrs["columns"] = ",".join(HISTORY_COLUMNS)
            group = file.create_group("scenes")
            for i in sorted(records):
                rows = records[i].history()
                if rows is not None:
                    dataset = group.create_dataset(str(i), data=rows)
                    # the scene's own columns: the default ones, then what its [output] adds
                    dataset.attrs["columns"] = ",".join(c.name for c in for_scene(sweep.scene(i)))
        with open(part, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise


def load_sweep(path: str | Path) -> SweepResult:
    """The table of a sweep directory (complete or stopped: the rows it has).

    Raises:
        rodfem.output.results.ResultsError: ``path`` holds no sweep table (a directory of
            another command is named with its loader), or its results.csv is not rodfem's.
        SceneError: a stopped sweep's sweep.json or journal is not this sweep's (edited).
    """
    from rodfem.output.directories import state
    from rodfem.output.kinds import other_kind

    path = Path(path)
    if (other := other_kind(path, "sweep")) is not None:
        raise table.ResultsError(other)
    if journal.exists(path):  # stopped: its rows are in the journal
        written = read_meta(path)
        sweep = parsed(path, written)
        records = journal.read(path, tag(written))
        return result_from({i: r.line for i, r in records.items()}, sweep.axes,
                           state(path) or "interrupted", path, declared=sweep.declared,
                           sweep=sweep)
    axes, columns = table.read(path / table.NAME)
    try:  # the axes' words and the format: sweep.json's, where it reads as a sweep's
        drawing = _drawing(parsed(path, read_meta(path)))
    except (OSError, ValueError):  # SceneError too: the table is read all the same
        drawing = {}
    return SweepResult(columns, axes, state(path) or "complete", path, **drawing)


def meta(sweep: Sweep, histories: bool) -> dict[str, Any]:
    """What sweep.json holds: the sweep and its base scene, resolved (what resume reads), and
    their digest. SceneError (nothing written) if a value is not one JSON keeps as it is."""
    data = {"format": FORMAT, "name": sweep.name, "sweep": sweep.data, "base": sweep.base,
            "source": sweep.source, "axes": list(sweep.axes), "design": sweep.design,
            "grid": sweep.grid, "histories": histories, "scenes": len(sweep),
            # the declared measures' names (the figures read them); none: as before
            **({"measures": list(sweep.declared)} if sweep.declared else {})}
    try:
        json.dumps(data, allow_nan=False)  # as write_json writes it, or not at all
    except (TypeError, ValueError) as err:
        raise SceneError(f"{sweep.name}: the sweep cannot be written to sweep.json "
                         f"({' '.join(str(err).split())})") from None
    return {**data, "digest": digest(data)}


def digest(data: dict[str, Any]) -> str:
    """The SHA-256 of sweep.json's values but the digest, in their order (the order of the
    axes is the order of the scenes)."""
    content = {k: v for k, v in data.items() if k != "digest"}
    return hashlib.sha256(json.dumps(content, allow_nan=True).encode()).hexdigest()


def tag(data: dict[str, Any]) -> bytes:
    """The tag of this sweep's journal records: the start of its digest."""
    return bytes.fromhex(data["digest"][:16])


KEYS = {"name": str, "sweep": dict, "base": dict, "source": str, "histories": bool,
        "scenes": int, "digest": str}


def reserve_marker(out: Path, comm) -> None:
    """Keep room for the marker's last word on a disk the sweep may fill: its temporary file
    (``.rodfem.json.<pid>``), of a block, which :func:`rodfem.output.directories.finish`
    truncates and replaces (rank 0). Those of killed processes go; without room, none."""
    from rodfem.output.atomic import TEMPORARY, temporary
    from rodfem.output.directories import MARKER

    if comm.rank != 0:
        return
    mine = temporary(out / MARKER)
    for path in out.iterdir():
        match = TEMPORARY.match(path.name)
        if match and match["name"] == MARKER and path != mine and path.is_file() \
                and not path.is_symlink():
            path.unlink()  # a killed process's: this one holds the directory now
    try:
        with open(mine, "wb") as file:
            file.write(bytes(4096))
            file.flush()
            os.fsync(file.fileno())
    except OSError:
        mine.unlink(missing_ok=True)


def read_meta(out: Path) -> dict[str, Any]:
    """The sweep.json of ``out``, checked to be one this version wrote (SceneError, one line)."""
    return checked_json(out, "sweep.json", FORMAT, KEYS, "the sweep this directory was run with "
                        "(it was edited); a sweep resumes as it was written: run the edited "
                        "sweep into another directory")


def checked_json(out: Path, name: str, format: int, keys: dict[str, type],
                 edited: str) -> dict[str, Any]:
    """The JSON file ``name`` of the directory ``out``, checked to be one this version wrote
    (its ``format``, each of ``keys`` of its type) and unedited (its digest); ``edited`` says
    what it is not when it was edited (SceneError, one line)."""
    try:
        meta = json.loads((out / name).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise SceneError(f"{out}: no readable {name} ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != format:
        raise SceneError(f"{out}/{name} is not one this version of rodfem reads")
    for key, kind in keys.items():
        if not isinstance(meta.get(key), kind):
            raise SceneError(f"{out}/{name}: '{key}' is missing or not a {kind.__name__} "
                             "(was it edited?)")
    if meta["digest"] != digest(meta):
        raise SceneError(f"{out}/{name} is not {edited}")
    return meta


def parsed(out: Path, meta: dict) -> Sweep:
    """The sweep of a directory's sweep.json (SceneError, one line, if it is not one)."""
    try:
        return design.parse(meta["sweep"], meta["name"], base=(meta["base"], meta["source"]))
    except (KeyError, TypeError, AttributeError, IndexError) as err:
        raise SceneError(f"{out}/sweep.json is not a sweep's ({type(err).__name__}: {err})") \
            from None
