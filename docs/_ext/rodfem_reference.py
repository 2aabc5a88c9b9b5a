"""The generated reference pages: every scene key from :data:`rodfem.scene.schema.SCHEMA` (those
at the top of a file from ``TOP_KEYS``, the entries of ``[measures]`` from
:mod:`rodfem.scene.measures`) and every subcommand and option from :func:`rodfem.cli.parser`, as
MyST Markdown.

Written from the objects rodfem itself reads, at every build, so they cannot fall out of date.
Plain Python (no Sphinx): ``tests/test_docs_reference.py`` runs these functions in ``make test``.
"""

from __future__ import annotations

import argparse
import re

from rodfem.scene import measures
from rodfem.scene.schema import SCHEMA, TOP_KEYS, Key

_SPECIAL = re.compile(r"([\\`*_\[\]<>|$#{}])")

KINDS = {
    "real": "real",
    "integer": "integer",
    "boolean": "boolean",
    "choice": "choice",
    "expression": "expression",
    "reals": "list of reals",
    "choices": "list of choices",
}


def escape(text: str) -> str:
    """Text shown as it is written, whatever Markdown would make of it (``[u(1) - g]_+``)."""
    return _SPECIAL.sub(r"\\\1", " ".join(text.split()))


def toml(value) -> str:
    """A value as a scene file writes it."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml(v) for v in value) + "]"
    return f"{value:g}" if isinstance(value, float) else str(value)


def _number(value: float) -> str:
    return f"{value:g}"


def allowed(name: str, key: Key) -> str:
    """What a key accepts, in words (of each value, for a list)."""
    low = (f"> {_number(key.above)}" if key.above is not None
           else f"{_number(key.minimum)} ≤" if key.minimum is not None else "")
    high = f"≤ {_number(key.maximum)}" if key.maximum is not None else ""
    bounds = " value ".join(b for b in (low, high) if b) if low.endswith("≤") else \
        ", ".join(b for b in (low, high) if b)
    if key.kind in ("choice", "choices"):
        text = ", ".join(f"`{c}`" for c in key.choices)
        text = ("one of " if key.kind == "choice" else "any of ") + text
    elif key.kind == "boolean":
        text = "`true` or `false`"
    elif key.kind == "expression":
        names = "x, t" if name.startswith("source.") else "x"
        text = (f"an expression in {names} and the model's names (`a b zeta k theta_A`), "
                "with `+ - * / **`, `sin cos tan exp log sqrt abs`, `pi`")
    else:
        text = escape(bounds) if bounds else "any"
        if key.kind == "reals" and bounds:
            text = "each value: " + text
    if key.only_with is not None:
        other, value = key.only_with
        first, *others = value if isinstance(value, tuple) else (value,)
        text += f"; only with `{other} = {toml(first)}`" + "".join(
            f" or `{toml(v)}`" for v in others)
    return text


def scene_reference() -> str:
    """The scene reference page: every section, every key."""
    lines = [
        "# Scene reference",
        "",
        "Every key a scene may set, generated from rodfem's scene schema "
        "(`rodfem.scene.schema.SCHEMA`), the table rodfem checks every scene against. A scene "
        "file, a sweep file's values and `--set section.key=value` all use these names; a key "
        "left out takes its default (the paper's common data and its first experiment). "
        "{doc}`../running` shows a scene file and how mistakes are reported. A list "
        "(\"list of reals\", \"list of choices\") holds distinct values, each within the range "
        "or among the choices shown.",
        "",
        "At the top of the file, before its first section:",
        "",
        "| key | kind | default | meaning |",
        "|---|---|---|---|",
    ]
    for name, key in TOP_KEYS.items():
        default = "none" if key.default is None else f"`{toml(key.default)}`"
        lines.append(f"| `{name}` | {key.kind} | {default} | {escape(key.help)} |")
    for section, keys in SCHEMA.items():
        lines += ["", f"## `[{section}]`", "",
                  "| key | kind | default | allowed | meaning |", "|---|---|---|---|---|"]
        for key_name, key in keys.items():
            name = f"{section}.{key_name}"
            lines.append(f"| `{name}` | {KINDS[key.kind]} | `{toml(key.default)}` | "
                         f"{allowed(name, key)} | {escape(key.help) or '–'} |")
    return "\n".join(lines + measures_reference()) + "\n"


def entry_allowed(name: str) -> str:
    """What an entry key of ``[measures]`` accepts, in words."""
    if name == "column":
        probes = ", ".join(f"`{field}@x`" for field in measures.PROBE_FIELDS)
        fixed = ", ".join(f"`{c}`" for c in measures.COLUMN_NAMES if "@" not in c)
        adaptive = " and ".join(f"`{c}`" for c in measures.ADAPTIVE_COLUMNS)
        return (f"one of {fixed}, or a probe {probes} with 0 ≤ x ≤ 1; {adaptive} only with "
                "`time.adaptive = true`")
    if name == "reduce":
        return "one of " + ", ".join(f"`{r}`" for r in measures.REDUCTIONS)
    return r"\[t0, t1\] with 0 ≤ t0 < t1, t0 before `time.end`"


def measures_reference() -> list[str]:
    """The ``[measures]`` section: the keys of each entry, from :mod:`rodfem.scene.measures`."""
    lines = ["", "## `[measures]`", "",
             "Each entry declares a measure: `NAME = { column = ..., reduce = ... }`. NAME is "
             "lower-case letters, digits and `_`, not starting with a digit, and none of the "
             "names results.csv uses already (" + ", ".join(f"`{n}`" for n in measures.RESERVED)
             + "). {doc}`../outputs` shows what each reduction gives.",
             "", "| key | kind | default | allowed | meaning |", "|---|---|---|---|---|"]
    for name, (kind, required, meaning) in measures.ENTRIES.items():
        default = "required" if required else "none"
        lines.append(f"| `measures.NAME.{name}` | {kind} | {default} | {entry_allowed(name)} | "
                     f"{escape(meaning)} |")
    return lines


def _subcommands(parser: argparse.ArgumentParser):
    """(name, help, subparser) of each subcommand, in the parser's order."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, helps.get(name, ""), sub


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = argparse.HelpFormatter(parser.prog, width=90)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip()


def _argument(action: argparse.Action) -> str:
    if action.option_strings:
        names = ", ".join(action.option_strings)
        if action.nargs != 0:
            names += " " + (action.metavar or action.dest.upper())
        return names
    return action.metavar or action.dest


def options(parser: argparse.ArgumentParser) -> dict[str, list[str]]:
    """Every subcommand's option strings (``--out``, ``-h``…) and positional names."""
    found = {}
    for name, _, sub in _subcommands(parser):
        found[name] = [s for a in sub._actions for s in (a.option_strings or [_argument(a)])]
    return found


def cli_reference(parser: argparse.ArgumentParser) -> str:
    """The command-line reference page: every subcommand, its arguments and their help."""
    lines = [
        "# Command-line reference",
        "",
        f"`{parser.prog}`: {escape(parser.description or '')} Generated from rodfem's argument "
        "parser (`rodfem.cli.parser`), so it lists exactly what `rodfem SUBCOMMAND --help` "
        "prints. Every command checks all its arguments before it starts: a mistake is one line "
        "and exit code 2 ({doc}`../running` lists the exit codes).",
        "",
        f"| option of `{parser.prog}` itself | meaning |",
        "|---|---|",
        *(f"| `{_argument(action)}` | {escape(action.help or '')} |"
          for action in parser._actions if action.option_strings),
        "",
        "| subcommand | what it does |",
        "|---|---|",
    ]
    subcommands = list(_subcommands(parser))
    for name, help, _ in subcommands:
        lines.append(f"| [`{parser.prog} {name}`](cli-{name}) | {escape(help or '')} |")
    for name, help, sub in subcommands:
        lines += ["", f"(cli-{name})=", f"## `{parser.prog} {name}`", "",
                  "```text", _usage(sub), "```", "", escape(sub.description or help or ""), "",
                  "| argument | meaning | default |", "|---|---|---|"]
        for action in sub._actions:
            default = action.default
            shown = ("–" if default in (None, False, [], argparse.SUPPRESS) or action.nargs == 0
                     else f"`{default}`")
            lines.append(f"| `{_argument(action)}` | {escape(action.help or '')} | "
                         f"{shown} |")
    return "\n".join(lines) + "\n"
