"""``rodfem steady``: every steady state of a scene with its stability, and (``--continue``)
their branches over a scene value.

The states come from :mod:`rodfem.model.steady` (every root, by a search that cannot miss one),
their stability from the spectrum of the dynamic problem linearised about each, discretised like
the scene (:mod:`rodfem.solver.spectrum`). Each row says in ``trust`` whether both are earned:
``ok``; ``residual``, a state that does not satisfy its equation to round-off (its stability not
given); ``neutral``, a spectrum on the imaginary axis to round-off; ``unresolved``, a spectrum
whose round-off could put it on either side. Only an ``ok`` row has ``stable`` true or false.
Every rank computes the same table; rank 0 writes it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rodfem.model import steady
from rodfem.scene import load
from rodfem.solver.spectrum import Spectra
from rodfem.studies.common import deal, prepare, write_csv
from rodfem.studies.steady.ranges import parse_range

STATES = "steady.csv"
BRANCHES = "branches.csv"
COLUMNS = ("u_1", "sigma_1", "theta_1", "contact", "stable", "growth_rate", "h", "tangential",
           "residual", "growth_error", "trust", "continuum_rate", "continuum_error")
BRANCH_COLUMNS = ("parameter", "u_1", "sigma_1", "theta_1", "contact", "stable", "growth_rate",
                  "branch", "h", "tangential", "residual", "growth_error", "trust", "key",
                  "point")
# The scene sections whose values change neither a steady state nor its spectrum: --continue
# over them would repeat one table (time.dt does change the dispersion-free mass).
INERT = {"time": "the time stepping", "output": "what a run writes",
         "solver": "how a run solves its steps", "initial": "a run's initial state"}
# Above DENSE_CELLS the spectrum is taken on the sparse path (rodfem.solver.rightmost), its
# memory linear in the cells: at 10,000 cells 23 to 61 s and 0.2 GB a state on 2 shared cores
# (benchmarks/bench_spectrum.py), so about two minutes a state here.
MAX_CELLS = 20_000


class SteadyError(ValueError):
    """A ``--continue`` that cannot be read (exit code 2, nothing written)."""


def parse_continuation(texts: list[str] | str, scene=None) -> tuple[str, float, float, int | None]:
    """``KEY=a:b`` or ``KEY=a:b:n`` (given once) → the key, a, b and n (None without it: the
    branches followed by continuation; with it, the states at n values from a to b). KEY is a
    real scene key that can change a steady state or its spectrum, n ≥ 2."""
    if not isinstance(texts, str):
        if len(texts) != 1:
            raise SteadyError(f"--continue is given {len(texts)} times; give it once: the "
                              "branches over one scene value")
        texts = texts[0]
    key, found, a, b, n = parse_range(texts, "--continue", SteadyError)
    check_key(key, scene)
    if found.kind != "real":
        raise SteadyError(f"--continue: {key} is not a real value ({found.kind}); continue over "
                          "a real one")
    return key, a, b, n


def check_key(key: str, scene=None) -> None:
    """SteadyError for a key that changes neither a steady state nor its spectrum (a
    :data:`INERT` section's; time.dt changes the dispersion-free mass of ``scene``)."""
    section = key.partition(".")[0]
    dispersion_free = scene is not None and scene["discretisation.mass"] == "dispersion-free"
    if section in INERT and not (key == "time.dt" and dispersion_free):
        raise SteadyError(f"--continue: {key} cannot change a steady state or its stability "
                          f"(it sets {INERT[section]}"
                          + (", and the mass only with discretisation.mass = dispersion-free"
                             if key == "time.dt" else "")
                          + "); continue over a model, obstacle or heat_exchange value")


def scenes_over(scene_name: str, overrides: list[str], key: str, values: np.ndarray) -> list:
    """The scene at each value of ``key`` (every one checked: SceneError)."""
    return [load(scene_name, [*overrides, f"{key}={float(value)!r}"]) for value in values]


def check_mesh(scene, factor: int = 1) -> None:
    """SteadyError for a mesh finer than the spectra take (``factor`` times the scene's cells:
    an extrapolation's finest mesh)."""
    if factor * scene["mesh.cells"] > MAX_CELLS:
        finest = "" if factor == 1 else f" (with --extrapolate, {factor} times that)"
        raise SteadyError(f"mesh.cells = {scene['mesh.cells']}{finest}: the stability of steady "
                          f"states is computed on at most {MAX_CELLS} cells; "
                          f"--set mesh.cells={MAX_CELLS // factor} or fewer")


def analyse(scene, spectra: Spectra) -> list[dict]:
    """One row per steady state of ``scene``, in increasing u(1), with its stability and
    ``trust`` (the module's doc)."""
    problem = steady.of_scene(scene)
    return [state_row(scene, problem, state, spectra) for state in problem.states()]


def state_row(scene, problem, state, spectra: Spectra) -> dict:
    """A steady state's row: its values, and its stability where it satisfies its equation to
    round-off, with ``trust`` (the module's doc)."""
    row = {"u_1": state.u_1, "sigma_1": state.sigma_1, "theta_1": state.theta_1,
           "contact": state.contact, "stable": None, "growth_rate": math.nan,
           "h": state.h, "tangential": state.tangential, "residual": state.residual,
           "growth_error": math.nan, "trust": "residual", "continuum_rate": math.nan,
           "continuum_error": math.nan}
    if state.resolved:
        found = spectra.verdict(scene, problem.linearise(state))
        earned = found.verdict in ("stable", "unstable")
        row.update(stable=found.verdict == "stable" if earned else None,
                   growth_rate=found.growth_rate, growth_error=found.error,
                   trust="ok" if earned else found.verdict)
    return row


def continuation(scenes: list, values: np.ndarray, spectra: Spectra,
                 key: str = "") -> list[dict]:
    """The states and their stability of each scene, the scene at each value of a continuation,
    each row with its ``parameter``, ``branch`` (:func:`branches`) and ``key``. Under MPI the scenes
    are dealt to the ranks (their operators assembled first, together) and the table gathered on
    every rank: the serial table."""
    comm = spectra.comm
    for scene in scenes:
        spectra.assemble(scene)  # collective: once per mesh, mass and step
    mine = deal([1.0] * len(scenes), comm.size)[comm.rank]
    solved = {i: analyse(scenes[i], spectra) for i in mine}
    for part in comm.allgather(solved):
        solved.update(part)
    table = [solved[i] for i in range(len(scenes))]
    rows, along = [], {}
    for value, states, labels in zip(values, table, branches(table), strict=True):
        for row, label in zip(states, labels, strict=True):
            along[label] = along.get(label, -1) + 1
            rows.append({"parameter": float(value), **row, "branch": label, "key": key,
                         "point": along[label]})
    return rows


def branches(table: list[list[dict]]) -> list[list[int]]:
    """A branch number for each state of each value. The states are the ordered roots of one
    scalar equation in s = u(1) − σ(1), which stay in order as the value moves and are born or
    end in pairs at folds: from one value to the next, the pairs of neighbours closest in s are
    the ones born (or ended), and the others continue their branches in order."""
    labels: list[list[int]] = []
    made = 0
    before: list[tuple[float, int]] = []  # (s, branch) of the value before, in order
    for states in table:
        now = [row["u_1"] - row["sigma_1"] for row in states]
        kept_before = _unpaired([s for s, _ in before], len(before) - len(now))
        kept_now = _unpaired(now, len(now) - len(before))
        here: list[int | None] = [None] * len(states)
        for i, j in zip(kept_now, kept_before):
            here[i] = before[j][1]
        for i in range(len(states)):
            if here[i] is None:
                here[i] = made
                made += 1
        labels.append(here)
        before = list(zip(now, here, strict=True))
    return labels


def _unpaired(values: list[float], excess: int) -> list[int]:
    """The indices of ``values`` (increasing) left when ``excess`` // 2 pairs of neighbours,
    the closest first, are taken out."""
    left = list(range(len(values)))
    while excess >= 2 and len(left) >= 2:
        gaps = [values[b] - values[a] for a, b in zip(left, left[1:])]
        i = int(np.argmin(gaps))
        del left[i:i + 2]
        excess -= 2
    return left


def write(out: Path, force: bool, comm, rows: list[dict],
          branch_rows: list[dict] | None = None, point_rows: list[dict] | None = None,
          curve_rows: list[dict] | None = None, grid: dict | None = None) -> None:
    """steady.csv (and branches.csv; points.csv of a diagram; curves.csv and counts.csv of
    points followed over a second value) into ``out``, prepared first (OutputError: nothing
    written); rank 0 writes."""
    from rodfem.studies.steady import curves
    from rodfem.studies.steady.points import POINT_COLUMNS, POINTS

    files = (STATES, *(() if branch_rows is None else (BRANCHES,)),
             *(() if point_rows is None else (POINTS,)),
             *(() if curve_rows is None else (curves.CURVES, curves.COUNTS)))
    prepare(out, force, comm, files, "steady")
    if comm.rank == 0:
        write_csv(out / STATES, COLUMNS, rows)
        if branch_rows is not None:
            write_csv(out / BRANCHES, BRANCH_COLUMNS, branch_rows)
        if point_rows is not None:
            write_csv(out / POINTS, POINT_COLUMNS, point_rows)
        if curve_rows is not None:
            write_csv(out / curves.CURVES, curves.COLUMNS, curve_rows)
            write_csv(out / curves.COUNTS, ("parameter", "parameter2", "count", "key", "key2"),
                      [{"parameter": float(x), "parameter2": float(y), "count": int(n),
                        "key": grid["key"], "key2": grid["key2"]}
                       for j, y in enumerate(grid["y"]) for i, x in enumerate(grid["x"])
                       for n in [grid["count"][j, i]]])


def continuum(scene, rows: list[dict], spectra: Spectra) -> None:
    """Each row's growth rate extrapolated in h from the scene's mesh and 2 and 4 times its
    cells (:func:`.points.extrapolated`): ``continuum_rate`` (nan where pre-asymptotic) and
    ``continuum_error``. The states are exact on every mesh (P1 at the nodes): only their
    spectra change. The rate followed is the eigenvalue nearest the scene mesh's rightmost."""
    from rodfem.studies.steady import continuation as ct
    from rodfem.studies.steady import points as pt

    problem = steady.of_scene(scene)
    states = problem.states()
    for row, state in zip(rows, states, strict=True):
        if not math.isfinite(row["growth_rate"]):
            continue
        lin = problem.linearise(state)
        top = pt.eigenvalues(spectra, scene, lin)[0]
        rates = [top.real]
        for factor in pt.REFINED:
            finer = pt.eigenvalues(spectra, ct.at(scene, "mesh.cells",
                                                  factor * scene["mesh.cells"]), lin)
            top = finer[int(np.argmin(np.abs(finer - top)))]
            rates.append(top.real)
        found = pt.extrapolated(rates)
        row.update(continuum_rate=found.value, continuum_error=found.error)


VERDICTS = {"neutral": "neutral", "unresolved": "?", "residual": "?"}


def table_lines(rows: list[dict]) -> list[str]:
    """The states as a short table: stable yes or NO only where the row's ``trust`` is ok."""
    extrapolated = any(math.isfinite(row.get("continuum_error", math.nan)) for row in rows)
    lines = [f"{'u(1)':>12} {'sigma(1)':>12} {'theta(1)':>10} {'contact':>8} {'stable':>7} "
             f"{'growth rate':>12}" + (f"  {ROD_RATE:>26}" if extrapolated else "")]
    for row in rows:
        lines.append(f"{row['u_1']:12.6g} {row['sigma_1']:12.6g} {row['theta_1']:10.5g} "
                     f"{'yes' if row['contact'] else 'no':>8} "
                     f"{_verdict(row):>7} {row['growth_rate']:12.5g}"
                     + (f"  {_continuum(row):>26}" if extrapolated else "")
                     + ("  (fold)" if row["tangential"] else ""))
    return lines


ROD_RATE = "the rod's (extrapolated)"


def _continuum(row: dict) -> str:
    """The rod's growth rate ± its error estimate, or why there is none."""
    if math.isfinite(row["continuum_rate"]):
        return f"{row['continuum_rate']:.8g} ± {row['continuum_error']:.1e}"
    return "pre-asymptotic" if math.isfinite(row["continuum_error"]) else "-"


def _verdict(row: dict) -> str:
    if row["trust"] == "ok":
        return "yes" if row["stable"] else "NO"
    return VERDICTS.get(row["trust"], "?")


def warning_lines(rows: list[dict]) -> list[str]:
    """One line for each row whose ``trust`` is not ok (a continuation's: with its value)."""
    lines = []
    for row in rows:
        if row.get("located") == "hopf":  # neutral by what it is
            continue
        where = f"the state at u(1) = {row['u_1']:.6g}, sigma(1) = {row['sigma_1']:.6g}" + (
            f" ({row['key']} = {row['parameter']:g})" if "parameter" in row else "")
        if row["trust"] == "residual":
            lines.append(f"rodfem: warning: {where} does not satisfy the steady equation to "
                         f"round-off (residual {row['residual']:.3g}): the laws change there "
                         "faster than doubles resolve; its stability is not given")
        elif row["trust"] == "neutral":
            lines.append(f"rodfem: warning: {where} is neutral: its rightmost eigenvalues lie "
                         f"on the imaginary axis to round-off (growth rate "
                         f"{row['growth_rate']:.3g}, error {row['growth_error']:.3g}), "
                         "neither stable nor unstable")
        elif row["trust"] != "ok":
            lines.append(f"rodfem: warning: the stability of {where} is not resolved: "
                         "round-off in its spectrum could put an eigenvalue on either side of "
                         f"the imaginary axis (growth rate {row['growth_rate']:.3g})")
    return lines


def branch_lines(rows: list[dict], key: str) -> list[str]:
    """How many states each value has, in runs of equal counts."""
    counts: dict[float, int] = {}
    for row in rows:
        counts[row["parameter"]] = counts.get(row["parameter"], 0) + 1
    lines, start = [], None
    items = list(counts.items())
    for i, (value, count) in enumerate(items):
        if start is None:
            start = value
        if i + 1 == len(items) or items[i + 1][1] != count:
            lines.append(f"{key} from {start:g} to {value:g}: {count} steady "
                         f"state{'s' if count != 1 else ''}")
            start = None
    return lines
