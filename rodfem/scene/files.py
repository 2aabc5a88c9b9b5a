"""Reading the files a user names (a scene, a sweep) as TOML, apart from checking what they say.

Only a regular file is read: a device such as /dev/zero would be read without end, and a pipe
without a writer would wait forever. Each refusal and each failure to read is a one-line
:class:`SceneError`.
"""

from __future__ import annotations

import os
import stat
import tomllib
from importlib import resources
from pathlib import Path

from rodfem.scene.expressions import shorten
from rodfem.scene.schema import BUILTIN, EXTRA, SCHEMA, SceneError
from rodfem.scene.values import with_changes

MAX_BASES = 16  # base scenes, one on another


def _parse_toml(text: str, what: str) -> dict:
    """TOML text as a dict; SceneError (one line) for anything tomllib refuses, including what
    it refuses with other errors: integers of more than 4,300 digits (ValueError), nesting
    deeper than Python's recursion limit (RecursionError)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{what}: invalid TOML ({err})") from None
    except ValueError as err:
        raise SceneError(f"{what}: a value TOML cannot hold ({err})") from None
    except RecursionError:
        raise SceneError(f"{what}: nested too deeply to read") from None


# What a path names if not a regular file, for the message that refuses it.
_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a pipe"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def read_text(path: Path, what: str, form: str = "TOML") -> str | None:
    """The text of the regular file ``path`` (a ``form`` file; UTF-8, a leading byte-order mark
    dropped), or None if there is no such file. The file is opened without waiting for a writer
    and checked once open, so what is read is what was checked.

    Raises:
        SceneError: ``what`` and why, on one line, for a path that names something else (a
            directory, a device, a pipe) or cannot be read (no permission, a name longer than
            the system allows, text that is not UTF-8).
    """
    if "\0" in str(path):  # Python's own words for it differ from version to version
        raise SceneError(f"{what}: cannot be read (a path cannot hold a NUL character)")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as err:
        raise SceneError(f"{what}: cannot be read "
                         f"({getattr(err, 'strerror', None) or err})") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((name for test, name in _KINDS if test(mode)), "not a file")
            raise SceneError(f"{what}: not a regular file but {kind}; give a {form} file")
        # "utf-8-sig": a byte-order mark, which some editors write first, is not part of the text
        with open(fd, encoding="utf-8-sig", closefd=False) as file:
            return file.read()
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError(f"{what}: cannot be read ({err})") from None
    finally:
        os.close(fd)


def _identity(path: Path) -> str:
    """The path ``path`` names, links followed, for spotting a cycle of base scenes; the absolute
    path where it cannot be followed (a cycle of links, a NUL character in the name), which
    :func:`read_text` then refuses in one line."""
    try:
        return str(path.resolve())
    except (OSError, RuntimeError, ValueError):  # RuntimeError: a symlink loop (Python 3.11)
        return os.path.abspath(path) if "\0" not in str(path) else str(path)


def read_file(path: str | Path, what: str) -> dict:
    """The TOML data of the file ``path`` (a sweep's, say), refused as ``what`` in one line where
    there is no such regular file or it cannot be read."""
    text = read_text(Path(path), what)
    if text is None:
        raise SceneError(f"{what}: no such file")
    return _parse_toml(text, what)


def read(scene: str | Path) -> tuple[dict, str]:
    """The raw TOML data of a built-in scene (by name) or a TOML file (by path), and its source:
    the name, or the path as given. A file that names a base scene (``scene = "paper2"``, a
    built-in name or a path relative to the file) is read over it (:func:`based`).

    Raises:
        SceneError: if the scene cannot be read.
    """
    return _read(str(scene), ())


def _read(scene: str, chain: tuple[str, ...]) -> tuple[dict, str]:
    """:func:`read`, ``chain`` the files that named this one as their base (for a cycle)."""
    if scene in BUILTIN or scene in EXTRA:
        text = resources.files("rodfem.scene").joinpath("builtin", f"{scene}.toml").read_text()
        return _parse_toml(text, f"scene '{scene}'"), scene
    what = f"scene '{shorten(scene)}'"
    text = read_text(Path(scene), what)
    if text is None:
        raise SceneError(
            f"{what}: not a built-in scene ({', '.join(BUILTIN + EXTRA)}) nor a TOML file"
            if not chain else f"{what}: no such file (the base scene of '{shorten(chain[-1])}')"
        )
    return based(_parse_toml(text, what), what, Path(scene).parent,
                 (*chain, _identity(Path(scene)))), \
        str(Path(scene))


def based(data: dict, what: str, directory: Path | None = None,
          chain: tuple[str, ...] = ()) -> dict:
    """A scene's raw ``data`` read over the base scene it names (``scene = "paper2"``: a built-in
    name, or a TOML path relative to ``directory``), if it names one: the base's sections with
    this scene's keys set over them, key by key (a section such as ``[measures]`` too, entry by
    entry), and its description unless this scene has its own (the base's, naming the keys
    this scene sets: :func:`~rodfem.scene.values.with_changes`). A base may name a base of its own.

    Raises:
        SceneError: for a base that is not a name or path, cannot be read, or comes round again.
    """
    if not isinstance(data, dict) or "scene" not in data:
        return data
    name = data["scene"]
    if not isinstance(name, str) or not name.strip():
        raise SceneError(f'{what}: scene must name its base scene, e.g. scene = "paper2"')
    path = name
    if name not in BUILTIN + EXTRA and directory is not None and not Path(name).is_absolute():
        path = str(directory / name)
    again = name not in BUILTIN + EXTRA and _identity(Path(path)) in chain
    if again or len(chain) > MAX_BASES:
        raise SceneError(f"{what}: its base scene '{shorten(name)}' comes round again (a cycle "
                         "of base scenes)" if again else
                         f"{what}: more than {MAX_BASES} base scenes, one on another")
    base, _ = _read(path, chain)
    merged = {key: dict(value) if isinstance(value, dict) else value
              for key, value in base.items()}
    for key, value in data.items():
        if key == "scene":
            continue
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key].update(value)
        else:
            merged[key] = value
    if "description" not in data and isinstance(merged.get("description"), str):
        changes = {f"{section}.{key}": value for section, keys in data.items()
                   if section in SCHEMA and isinstance(keys, dict) for key, value in keys.items()}
        merged["description"] = with_changes(merged["description"], changes)
    return merged
