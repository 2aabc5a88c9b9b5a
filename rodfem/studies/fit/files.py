"""What a fit directory holds, written and read: ``study.json`` (the fit file resolved, with its
base scene and its data's digest: what resume reads), ``fit.json`` (the fitted values, their
standard errors and correlations), and the fit read back as a :class:`FitResult`.

The directory of ``rodfem fit FIT.toml --out DIR``: ``fit.toml`` (the file as given),
``study.json``, ``base.toml`` (the base scene, resolved), ``data.csv`` (a copy of the data),
``journal/`` (the residuals of every point run), ``fit.json``, ``fitted/`` (the run at the
optimum, a run directory) and ``fit.png`` (the data against the fitted run).
"""

from __future__ import annotations

import dataclasses
import hashlib
import html
import json
from pathlib import Path
from typing import Any

import numpy as np

from rodfem.scene import SceneError
from rodfem.studies.common import plural
from rodfem.studies.sweep.files import digest, tag  # noqa: F401 (a fit's study.json as a sweep's)

FORMAT = 1
FILES = ("fit.toml", "study.json", "base.toml", "data.csv", "journal", "fit.json", "fitted",
         "fit.png", "fit.pdf", "fit.svg")  # the figure in each format


class FitError(RuntimeError):
    """A run of a fit failed (its method did not converge, its values overflowed): the fit
    cannot go on. The message names the point."""


@dataclasses.dataclass(frozen=True)
class FitResult:
    """A fit: ``result.values["model.zeta"]``, ``result.stderr[...]``, ``result.parameters``
    (key: (value, stderr)), ``result.correlation`` (or None), ``result.residual_norm``.

    Attributes:
        numbers: what fit.json holds.
        t: the data's times (those with a value in a fitted column).
        data: the measured values by column (NaN where a column was not measured).
        model: the fitted model at the data's times, by column (NaN where the data have none).
        fitted: the run at the optimum (a :class:`rodfem.Result`), where there is one.
        path: the fit directory, or None for a fit in memory.
    """

    numbers: dict
    t: np.ndarray
    data: dict[str, np.ndarray]
    model: dict[str, np.ndarray]
    fitted: Any = dataclasses.field(default=None, repr=False)
    path: Path | None = None

    @property
    def parameters(self) -> dict[str, tuple[float, float | None]]:
        """Each parameter's fitted value and standard error (None where there is none)."""
        return {key: (p["value"], p["stderr"]) for key, p in self.numbers["parameters"].items()}

    @property
    def values(self) -> dict[str, float]:
        """Each parameter's fitted value."""
        return {key: p["value"] for key, p in self.numbers["parameters"].items()}

    @property
    def stderr(self) -> dict[str, float | None]:
        """Each parameter's standard error (None where the data cannot give one)."""
        return {key: p["stderr"] for key, p in self.numbers["parameters"].items()}

    @property
    def correlation(self) -> np.ndarray | None:
        """The parameters' correlation matrix, in their order (None without standard errors)."""
        found = self.numbers.get("correlation")
        return None if found is None else np.array(found, dtype=float)

    @property
    def residual_norm(self) -> float:
        """The norm ``|r|`` at the optimum of the weighted residuals ``w (model - data)``."""
        return self.numbers["residual_norm"]

    @property
    def iterations(self) -> int:
        """The optimiser's iterations (its Jacobians)."""
        return self.numbers["iterations"]

    @property
    def status(self) -> str:
        """converged, or stopped (max_evaluations reached first)."""
        return self.numbers["status"]

    def _rows(self) -> list[tuple[str, str, str]]:
        return [(key, f"{value:.6g}", "" if err is None else f"{err:.2g}")
                for key, (value, err) in self.parameters.items()]

    def __repr__(self) -> str:
        n = self.numbers
        fitted = sum(n.get("counts", {}).values()) or n["points"] * len(n["columns"])
        some = "" if fitted == n["points"] * len(n["columns"]) else f" ({fitted} values)"
        lines = [f"<rodfem.FitResult {n['status']}: {plural(len(n['parameters']), 'parameter')}"
                 f", {plural(n['points'], 'time')} × {plural(len(n['columns']), 'column')}{some}"
                 f", |r| = {n['residual_norm']:.4g}, {plural(n['runs'], 'run')}>"]
        lines += [f"    {key} = {value}" + (f" ± {err}" if err else " (no standard error)")
                  for key, value, err in self._rows()]
        if self.path is not None:
            lines.append(f"    path: {self.path}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{v}</td><td>{e or '—'}</td></tr>"
                       for k, v, e in self._rows())
        n = self.numbers
        return (f"<p>rodfem fit, {html.escape(n['status'])}: |r| = {n['residual_norm']:.4g}, "
                f"{plural(n['runs'], 'run')}</p><table><thead><tr><th>parameter</th><th>value</th>"
                f"<th>standard error</th></tr></thead><tbody>{rows}</tbody></table>")


def meta(study, base: tuple[dict, str], data_bytes: bytes,
         figure: str | None = None) -> dict[str, Any]:
    """What study.json holds: the fit file with its scene and data the directory's copies
    (base.toml, data.csv), the base scene's raw data, the data's digest, the figure's format
    asked for (``--format``; None: the scene's, which resume then takes too), and the digest of
    it all. SceneError (nothing written) if a value is not one JSON keeps as it is."""
    kept = {**study.data, "scene": "base.toml", "data": "data.csv"}
    data = {"format": FORMAT, "name": study.name, "study": kept, "scene": study.data["scene"],
            "base": base[0], "source": base[1], "parameters": list(study.keys),
            "data_sha256": hashlib.sha256(data_bytes).hexdigest(), "figure": figure}
    try:
        json.dumps(data, allow_nan=False)
    except (TypeError, ValueError) as err:
        raise SceneError(f"{study.name}: the fit cannot be written to study.json "
                         f"({' '.join(str(err).split())})") from None
    return {**data, "digest": digest(data)}


def read_meta(out: Path) -> dict[str, Any]:
    """The study.json of ``out``, checked to be one this version wrote and unedited, with the
    data.csv it names (SceneError, one line)."""
    try:
        found = json.loads((out / "study.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        why = ("the fit stopped before it began; run it again with --force"
               if isinstance(err, FileNotFoundError)
               else "run the fit again into another directory")
        raise SceneError(f"{out}: no readable study.json ({getattr(err, 'strerror', None) or err}"
                         f"): {why}") from None
    if not isinstance(found, dict) or found.get("format") != FORMAT \
            or not isinstance(found.get("digest"), str) or found["digest"] != digest(found):
        raise SceneError(f"{out}/study.json is not the fit this directory was run with (was it "
                         "edited?); run the fit again into another directory")
    try:
        data = (out / "data.csv").read_bytes()
    except OSError as err:
        raise SceneError(f"{out}: no readable data.csv ({err.strerror or err})") from None
    if hashlib.sha256(data).hexdigest() != found.get("data_sha256"):
        raise SceneError(f"{out}/data.csv is not the data this fit was run with (was it "
                         "edited?); run the fit again into another directory")
    return found


def numbers_of(path: Path) -> dict:
    """fit.json of a fit directory (SceneError, one line, if there is none to read)."""
    try:
        numbers = json.loads((path / "fit.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise SceneError(f"{path} is not a complete fit (no readable fit.json: "
                         f"{getattr(err, 'strerror', None) or err})") from None
    if not isinstance(numbers, dict) or not isinstance(numbers.get("parameters"), dict):
        raise SceneError(f"{path}/fit.json is not one rodfem wrote")
    return numbers


def load_fit(path: str | Path) -> FitResult:
    """The :class:`FitResult` of a complete fit directory (``rodfem fit --out``).

    Raises:
        rodfem.SceneError: ``path`` is not a complete fit's directory (a directory of another
            command is named with its loader), or its study.json or data.csv was edited since
            (one line).
    """
    from rodfem.output.kinds import other_kind
    from rodfem.output.result import load
    from rodfem.studies.fit.data import measured, read_csv

    path = Path(path)
    if (other := other_kind(path, "fit")) is not None:
        raise SceneError(other)
    numbers = numbers_of(path)
    read_meta(path)  # the data are those fitted
    header, values = read_csv(path / "data.csv", str(path))
    columns = numbers["columns"]
    t, chosen = measured(header, values, tuple(columns))
    data = {c: chosen[:, j] for j, c in enumerate(columns)}
    model = {c: np.array(numbers["model"][c], dtype=float) for c in columns}
    fitted = load(path / "fitted") if (path / "fitted").is_dir() else None
    return FitResult(numbers, t, data, model, fitted, path)
