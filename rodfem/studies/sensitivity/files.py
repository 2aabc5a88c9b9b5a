"""What a sensitivity directory holds, written and read (:mod:`rodfem.studies.sensitivity.run`):
``sensitivity.json`` (what resume reads), ``samples.csv``, ``sensitivity.csv``, and the
indices read back as a :class:`SensitivityResult`.
"""

from __future__ import annotations

import dataclasses
import html
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.scene import SceneError
from rodfem.studies.common import plural
from rodfem.studies.sensitivity import indices
from rodfem.studies.sweep.files import checked_json, digest

CSV, FIGURE = "sensitivity.csv", "sensitivity.png"
FILES = ("sensitivity.toml", "sensitivity.json", "samples.csv", "runs", CSV, FIGURE,
         "sensitivity.pdf", "sensitivity.svg")  # the figure in each format
FORMAT = 1
KEYS = {"name": str, "study": dict, "scene": str, "base": dict, "source": str, "method": str,
        "samples": int, "seed": int, "outputs": list, "runs": str, "digest": str}


@dataclasses.dataclass(frozen=True)
class SensitivityResult:
    """The indices of a sensitivity study: :attr:`table` has a row per measure and parameter
    (``S1, S1_conf, ST, ST_conf`` for Sobol, ``mu_star, mu_star_conf, sigma`` for Morris);
    :meth:`indices` gives one measure's.

    Attributes:
        method: sobol or morris.
        columns: the indices' columns of that method.
        table: the rows, as dicts, measure by measure in the order of ``outputs``.
        parameters: the parameters' keys.
        outputs: the measures analysed (those without rows: see ``warnings``).
        status: complete, interrupted (resume continues it) or failed (a file could not be
            written: ``error``).
        path: the directory, or None in memory.
        warnings: a line for each measure left without indices (a failed run, a value that is
            not a number, a constant).
        failed: how many runs failed.
        numbers: the runs' count and time, and the analysis' time.
    """

    method: str
    columns: tuple[str, ...]
    table: tuple[dict, ...]
    parameters: tuple[str, ...]
    outputs: tuple[str, ...]
    status: str
    path: Path | None = None
    warnings: tuple[str, ...] = ()
    failed: int = 0
    error: str | None = None
    numbers: dict = dataclasses.field(default_factory=dict)

    def indices(self, measure: str) -> dict[str, dict[str, float]]:
        """One measure's indices by parameter, e.g. ``result.indices("u_1_final")["model.zeta"]
        ["ST"]``. KeyError for a measure without them."""
        found = {row["parameter"]: {c: row[c] for c in self.columns}
                 for row in self.table if row["measure"] == measure}
        if not found:
            having = ", ".join(dict.fromkeys(r["measure"] for r in self.table)) or "none"
            raise KeyError(f"no indices of {measure!r}; measures with indices: {having}")
        return found

    def to_pandas(self):
        """The table as a ``pandas.DataFrame`` indexed by (measure, parameter). Needs pandas."""
        from rodfem.output.frames import require

        pd = require("pandas", "to_pandas()")
        frame = pd.DataFrame(list(self.table), columns=["measure", "parameter", *self.columns])
        return frame.set_index(["measure", "parameter"])

    def __len__(self) -> int:
        return len(self.table)

    def __repr__(self) -> str:
        kind = "Sobol indices" if self.method == "sobol" else "Morris screening"
        lines = [f"<rodfem.SensitivityResult {self.status}: {kind}, "
                 f"{plural(len(self.outputs), 'measure')} × "
                 f"{plural(len(self.parameters), 'parameter')}>"]
        for row in self.table[:12]:
            lines.append(f"    {row['measure']} / {row['parameter']}: " + ", ".join(
                f"{c} {row[c]:.3g}" for c in self.columns))
        if len(self.table) > 12:
            lines.append(f"    … {len(self.table) - 12} more rows")
        lines += [f"    warning: {w}" for w in self.warnings]
        if self.error:
            lines.append(f"    error: {self.error}")
        if self.path is not None:
            lines.append(f"    path: {self.path}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        head = "".join(f"<th>{html.escape(c)}</th>" for c in ("measure", "parameter",
                                                               *self.columns))
        body = "".join("<tr>" + "".join(
            f"<td>{html.escape(str(row[c]))}</td>" for c in ("measure", "parameter"))
            + "".join(f"<td>{row[c]:.4g}</td>" for c in self.columns) + "</tr>"
            for row in self.table)
        notes = "".join(f"<p>warning: {html.escape(w)}</p>" for w in self.warnings)
        return (f"<p><b>{html.escape(repr(self).splitlines()[0])}</b></p>"
                f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{notes}")


def meta(found, sweep: dict[str, Any]) -> dict[str, Any]:
    """What sensitivity.json holds of a campaign (:class:`rodfem.studies.sensitivity.run.Campaign`;
    ``sweep``: its runs' sweep.json), with its digest."""
    plan = found.plan
    data = {"format": FORMAT, "name": found.study.name, "study": found.study.data,
            "scene": found.study.scene, "base": sweep["base"], "source": sweep["source"],
            "method": plan.method, "samples": plan.samples, "seed": plan.seed,
            "levels": plan.levels, "resamples": plan.resamples, "confidence": plan.confidence,
            "parameters": [dataclasses.asdict(p) for p in plan.parameters],
            "outputs": list(found.outputs), "runs": sweep["digest"],
            "figure": found.figure_format}  # --format's (None: the scene's), which resume takes
    return {**data, "digest": digest(data)}


def read_meta(out: Path) -> dict[str, Any]:
    """The sensitivity.json of ``out``, checked to be one this version wrote (SceneError)."""
    return checked_json(out, "sensitivity.json", FORMAT, KEYS, "the study this directory was "
                        "run with (it was edited); run the edited study into another directory")


def samples_text(plan: indices.Plan) -> str:
    """samples.csv: the run's index and the parameters' values, a row per run."""
    keys = [p.key for p in plan.parameters]
    lines = [",".join(["index", *keys])]
    lines += [",".join([str(i), *(repr(float(v)) for v in row)])
              for i, row in enumerate(plan.values)]
    return "\n".join(lines) + "\n"


def coarse_warning(sweep, runs) -> list[str]:
    """The line that says how many of the runs had a fixed step coarse for their contact, with
    the fix (none: no run had)."""
    from rodfem.studies.sweep.run import coarse_study_line

    line = coarse_study_line(sweep, runs, "flagged in the coarse column of runs/results.csv")
    return [line] if line else []


def _coarse(runs: Path, columns: dict) -> list[str]:
    """The line of the runs whose fixed step was coarse for their contact, said again (the
    runs' sweep read from their sweep.json)."""
    from rodfem.studies.sweep.files import SweepResult, parsed, read_meta

    if "coarse" not in columns or not (columns["coarse"] == 1).any():
        return []
    return coarse_warning(parsed(runs, read_meta(runs)), SweepResult(columns, (), "complete"))


def load_sensitivity(path: str | Path) -> SensitivityResult:
    """The indices of a sensitivity directory (written by ``rodfem sensitivity``).

    Raises:
        SceneError: ``path`` is not a sensitivity directory (a directory of another command is
            named with its loader), or its files were edited (one line).
    """
    from rodfem.output.directories import state
    from rodfem.output.kinds import other_kind

    path = Path(path)
    if (other := other_kind(path, "sensitivity")) is not None:
        raise SceneError(other)
    data = read_meta(path)
    columns = indices.COLUMNS.get(data["method"])
    if columns is None:
        raise SceneError(f"{path}/sensitivity.json: unknown method {data['method']!r}")
    status = state(path) or "complete"
    rows = []
    if (path / CSV).is_file():
        lines = (path / CSV).read_text(encoding="utf-8").splitlines()
        names = ("measure", "parameter", *columns)
        if not lines or tuple(lines[0].split(",")) != names:
            raise SceneError(f"{path / CSV} is not a table rodfem wrote (its header is not "
                             f"{','.join(names)})")
        for number, line in enumerate(lines[1:], 2):
            cells = line.split(",")
            try:
                rows.append({"measure": cells[0], "parameter": cells[1],
                             **{c: float(v) for c, v in zip(columns, cells[2:], strict=True)}})
            except (ValueError, IndexError):
                raise SceneError(f"{path / CSV}, line {number}: not a row rodfem wrote (was it "
                                 f"edited?): {line[:80]!r}") from None
    keys = tuple(p["key"] for p in data.get("parameters", ()))
    failed, warnings = 0, []
    if (path / "runs" / "results.csv").is_file():
        from rodfem.output import results as table

        _, found = table.read(path / "runs" / "results.csv")
        failed = int(np.sum(found["status"] != "complete"))
        if status == "complete":  # the warnings of its analysis, said again
            analysed = {row["measure"] for row in rows}
            warnings = [indices.failed_line(failed, len(found["status"]))] if failed else [
                line for m in data["outputs"] if m not in analysed and m in found
                and (line := indices.left_out(m, found[m])) is not None]
            if not failed:
                warnings += _coarse(path / "runs", found)
    return SensitivityResult(data["method"], columns, tuple(rows), keys,
                             tuple(data["outputs"]), status, path, tuple(warnings), failed,
                             numbers={"runs": indices.count(data["method"], data["samples"],
                                                            len(keys))})
