"""``rodfem steady``: every steady state of a scene with its stability, and (``--continue``)
their branches over a scene value.

The states come from :mod:`rodfem.model.steady` (every root, by a search that cannot miss one),
their stability from the spectrum of the dynamic problem linearised about each, discretised like
the scene (:mod:`rodfem.solver.spectrum`). Every rank computes the same table; rank 0 writes it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rodfem.model import steady
from rodfem.scene import SCHEMA, load
from rodfem.solver.spectrum import Spectra
from rodfem.studies.common import deal, prepare, write_csv

STATES = "steady.csv"
BRANCHES = "branches.csv"
COLUMNS = ("u_1", "sigma_1", "theta_1", "contact", "stable", "growth_rate", "h", "tangential")
BRANCH_COLUMNS = ("parameter", "u_1", "sigma_1", "theta_1", "contact", "stable", "growth_rate",
                  "branch", "h", "tangential")
MAX_POINTS = 10_000  # values of a continuation
# The spectrum is a dense eigenproblem in 3 × cells unknowns: at 1000 cells about 100 s a state
# and 0.55 GB (measured on 2 shared cores; it grows as cells³ and cells²).
MAX_CELLS = 1000


class SteadyError(ValueError):
    """A ``--continue`` that cannot be read (exit code 2, nothing written)."""


def parse_continuation(text: str) -> tuple[str, np.ndarray]:
    """``KEY=a:b:n`` → the key and its n values from a to b (a real scene key, n ≥ 2)."""
    key, sep, span = text.partition("=")
    key = key.strip()
    section, _, name = key.partition(".")
    found = SCHEMA.get(section, {}).get(name)
    if found is None:
        raise SteadyError(f"--continue: unknown scene key {key!r}; give section.key, e.g. "
                          "heat_exchange.k1")
    if found.kind != "real":
        raise SteadyError(f"--continue: {key} is not a real value ({found.kind}); continue over "
                          "a real one")
    parts = span.split(":")
    try:
        if not sep or len(parts) != 3:
            raise ValueError
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise SteadyError(f"--continue: {text!r} is not KEY=a:b:n (reals a, b, a whole number "
                          "n of values)") from None
    if not (math.isfinite(a) and math.isfinite(b)) or a == b or not 2 <= n <= MAX_POINTS:
        raise SteadyError(f"--continue {text!r}: a and b must be finite and differ, and 2 <= n <= "
                          f"{MAX_POINTS}")
    return key, np.linspace(a, b, n)


def scenes_over(scene_name: str, overrides: list[str], key: str, values: np.ndarray) -> list:
    """The scene at each value of ``key`` (every one checked: SceneError)."""
    return [load(scene_name, [*overrides, f"{key}={float(value)!r}"]) for value in values]


def check_mesh(scene) -> None:
    """SteadyError for a mesh finer than the dense eigenproblem takes."""
    if scene["mesh.cells"] > MAX_CELLS:
        raise SteadyError(f"mesh.cells = {scene['mesh.cells']}: the stability of steady states "
                          f"is computed on at most {MAX_CELLS} cells (a dense eigenproblem); "
                          f"--set mesh.cells={MAX_CELLS} or fewer")


def analyse(scene, spectra: Spectra) -> list[dict]:
    """One row per steady state of ``scene``, in increasing u(1), with its stability."""
    problem = steady.of_scene(scene)
    rows = []
    for state in problem.states():
        rate = spectra.growth_rate(scene, problem.linearise(state))
        rows.append({"u_1": state.u_1, "sigma_1": state.sigma_1, "theta_1": state.theta_1,
                     "contact": state.contact, "stable": rate < 0.0, "growth_rate": rate,
                     "h": state.h, "tangential": state.tangential})
    return rows


def continuation(scenes: list, values: np.ndarray, spectra: Spectra) -> list[dict]:
    """The states and their stability of each scene, the scene at each value of a continuation,
    each row with its ``parameter`` and ``branch`` (:func:`branches`). Under MPI the scenes are
    dealt to the ranks (their operators assembled first, together) and the table gathered on
    every rank: the serial table."""
    comm = spectra.comm
    for scene in scenes:
        spectra.operators(scene)  # collective: once per mesh, mass and step
    mine = deal([1.0] * len(scenes), comm.size)[comm.rank]
    solved = {i: analyse(scenes[i], spectra) for i in mine}
    for part in comm.allgather(solved):
        solved.update(part)
    table = [solved[i] for i in range(len(scenes))]
    rows = []
    for value, states, labels in zip(values, table, branches(table), strict=True):
        rows.extend({"parameter": float(value), **row, "branch": label}
                    for row, label in zip(states, labels, strict=True))
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
          branch_rows: list[dict] | None = None) -> None:
    """steady.csv (and branches.csv) into ``out``, prepared first (OutputError: nothing
    written); rank 0 writes."""
    files = (STATES,) if branch_rows is None else (STATES, BRANCHES)
    prepare(out, force, comm, files, "steady")
    if comm.rank == 0:
        write_csv(out / STATES, COLUMNS, rows)
        if branch_rows is not None:
            write_csv(out / BRANCHES, BRANCH_COLUMNS, branch_rows)


def table_lines(rows: list[dict]) -> list[str]:
    """The states as a short table."""
    lines = [f"{'u(1)':>12} {'sigma(1)':>12} {'theta(1)':>10} {'contact':>8} {'stable':>7} "
             f"{'growth rate':>12}"]
    for row in rows:
        lines.append(f"{row['u_1']:12.6g} {row['sigma_1']:12.6g} {row['theta_1']:10.5g} "
                     f"{'yes' if row['contact'] else 'no':>8} "
                     f"{'yes' if row['stable'] else 'NO':>7} {row['growth_rate']:12.5g}"
                     + ("  (fold)" if row["tangential"] else ""))
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
