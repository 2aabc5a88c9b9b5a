"""The layers of the package: each imports only the layers before it (function-level imports
included), the API above the studies and never imported by them, the study families apart, every
registry agrees with the scene schema, and the compiled loops' C tables agree with the Python
ones."""

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
          "api", "commands", "cli"]
# Within the studies: a family (a subpackage) imports its own modules, the shared ones and the
# sweep engine it runs on; the shared modules import no family.
SHARED = {"common", "cost", "damage", "asymptotic", "accuracy"}
ENGINE = "sweep"


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


def layer_faults(path: Path, module: str) -> list[str]:
    """The imports of ``module`` from a layer after its own."""
    own = layer(module)
    if own is None:
        return []
    return [f"{module} imports {target}" for target in sorted(imports(path, module))
            if layer(target) is not None and LAYERS.index(layer(target)) > LAYERS.index(own)]


def family(module: str) -> str | None:
    """The study family (``fit``, ``sweep``...) or shared module (``common``...) of a module."""
    parts = module.split(".")
    return parts[2] if parts[:2] == ["rodfem", "studies"] and len(parts) > 2 else None


def family_faults(path: Path, module: str) -> list[str]:
    """The imports of a study module from a family it may not use."""
    own = family(module)
    if own is None:
        return []
    allowed = SHARED if own in SHARED else {own, ENGINE, *SHARED}
    return [f"{module} imports {target}" for target in sorted(imports(path, module))
            if family(target) is not None and family(target) not in allowed]


def test_each_layer_imports_only_the_layers_before_it():
    wrong = [fault for path, module in modules() for fault in layer_faults(path, module)]
    assert not wrong, wrong


def test_the_studies_never_import_the_api():
    """rodfem.api imports the studies (``rodfem.steady``), never the other way round: what the
    studies read runs with (:mod:`rodfem.output.result`) lies below both."""
    below = LAYERS[: LAYERS.index("studies") + 1]
    wrong = [f"{module} imports {target}" for path, module in modules()
             if layer(module) in below for target in imports(path, module)
             if target == "rodfem.api" or target.startswith("rodfem.api.")]
    assert not wrong, wrong


def test_each_study_family_imports_only_itself_the_shared_modules_and_the_sweep_engine():
    families = {family(module) for _, module in modules()} - {None}
    assert {"sweep", "fit", "sensitivity", "verification", "steady"} | SHARED <= families
    wrong = [fault for path, module in modules() for fault in family_faults(path, module)]
    assert not wrong, wrong


def test_forms_import_nothing_but_ufl():
    for path, module in modules():
        if module.startswith("forms."):
            assert {t.split(".")[0] for t in imports(path, module)} <= {"ufl"}, module


def test_the_layer_check_can_fail(tmp_path):
    """A module of the solver importing the output layer is reported, and a study importing the
    API; a fit importing the sensitivity study, and a shared study module importing the sweep
    engine, are reported too; a fit importing the sweep engine is not."""
    module = tmp_path / "bad.py"
    module.write_text("def f():\n    from rodfem.output import files\n")
    assert layer_faults(module, "rodfem.solver.bad") == [
        "rodfem.solver.bad imports rodfem.output", "rodfem.solver.bad imports rodfem.output.files"]
    module.write_text("def f():\n    from rodfem.api import load\n")
    assert layer_faults(module, "rodfem.studies.sweep.bad")
    module.write_text("import rodfem.studies.sensitivity.indices\n")
    assert family_faults(module, "rodfem.studies.fit.bad")
    module.write_text("from rodfem.studies.sweep import design\n")
    assert family_faults(module, "rodfem.studies.common") and not family_faults(
        module, "rodfem.studies.fit.bad")


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
