"""``rodfem periodic``: the periodic orbit of a scene whose steady state has lost stability,
found by shooting with the scene's own scheme (:mod:`rodfem.studies.steady.orbit`), and with
``--continue`` the orbits over a scene value (:mod:`rodfem.studies.steady.periodic`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rodfem.commands.common import EXIT_INPUT, say
from rodfem.scene import load


def periodic(args: argparse.Namespace) -> int:
    """The orbit(s) into the directory; a short table on standard output, a warning line for
    each value without an orbit."""
    from mpi4py import MPI

    from rodfem.output.directories import OutputError, finish
    from rodfem.output.figures import FormatError, chosen
    from rodfem.studies.steady import periodic as pe

    comm = MPI.COMM_WORLD
    scene = load(args.scene, args.overrides)
    try:
        key, values = pe.parse_continuation(args.continuation)
        if key is not None:  # every value's scene checked before anything runs
            for value in values:
                pe.check(load(args.scene, [*args.overrides, f"{key}={float(value)!r}"]))
        pe.check(scene)
        format = chosen(args.format, scene)
    except (pe.PeriodicError, FormatError) as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    out = args.out if args.out is not None else \
        Path("results") / f"{Path(args.scene).stem}-periodic"
    try:
        pe.prepare_out(out, args.force, comm)
    except OutputError as err:
        say(f"rodfem: error: {err}")
        return EXIT_INPUT
    points = pe.continuation(args.scene, args.overrides, key, values, comm)
    written = pe.write(out, comm, points, key)
    if comm.rank == 0:
        from rodfem.post.periodic import plot_continuation, plot_orbit

        if pe.ORBIT in {path.name for path in written}:
            written += plot_orbit(out, scene["obstacle.gap"], format)
        if key is not None:
            written += plot_continuation(out, key, format)
    finish(out, "complete", comm)
    for line in pe.table_lines(points, key):
        say(line, sys.stdout)
    for line in pe.warning_lines(points, key):
        say(line)
    for path in written:
        say(str(path), sys.stdout)
    comm.barrier()
    return 0
