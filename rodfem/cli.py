"""The ``rodfem`` command: its arguments (:func:`parser`, of each subcommand's in
:mod:`rodfem.commands.parsers`) and their dispatch to :mod:`rodfem.commands`.

    rodfem run SCENE [--out DIR] [--set section.key=value ...] [--force]
    rodfem sweep SWEEP.toml [--out DIR] [--force] [--histories]
    rodfem fit FIT.toml [--out DIR] [--force] [--progress] [--format png|pdf|svg]
    rodfem sensitivity SENS.toml [--out DIR] [--force] [--format png|pdf|svg]
    rodfem resume DIR [--set time.end=T] [--format png|pdf|svg]   (a fit's or a study's figure)
    rodfem plot DIR [DIR ...] [--out FIGDIR] [--force] [--only KINDS] [--no-animation]
                [--window T0,T1] [--labels A,B,...] [--colour-by KEY]   (runs, or one sweep)
                [--format png|pdf|svg]
    rodfem stability [--out DIR] [--scene S] [--methods M,...] [--dt LIST] [--epsilon LIST]
                     [--zeta LIST] [--a LIST] [--end T] [--force] [--progress]
    rodfem verify [--out DIR] [--scenes S,FILE.toml,...] [--set section.key=value ...]
                  [--select I,J,...] [--force] [--quick] [--progress]
    rodfem work-precision [--out DIR] [--force] [--quick] [--progress]
    rodfem steady SCENE [--out DIR] [--set section.key=value ...] [--continue KEY=a:b[:n]]
                  [--force] [--format png|pdf|svg]
    rodfem periodic SCENE [--out DIR] [--set section.key=value ...] [--continue KEY=a:b:n]
                    [--force] [--format png|pdf|svg]

Exit codes (:mod:`rodfem.commands`): 0 complete, 2 bad input, 3 a step could not be taken, 4 a
file could not be written, 128 + the signal's number when stopped by a signal.
"""

from __future__ import annotations

import argparse
import os
import sys

from rodfem import commands, parallel
from rodfem.commands.arguments import add_version
from rodfem.commands.parsers import ADDERS
from rodfem.output import interrupts
from rodfem.scene import SceneError


class _Parser(argparse.ArgumentParser):
    """A mistake in the arguments is one line, and exit code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} "
                     "--help)\n")


def parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of every subcommand (the CLI reference is generated from it), or
    with ``command`` (a subcommand's name) of that one alone: the same parser for its
    arguments, without the others' set-up (a tenth of a small run's start)."""
    parser = _Parser(
        prog="rodfem",
        description="Dynamic contact of a thermoviscoelastic rod with an obstacle (Copetti).",
    )
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True)
    for add in (ADDERS[command],) if command in ADDERS else dict.fromkeys(ADDERS.values()):
        add(sub)
    return parser


COMMANDS = {"run": commands.run, "sweep": commands.sweep, "resume": commands.resume,
            "fit": commands.fit, "sensitivity": commands.sensitivity,
            "plot": commands.plot,
            "paper": commands.paper,
            "stability": commands.stability, "verify": commands.verify,
            "work-precision": commands.verify, "steady": commands.steady,
            "periodic": commands.periodic, "prepare": commands.prepare}


def _release(status: str) -> str:
    """Mark the directories still held with ``status`` (if rodfem got as far as holding any);
    returns how to continue the outermost of them, where ``rodfem resume`` continues it, or
    ''."""
    directories = sys.modules.get("rodfem.output.directories")
    if directories is None:
        return ""
    with interrupts.deferred():  # a second signal (mpirun's SIGTERM) waits for the marker
        released = directories.release_all(status)
    if not released:
        return ""
    outer = min(released, key=lambda path: len(path.parts))  # a study's, not its runs/
    if released[outer] not in directories.RESUMABLE:  # e.g. rodfem paper, holding its runs
        return ""
    try:
        shown = os.path.relpath(outer)
    except OSError:  # no current directory
        shown = str(outer)
    return f"; 'rodfem resume {outer if shown.startswith('..') else shown}' continues it"


def main(argv: list[str] | None = None) -> int:
    interrupts.install()  # before anything heavy is imported: signals stop rodfem cleanly
    parallel.start()  # under mpirun: PETSc started on every rank alike, before any rank's work
    with interrupts.command():
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    try:
        words = sys.argv[1:] if argv is None else argv
        args = parser(words[0] if words else None).parse_args(argv)
        kernel = os.environ.get("RODFEM_KERNEL")
        if kernel not in (None, "0", "1"):  # "false" must not mean the compiled loop
            commands.say(f"rodfem: error: RODFEM_KERNEL is {kernel!r}; allowed: 0 (the PETSc "
                         "loop) or 1 (the compiled loop where it applies), or unset")
            return commands.EXIT_INPUT
        return COMMANDS[args.command](args)
    except SceneError as err:
        commands.say(f"rodfem: error: {err}")
        return commands.EXIT_INPUT
    except Exception as err:  # noqa: BLE001 (what a signal or a failed write became)
        from rodfem.output import handover

        signum = interrupts.signal_behind(err)
        if signum is not None:
            again = _release("interrupted")
            # said by every rank that gets here, not rank 0's alone: this rank may end the others
            # (handover.abort_ranks) before rank 0 has said anything
            print(f"rodfem: {interrupts.Interrupted(signum)}; stopped outside a time loop, "
                  f"nothing half-written{again}", file=sys.stderr, flush=True)
            handover.abort_ranks(128 + signum)
            return 128 + signum
        from rodfem.solver.errors import KernelUnavailable

        if isinstance(err, KernelUnavailable):  # a study's scene's loop (a run checks first)
            _release("failed")
            commands.say(err.line())
            return commands.EXIT_DIVERGED
        if isinstance(err, OSError):  # a write that failed outside a run's loop (a figure)
            _release("failed")
            from rodfem.output.atomic import io_line

            commands.say(f"rodfem: error: {io_line(err)}")
            handover.abort_ranks(commands.EXIT_IO)
            return commands.EXIT_IO
        raise


if __name__ == "__main__":
    sys.exit(main())
