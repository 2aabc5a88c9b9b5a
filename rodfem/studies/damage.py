"""Whether a stopped study's directory is as rodfem left it, checked before ``rodfem resume``
does anything: a sweep, fit or sensitivity directory whose files were replaced, removed or
planted is refused in one line naming the entry (exit code 2), and nothing in it is changed.

What is checked (:func:`damage`): the marker names the command whose files the directory holds
(not another's, as an edited marker would); each entry the command writes is of its kind, a
regular file or a directory, never a link (a ``journal`` replaced by a file, a ``results.csv``
that is a directory); a run directory inside (a fit's ``fitted/``, a sensitivity study's
``runs/``) is rodfem's, of the right command, and checked alike; and the file that resume reads
first (``sweep.json``, ``study.json``, ``sensitivity.json``) is there wherever the study had
gone beyond writing it.
"""

from __future__ import annotations

from pathlib import Path

from rodfem.output.atomic import TEMPORARY
from rodfem.output.journal import DIRECTORY as JOURNAL
from rodfem.output.writers import LOCK, MARKER, read_marker

COMMANDS = ("run", "sweep", "fit", "sensitivity")
# The file that resume reads first, per command: written first, after the marker.
META = {"sweep": "sweep.json", "fit": "study.json", "sensitivity": "sensitivity.json"}
# Files that only one command writes: a directory holding one is that command's.
SIGNS = {"run": ("scene.toml", "checkpoint.npz", "history.h5"), "sweep": ("sweep.json",),
         "fit": ("study.json", "fit.json", "base.toml"),
         "sensitivity": ("sensitivity.json", "samples.csv")}
# The directories a command writes inside its own: None for data, else the command of the run
# directory it is (which may be missing, or only claimed, when the study stopped early).
DIRECTORIES = {"sweep": {JOURNAL: None}, "fit": {JOURNAL: None, "fitted": "run"},
               "sensitivity": {"runs": "sweep"}}


def _kind(path: Path) -> str:
    """What ``path`` is, in words, for a message."""
    if path.is_symlink():
        return "a link"
    return "a directory" if path.is_dir() else "a file" if path.is_file() else "not a file"


def _begun(out: Path, command: str) -> str | None:
    """An entry that shows the study ``command`` in ``out`` went beyond writing its first file,
    or None."""
    journal = out / JOURNAL
    if journal.is_dir() and any(journal.iterdir()):
        return f"its {JOURNAL}/ holds points"
    later = {"sweep": ("results.csv", "summary.json"), "fit": ("base.toml", "data.csv",
                                                              "fit.json", "fitted"),
             "sensitivity": ("samples.csv", "runs", "sensitivity.csv")}[command]
    found = next((name for name in later if (out / name).exists()), None)
    return None if found is None else f"it holds {found}"


def damage(out: Path, marker: dict, again: str | None = None) -> str | None:
    """Why the directory ``out`` (its ``marker`` read) cannot be resumed as it stands: the first
    entry that is not what its command wrote, on one line with what to do; or None. ``again``:
    how to start the study again (for a directory inside a study, the study's words)."""
    command = marker.get("command")
    if command not in COMMANDS:
        return None
    what = {"run": "run", "sweep": "sweep", "fit": "fit", "sensitivity": "sensitivity study"}
    again = again or f"run the {what[command]} again with --force"
    listed = {name for name in marker.get("files", ()) if isinstance(name, str)}
    for other, signs in SIGNS.items():
        sign = next((name for name in signs if other != command and (out / name).exists()),
                    None)
        if sign is not None:
            return (f"{out / MARKER} says it is a directory of 'rodfem {command}', but it holds "
                    f"{sign}, a file of 'rodfem {other}': the marker disagrees with the "
                    f"directory's files (was it edited?); put back its marker of 'rodfem {other}'")
    if command == "run":
        return None  # a run's own files are checked by its resume
    inside = DIRECTORIES[command]
    for name in sorted(listed | set(inside)):
        entry = out / name
        if not entry.exists() and not entry.is_symlink():
            continue
        wanted = "a directory" if name in inside else "a file"
        if _kind(entry) != wanted:
            return (f"{entry} is {_kind(entry)}, where 'rodfem {command}' keeps "
                    f"{wanted}: the directory was altered; put back what was there, or {again}")
        if inside.get(name) is not None:
            why = _run_directory(entry, inside[name], again)
            if why is not None:
                return why
    meta = META[command]
    if not (out / meta).exists() and (begun := _begun(out, command)) is not None:
        return (f"{out} is damaged: {meta} is missing, though {begun}; put {meta} back, or "
                f"{again}")
    return None


def _claim_file(name: str) -> bool:
    """Whether ``name`` is what a command leaves as it claims a directory: its lock, or the
    temporary file of its marker."""
    temporary = TEMPORARY.match(name)
    return name == LOCK or (temporary is not None and temporary["name"] == MARKER)


def _run_directory(path: Path, command: str, again: str) -> str | None:
    """Why ``path``, a directory a study writes its runs into, is not one ('rodfem
    ``command``'s), or None. Missing, or claimed but not yet marked (a study stopped as it
    created it), it is one."""
    entries = [entry.name for entry in path.iterdir()]
    marker = read_marker(path)
    if marker is None:
        if command == "sweep":  # a sensitivity study's runs/: its resume says what to do
            return None
        if entries and all(_claim_file(name) for name in entries):
            return None  # claimed as a kill left it
        return (f"{path} is not the directory rodfem writes there (it has no {MARKER}); "
                "move it away and resume again")
    if marker.get("command") != command:
        return (f"{path / MARKER} says it is a directory of 'rodfem {marker.get('command')}', "
                f"not of 'rodfem {command}' as rodfem writes there: the directory was altered; "
                f"put back what was there, or {again}")
    return damage(path, marker, again)
