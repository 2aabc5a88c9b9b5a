"""Which kind of directory a path is: the command its marker (``rodfem.json``) names. Each loader
(``rodfem.load``, ``load_sweep``, ``load_fit``, ``load_sensitivity``) asks first, so that a
directory of another kind is named in one line with what reads it, e.g. "out is a sweep
directory: use rodfem.load_sweep", instead of a file it lacks."""

from __future__ import annotations

from pathlib import Path

# The loader of each kind of directory, by the command that writes it.
LOADERS = {"run": "rodfem.load", "sweep": "rodfem.load_sweep", "fit": "rodfem.load_fit",
           "sensitivity": "rodfem.load_sensitivity"}
# What a directory of each command is called in a message.
NAMES = {"run": "a run", "sweep": "a sweep", "fit": "a fit", "sensitivity": "a sensitivity",
         "steady": "a steady-state", "verify": "a verify", "stability": "a stability",
         "work-precision": "a work-precision", "paper": "a paper",
         "periodic": "a periodic-orbit"}


def kind(path: Path) -> str | None:
    """The command whose directory ``path`` is (its marker's ``command``), or None where it has
    no marker rodfem wrote."""
    from rodfem.output.writers import read_marker

    marker = read_marker(Path(path))
    command = None if marker is None else marker.get("command")
    return command if isinstance(command, str) else None


def other_kind(path: Path, wanted: str) -> str | None:
    """The line saying that ``path`` is the directory of a command other than ``wanted`` and
    what reads it; None for a directory of ``wanted`` or one without a marker."""
    found = kind(path)
    if found is None or found == wanted:
        return None
    name = NAMES.get(found, f"a rodfem {found}")
    if found in LOADERS:
        return f"{path} is {name} directory: use {LOADERS[found]}"
    return (f"{path} is {name} directory (rodfem {found}), which no loader reads: only run, "
            "sweep, fit and sensitivity directories load")
