"""The layers of the package: each imports only the layers before it (function-level imports
included), every registry agrees with the scene schema, and the compiled loops' C tables agree
with the Python ones."""

import ast
import types
from pathlib import Path

import pytest

import rodfem
from rodfem.model.contact import LAWS, LinearLaw, PowerLaw, RigidObstacle
from rodfem.output.columns import NAMES
from rodfem.scene import SCHEMA
from rodfem.solver.compiled.loop import check_library
from rodfem.solver.methods import REGISTRY
from rodfem.solver.record import RAW
from rodfem.solver.time_schemes import TIME_SCHEMES

ROOT = Path(rodfem.__file__).parent
# The flow, first to last: a module may import its own layer and the layers before it.
LAYERS = ["scene", "model", "forms", "discrete", "solver", "output", "run", "post", "studies",
          "commands", "cli"]


def layer(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] == "forms":
        return "forms"
    if parts[0] != "rodfem" or len(parts) < 2:
        return None
    return parts[1] if parts[1] in LAYERS else None


def imports(path: Path, module: str) -> set[str]:
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def modules():
    for path in sorted(ROOT.rglob("*.py")):
        name = ".".join(path.relative_to(ROOT.parent).with_suffix("").parts)
        yield path, name.removesuffix(".__init__")
    for path in sorted((ROOT.parent / "forms").glob("*.py")):
        yield path, "forms." + path.stem


def test_each_layer_imports_only_the_layers_before_it():
    wrong = []
    for path, module in modules():
        own = layer(module)
        if own is None:
            continue
        for target in imports(path, module):
            other = layer(target)
            if other is not None and LAYERS.index(other) > LAYERS.index(own):
                wrong.append(f"{module} imports {target}")
    assert not wrong, wrong


def test_forms_import_nothing_but_ufl():
    for path, module in modules():
        if module.startswith("forms."):
            assert {t.split(".")[0] for t in imports(path, module)} <= {"ufl"}, module


def test_the_layer_check_can_fail(tmp_path):
    """A module of the solver importing the output layer is reported."""
    module = tmp_path / "bad.py"
    module.write_text("def f():\n    from rodfem.output import files\n")
    targets = imports(module, "rodfem.solver.bad")
    assert any(LAYERS.index(layer(t)) > LAYERS.index("solver") for t in targets if layer(t))


def test_registries_agree_with_the_schema():
    assert set(REGISTRY) == set(SCHEMA["solver"]["method"].choices)
    assert set(TIME_SCHEMES) == set(SCHEMA["time"]["scheme"].choices)
    assert set(LAWS) == set(SCHEMA["obstacle"]["law"].choices)
    assert {law.code for law in (LinearLaw, PowerLaw, RigidObstacle)} == {0, 1, 2}


def test_recorded_quantities_agree_with_the_schema():
    from rodfem.output.columns import QUANTITIES
    from rodfem.output.fields import FIELDS
    from rodfem.post.fields import FUNCTIONS

    assert SCHEMA["output"]["history"].choices == tuple(c.name for c in QUANTITIES)
    assert set(SCHEMA["output"]["fields"].choices) == set(FIELDS) == set(FUNCTIONS)
    assert set(SCHEMA["output"]["fields"].default) <= set(FIELDS)


def test_the_columns_and_names_measures_may_name_agree_with_the_output_layer():
    """The scene layer keeps the history's column names and the built-in measures' names that
    a declared measure may (and may not) use: they are the output layer's."""
    from rodfem.output import columns
    from rodfem.output.measures import NAMES as BUILTIN
    from rodfem.scene import measures

    assert measures.DEFAULT_COLUMNS == columns.NAMES
    assert measures.ADAPTIVE_COLUMNS == tuple(c.name for c in columns.ADAPTIVE)
    assert measures.PROBE_FIELDS == tuple(p.split("@")[0] for p, _, _ in columns.PROBES)
    assert measures.BUILTIN_NAMES == BUILTIN


def test_every_column_and_measure_has_a_name_in_the_figures():
    """The figures name each column a measure may reduce, and each built-in measure, by the
    paper's symbol and unit (rodfem.output.names), never by a fallback."""
    from rodfem.output import columns, names
    from rodfem.output.measures import NAMES as BUILTIN

    written = [c.name for c in (*columns.COLUMNS, *columns.ADAPTIVE, *columns.QUANTITIES)]
    assert set(written) <= set(names.COLUMNS)
    assert set(BUILTIN) == set(names.MEASURES)
    assert {p.split("@")[0] for p, _, _ in columns.PROBES} == set(names.PROBES)


def test_history_header():
    assert ",".join(NAMES) == "t,u_1,u_half,ut_1,sigma_1,energy,iterations"


def fake_library(**changes):
    values = {f"RAW_{slot.name.upper()}": i for i, slot in enumerate(RAW)}
    values.update(RAW_SLOTS=len(RAW), RC_LINEAR=0, RC_POWER=1, RC_RIGID=2)
    values.update(changes)
    return types.SimpleNamespace(**values)


def test_c_tables_are_checked_against_python():
    check_library(fake_library())  # as the headers have it
    with pytest.raises(RuntimeError, match="RAW_U_1"):
        check_library(fake_library(RAW_U_1=3))
    with pytest.raises(RuntimeError, match="RC_POWER"):
        check_library(fake_library(RC_POWER=5))


def test_built_loops_pass_the_check():
    from rodfem.solver.compiled import direct, picard

    for module in (direct, picard):
        if module.available():
            check_library(module._library()[1])
