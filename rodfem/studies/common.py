"""What the studies share: the machine they ran on, dealing tasks to ranks, their CSV tables and
their result directories."""

from __future__ import annotations

import csv
import math
import os
import platform
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import rodfem
from rodfem.output.atomic import replacing

if TYPE_CHECKING:
    from mpi4py import MPI


def plural(count: int, noun: str) -> str:
    """``1 interval``, ``3 intervals``."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def machine(comm: MPI.Comm) -> dict:
    """Where a study ran: node, CPU, ranks and the versions of the software."""
    import dolfinx
    from petsc4py import PETSc

    model = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            model = next((line.split(":", 1)[1].strip() for line in info
                          if line.startswith("model name")), "")
    except OSError:
        pass
    return {"node": platform.node(), "platform": platform.platform(), "cpu": model,
            "cpus": os.cpu_count(), "mpi_ranks": comm.size, "python": sys.version.split()[0],
            "rodfem": rodfem.__version__, "dolfinx": dolfinx.__version__,
            "petsc": ".".join(map(str, PETSc.Sys.getVersion())), "numpy": np.__version__}


def deal(costs: list[float], ranks: int) -> list[list[int]]:
    """Indices of the tasks for each rank: the costliest first, each to the least loaded rank
    (ties to the lowest); the same on every rank."""
    load, share = [0.0] * ranks, [[] for _ in range(ranks)]
    for i in sorted(range(len(costs)), key=lambda i: (-costs[i], i)):
        rank = min(range(ranks), key=lambda r: (load[r], r))
        load[rank] += costs[i]
        share[rank].append(i)
    return share


def parse_choices(text: str, option: str, allowed: tuple[str, ...], what: str,
                  error: type[ValueError]) -> tuple[str, ...]:
    """``"a,b"`` → the named choices, in the order of ``allowed``; ``error`` (one line naming
    ``option``) for a name that is not allowed."""
    names = [item.strip() for item in text.split(",")]
    for name in names:
        if name not in allowed:
            raise error(f"{option}: unknown {what} {name!r}; allowed: {', '.join(allowed)}")
    return tuple(a for a in allowed if a in names)


def csv_value(value) -> str:
    """A table cell: empty for None, true/false, floats to round-trip, nan and ±inf by name."""
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):  # NumPy 2's repr of its own floats says so
        value = float(value)
        return repr(value) if math.isfinite(value) else str(value)
    if isinstance(value, np.integer):
        return str(int(value))
    return str(value)


def write_csv(path: Path, columns: tuple[str, ...], rows: list[dict]) -> None:
    """A table of ``rows`` with the given ``columns``, whole or not at all (rank 0 calls it)."""
    with replacing(path, "w") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([csv_value(row[c]) for c in columns])


def prepare(out: Path, force: bool, comm: MPI.Comm, files: tuple[str, ...],
            command: str) -> None:
    """Create ``out`` for a study's ``files`` and its figures/, marked and held
    (:mod:`rodfem.output.directories`); with ``force``, replace an earlier rodfem result there but
    nothing else.

    Raises:
        OutputError: it exists (without ``force``), or is not rodfem's.
    """
    from rodfem.output.directories import prepare_directory

    prepare_directory(out, force, comm, command=command, files=(*files, "figures"))
