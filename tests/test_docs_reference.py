"""The generated reference pages (docs/_ext/rodfem_reference.py) list every scene key and every
command-line option, read from the scene schema and the argument parser themselves. Needs neither
Sphinx nor a built site: part of `make test`."""

import argparse
import sys
from pathlib import Path

import pytest

from rodfem.cli import parser
from rodfem.scene import measures
from rodfem.scene.schema import SCHEMA, TOP_KEYS, TOP_LEVEL

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "docs" / "_ext"))
import rodfem_reference  # noqa: E402


@pytest.fixture(scope="module")
def scene_page() -> str:
    return rodfem_reference.scene_reference()


@pytest.fixture(scope="module")
def cli_page() -> str:
    return rodfem_reference.cli_reference(parser())


def _row(page: str, name: str) -> str:
    rows = [line for line in page.splitlines() if line.startswith(f"| `{name}` |")]
    assert len(rows) == 1, f"{name}: {len(rows)} rows"
    return rows[0]


def test_scene_reference_lists_every_key(scene_page):
    for section, keys in SCHEMA.items():
        assert f"## `[{section}]`" in scene_page
        for name, key in keys.items():
            row = _row(scene_page, f"{section}.{name}")
            assert rodfem_reference.KINDS[key.kind] in row
            assert f"`{rodfem_reference.toml(key.default)}`" in row
            for choice in key.choices:
                assert f"`{choice}`" in row, (section, name, choice)
            for bound in (key.minimum, key.maximum, key.above):
                if bound is not None:
                    assert f"{bound:g}" in row, (section, name, bound)
            if key.only_with is not None:
                assert f"`{key.only_with[0]} = " in row
            # every key says what it means
            assert key.help.strip(), f"{section}.{name} has no meaning"
            assert rodfem_reference.escape(key.help) in row
    for name in TOP_LEVEL:
        _row(scene_page, name)


def _tables(page: str) -> list[list[list[str]]]:
    """Every table of a page: its rows (header first), each a list of cells."""
    tables, current = [], None
    for line in [*page.splitlines(), ""]:
        if line.startswith("|"):
            cells = [cell.strip() for cell in line.strip("|").split(" | ")]
            current = [cells] if current is None else [*current, cells]
        elif current is not None:
            tables.append(current)
            current = None
    return tables


def test_scene_reference_rows_are_the_schemas_keys_with_their_kinds(scene_page):
    """Every row of every table names a key rodfem reads, with its kind, and every key has one:
    the top-level keys (the base scene's included), each section's, and a [measures] entry's."""
    expected = {name: key.kind for name, key in TOP_KEYS.items()}
    expected |= {f"{section}.{name}": rodfem_reference.KINDS[key.kind]
                 for section, keys in SCHEMA.items() for name, key in keys.items()}
    expected |= {f"measures.NAME.{name}": kind for name, (kind, _, _) in measures.ENTRIES.items()}
    found = {}
    for table in _tables(scene_page):
        header, rule, *rows = table
        assert header[:3] == ["key", "kind", "default"], header  # no row outside a table
        assert set("".join(rule)) <= {"-", "|"}
        for row in rows:
            assert len(row) == len(header), row
            name = row[0].strip("`")
            assert name not in found, name
            found[name] = row[1]
    assert found == expected
    assert set(TOP_LEVEL) | {"scene"} == set(TOP_KEYS)
    assert set(measures.ENTRY_KEYS) == set(measures.ENTRIES)
    measures_section = scene_page.split("## `[measures]`", 1)[1]
    for name in (*measures.COLUMN_NAMES, *measures.REDUCTIONS, *measures.RESERVED):
        assert f"`{name}`" in measures_section, name


def test_scene_reference_list_kinds(scene_page):
    """The list kinds "reals" and "choices" say they are lists, with their values' range."""
    probes, fields = _row(scene_page, "output.probes"), _row(scene_page, "output.fields")
    assert "list of reals" in probes and "0 ≤ value ≤ 1" in probes
    assert "list of choices" in fields and '`["theta", "u", "sigma"]`' in fields


def test_cli_reference_lists_rodfems_own_options(cli_page):
    for option in ("-h, --help", "--version"):
        assert f"| `{option}` |" in cli_page


def test_cli_reference_lists_every_option(cli_page):
    options = rodfem_reference.options(parser())
    top = parser()
    commands = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    assert set(options) == set(commands.choices)
    for command, strings in options.items():
        section = cli_page.split(f"## `rodfem {command}`\n", 1)[1].split("\n## ", 1)[0]
        assert f"usage: rodfem {command}" in section
        listed = {name for line in section.splitlines() if line.startswith("| `")
                  for name in line.split("`")[1].replace(",", " ").split()}
        assert set(strings) <= listed, (command, set(strings) - listed)
        for action in commands.choices[command]._actions:
            if action.help:
                assert rodfem_reference.escape(action.help) in section, (command, action.help)
