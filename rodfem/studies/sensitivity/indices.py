"""The sampling and the analysis of a sensitivity study, thin layers on SALib: :func:`plan`
draws the points (Saltelli's for Sobol indices, or Morris' trajectories), :func:`analyse` turns
the measures of their runs into indices. Between the two, the runs are a sweep
(:mod:`rodfem.studies.sensitivity.run`).

Both work on the study's scale of each parameter
(:class:`rodfem.studies.sweep.parameters.Parameter`):
``log10`` of a log-scaled one, so that a range over decades is weighed evenly.

The keys of a sensitivity file besides the study's own (:data:`KEYS`)::

    method = "sobol"      # or "morris" (screening); default sobol
    samples = 256         # Sobol: N, a power of 2, for N (D + 2) runs (default 64); Morris:
                          # trajectories, for N (D + 1) runs (default 16); D parameters
    seed = 0              # of the sampling and of the bootstrap (default 0)
    outputs = ["peak_force", "u_1_final"]   # the measures analysed (default: the declared)
    levels = 4            # Morris: the grid's levels, even (default 4)
    resamples = 100       # bootstrap resamples of the confidence intervals (default 100, >= 2)
    confidence = 0.95     # their level (default 0.95)

Sobol indices (Saltelli's estimators, second order not computed): ``S1`` the first-order index
of each parameter (the share of the measure's variance it explains alone), ``ST`` its total
index (alone and with the others), each with ``_conf``, the half-width of its bootstrap
confidence interval. Morris: ``mu_star`` the mean absolute elementary effect on the study's
scale (a parameter's range counts as 1: ``mu_star`` of a linear measure is its coefficient times
the range), ``mu_star_conf`` its interval's half-width, ``sigma`` the effects' spread
(nonlinearity or interactions).

Only SALib's calls common to its releases 1.4.8 (NumPy 1) and 1.5 and later (NumPy 2) are used.
SALib takes a seed of 0 for none: it is given ``seed + 1``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from typing import Any

import numpy as np

from rodfem.scene import SceneError
from rodfem.studies.sweep.parameters import Parameter

KEYS = ("method", "samples", "seed", "outputs", "levels", "resamples", "confidence")
METHODS = ("sobol", "morris")
COLUMNS = {"sobol": ("S1", "S1_conf", "ST", "ST_conf"),
           "morris": ("mu_star", "mu_star_conf", "sigma")}
MAX_RUNS = 1_000_000  # as a sweep's samples


@dataclasses.dataclass(frozen=True)
class Plan:
    """The points of a study: ``scaled`` (runs × parameters, on the study's scales, as SALib
    drew them) and ``values`` (the parameters' values there), with the settings that analyse
    them."""

    parameters: tuple[Parameter, ...]
    method: str
    samples: int
    seed: int
    levels: int
    resamples: int
    confidence: float
    scaled: np.ndarray
    values: np.ndarray

    @property
    def problem(self) -> dict[str, Any]:
        """SALib's description of the parameters."""
        return {"num_vars": len(self.parameters), "names": [p.key for p in self.parameters],
                "bounds": [list(p.bounds) for p in self.parameters]}

    @property
    def columns(self) -> tuple[str, ...]:
        """The columns of the indices of this method."""
        return COLUMNS[self.method]


@contextlib.contextmanager
def _caller_random():
    """SALib's Morris functions seed NumPy's global generator (``np.random.seed``): the
    caller's is restored after them, as it was."""
    state = np.random.get_state()
    try:
        yield
    finally:
        np.random.set_state(state)


def _integer(extra: dict, key: str, default: int, low: int, name: str) -> int:
    value = extra.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= MAX_RUNS:
        raise SceneError(f"{name}: {key} must be an integer from {low} to {MAX_RUNS}, got "
                         f"{value!r}")
    return value


def count(method: str, samples: int, parameters: int) -> int:
    """How many runs a study makes: Saltelli's N (D + 2) without second-order terms, or
    Morris' N (D + 1)."""
    return samples * (parameters + (2 if method == "sobol" else 1))


def settings(extra: dict, name: str, parameters: int) -> dict[str, Any]:
    """The sampling keys of a study file (``extra``: its own keys, ``name`` for messages),
    checked; ``parameters``: how many it varies.

    Raises:
        SceneError: one line naming the key and what is allowed.
    """
    method = extra.get("method", "sobol")
    if method not in METHODS:
        raise SceneError(f"{name}: method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "sobol" and "levels" in extra:  # a forgotten method = "morris"
        raise SceneError(f"{name}: levels is an option of Morris' screening; give "
                         'method = "morris" with it, or leave it out for Sobol indices')
    samples = _integer(extra, "samples", 64 if method == "sobol" else 16, 2, name)
    if method == "sobol" and samples & (samples - 1):
        raise SceneError(f"{name}: samples must be a power of 2 for Sobol indices (Saltelli's "
                         f"sampling), e.g. {1 << samples.bit_length()}, got {samples}")
    runs = count(method, samples, parameters)
    if runs > MAX_RUNS:
        raise SceneError(f"{name}: samples = {samples} makes {runs} runs; at most {MAX_RUNS}")
    seed = _integer(extra, "seed", 0, 0, name)
    levels = _integer(extra, "levels", 4, 2, name)
    if levels % 2:
        raise SceneError(f"{name}: levels must be even (Morris' grid), got {levels}")
    if method == "morris" and parameters < 2:  # SALib's trajectories need two
        raise SceneError(f"{name}: Morris' screening ranks 2 parameters or more; give another "
                         "range in [parameters], or Sobol indices of this one")
    resamples = _integer(extra, "resamples", 100, 2, name)  # one has no spread
    confidence = extra.get("confidence", 0.95)
    if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) \
            or not 0 < confidence < 1:
        raise SceneError(f"{name}: confidence must be a number between 0 and 1, got "
                         f"{confidence!r}")
    return {"method": method, "samples": samples, "seed": seed, "levels": levels,
            "resamples": resamples, "confidence": float(confidence)}


def plan(parameters: tuple[Parameter, ...], method: str = "sobol", samples: int = 64,
         seed: int = 0, levels: int = 4, resamples: int = 100,
         confidence: float = 0.95) -> Plan:
    """The points of a study of ``parameters`` (the arguments as :func:`settings` gives them):
    Saltelli's sampling on a scrambled Sobol' sequence without second-order terms
    (``samples`` (D + 2) points), or ``samples`` Morris trajectories on a grid of ``levels``
    (``samples`` (D + 1) points)."""
    empty = Plan(tuple(parameters), method, samples, seed, levels, resamples, confidence,
                 np.empty((0, 0)), np.empty((0, 0)))
    if method == "sobol":
        from SALib.sample import sobol

        scaled = sobol.sample(empty.problem, samples, calc_second_order=False, seed=seed + 1)
    else:
        from SALib.sample import morris

        with _caller_random():
            scaled = morris.sample(empty.problem, samples, num_levels=levels, seed=seed + 1)
    scaled = np.ascontiguousarray(scaled, dtype=float)
    values = np.array([[p.value(x) for p, x in zip(parameters, row, strict=True)]
                       for row in scaled]).reshape(scaled.shape)
    return dataclasses.replace(empty, scaled=scaled, values=values)


def usable(output: np.ndarray) -> str | None:
    """Why a measure's values over the runs cannot be analysed, or None."""
    finite = np.isfinite(output)
    if not finite.all():
        return f"not a number in {int((~finite).sum())} of its {len(output)} runs"
    if np.all(output == output[0]):
        return f"it is constant ({output[0]!r}): every index is 0"
    return None


def left_out(name: str, output: np.ndarray) -> str | None:
    """The warning line of a measure that gets no indices (:func:`usable`), or None."""
    why = usable(np.asarray(output, dtype=float))
    return None if why is None else f"{name} has no indices: {why}"


def failed_line(failed: int, runs: int) -> str:
    """The warning line of a study whose runs failed: no measure gets indices."""
    return (f"no indices: {failed} of the {runs} runs failed (their rows in runs/results.csv "
            "say why)")


def analyse(plan: Plan, outputs: dict[str, np.ndarray]) -> tuple[list[dict], list[str]]:
    """The indices of each measure of ``outputs`` (name: its value at each of the plan's
    points, in order): rows {measure, parameter, and :attr:`Plan.columns`}, in the order of
    ``outputs`` and of the parameters; and a warning line for each measure left out (a run
    without it, or a constant)."""
    from SALib.analyze import morris, sobol

    rows, warnings = [], []
    problem = plan.problem
    for name, output in outputs.items():
        output = np.asarray(output, dtype=float)
        if len(output) != len(plan.scaled):
            raise ValueError(f"{name}: {len(output)} values for {len(plan.scaled)} points")
        line = left_out(name, output)
        if line is not None:
            warnings.append(line)
            continue
        if plan.method == "sobol":
            found = sobol.analyze(problem, output, calc_second_order=False,
                                  num_resamples=plan.resamples, conf_level=plan.confidence,
                                  seed=plan.seed + 1)
        else:
            with _caller_random():
                found = morris.analyze(problem, plan.scaled, output,
                                       num_resamples=plan.resamples, conf_level=plan.confidence,
                                       num_levels=plan.levels, seed=plan.seed + 1)
        for j, parameter in enumerate(plan.parameters):
            rows.append({"measure": name, "parameter": parameter.key,
                         **{c: float(np.asarray(found[c])[j]) for c in plan.columns}})
    return rows, warnings


def text(columns: tuple[str, ...], rows: list[dict]) -> str:
    """sensitivity.csv: a header and a line per row, numbers to round-trip precision."""
    def cell(value) -> str:
        if isinstance(value, float):
            return repr(value) if math.isfinite(value) else "nan"
        return str(value)

    names = ("measure", "parameter", *columns)
    return "".join(",".join(cell(row[c]) for c in names) + "\n"
                   for row in [dict(zip(names, names, strict=True)), *rows])
