"""The options that several ``rodfem`` subcommands share (:mod:`rodfem.cli` builds its parser
with them): paths, ``--set``, ``--out`` and ``--force``, ``--yes``, ``--progress``,
``--format``, and the command's own ``--version``."""

from __future__ import annotations

import argparse
from pathlib import Path


def path_argument(text: str) -> Path:
    """A path given on the command line; a NUL character, which no file name holds (a caller of
    :func:`main` can pass one, a shell cannot), is refused as a mistake in the arguments."""
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"{text!r} holds a NUL character, which no path can")
    return Path(text)


def add_overrides(command: argparse.ArgumentParser, help: str) -> None:
    command.add_argument("--set", dest="overrides", action="append", default=[],
                         metavar="SECTION.KEY=VALUE", help=help)


def add_output(command: argparse.ArgumentParser, default: str | None, help: str,
            force: str) -> None:
    """--out (with its default, or none) and --force (replace what that command wrote)."""
    command.add_argument("--out", type=path_argument, default=Path(default) if default else None,
                         help=help)
    command.add_argument("--force", action="store_true", help=force)


def add_yes(command: argparse.ArgumentParser) -> None:
    """--yes: a study estimated beyond a day is run all the same."""
    command.add_argument("--yes", action="store_true",
                         help="run it even if its estimated cost (runs × steps × the µs/step "
                         "measured on a few steps, said before it starts from ten minutes on) is "
                         "more than a day on the ranks given; without it such a study is "
                         "refused, nothing written")


def add_progress(command: argparse.ArgumentParser, help: str) -> None:
    command.add_argument("--progress", action="store_true", help=help)


def version_line() -> str:
    """What ``rodfem --version`` prints: rodfem's version and the FEniCSx and PETSc it runs on,
    read from their installed metadata (nothing heavy is imported)."""
    from importlib import metadata

    import rodfem

    found = []
    for shown, distribution in (("dolfinx", "fenics-dolfinx"), ("petsc4py", "petsc4py")):
        try:
            found.append(f"{shown} {metadata.version(distribution)}")
        except metadata.PackageNotFoundError:
            continue
    return f"rodfem {rodfem.__version__}" + (f" ({', '.join(found)})" if found else "")


class _Version(argparse.Action):
    """--version: :func:`version_line` on standard output, exit code 0 (the metadata is read
    only then: a tenth of a second no other command should pay)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help=None):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(version_line(), flush=True)
        parser.exit(0)


def add_version(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--version", action=_Version,
                        help="print rodfem's version (and dolfinx's, petsc4py's) and exit")


def add_format(command: argparse.ArgumentParser, default: str) -> None:
    """--format: the still figures' file format (one line and exit code 2 for another)."""
    from rodfem.scene.schema import FIGURE_FORMATS

    command.add_argument("--format", choices=FIGURE_FORMATS, default=None,
                         help=f"the figures' format: {', '.join(FIGURE_FORMATS)} (PDF and SVG "
                         f"keep text and lines as vectors; default: {default})")
