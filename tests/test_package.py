"""The package shows what it offers: ``dir(rodfem)`` and ``rodfem.__all__`` list the API that
docs/reference/api.md documents (errors included), every name resolves, ``import rodfem`` stays
light, and ``rodfem --version`` names the version that ``summary.json`` records."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import rodfem
from conftest import serial_only

API_PAGE = Path(__file__).resolve().parent.parent / "docs" / "reference" / "api.md"


def documented() -> set[str]:
    """The names the API reference documents (``.. autofunction:: rodfem.NAME`` and the rest)."""
    text = API_PAGE.read_text(encoding="utf-8")
    return set(re.findall(r"^\.\. auto(?:function|class|exception):: rodfem\.(\w+)", text, re.M))


def test_the_api_page_documents_every_exported_name_and_no_other():
    assert documented() == set(rodfem.__all__) - {"__version__"}


def test_dir_lists_the_api_without_importing_it():
    """Tab completion sees the whole API in a fresh interpreter, and listing it imports nothing
    heavy."""
    code = ("import json, sys, rodfem; names = dir(rodfem); "
            "print(json.dumps([names, 'dolfinx' in sys.modules, 'petsc4py' in sys.modules]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    names, dolfinx, petsc = json.loads(done.stdout)
    assert set(names) >= set(rodfem.__all__) | documented()
    assert names == sorted(names)
    assert (dolfinx, petsc) == (False, False)


def test_every_name_of_all_resolves():
    for name in rodfem.__all__:
        assert getattr(rodfem, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        rodfem.simulat  # noqa: B018


def test_the_errors_are_exported_and_are_the_ones_raised(tmp_path):
    errors = {name for name in rodfem.__all__
              if isinstance(getattr(rodfem, name), type)
              and issubclass(getattr(rodfem, name), Exception)
              and not issubclass(getattr(rodfem, name), Warning)}
    assert errors >= {"SceneError", "OutputError", "RunDirectoryError", "ResultsError",
                      "FieldsError", "FitError", "Interrupted"}
    with pytest.raises(rodfem.RunDirectoryError):
        rodfem.load(tmp_path)
    with pytest.raises(rodfem.FieldsError):
        rodfem.read_fields(tmp_path / "fields.xdmf")
    from rodfem.output import results

    (tmp_path / results.NAME).write_text("not,a,table rodfem wrote\n", encoding="utf-8")
    with pytest.raises(rodfem.ResultsError):
        results.read(tmp_path / results.NAME)


@serial_only
def test_version_is_printed_and_recorded(tmp_path):
    done = subprocess.run([sys.executable, "-m", "rodfem", "--version"], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0 and done.stderr == ""
    line = done.stdout.strip()
    assert re.fullmatch(r"rodfem \d+\.\d+\.\d+( \(dolfinx [\w.]+(, petsc4py [\w.]+)?\))?", line)
    version = line.split()[1]
    assert version == rodfem.__version__
    rodfem.simulate("paper1", {"time.end": 0.01, "mesh.cells": 10}, out=tmp_path / "run")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text(encoding="utf-8"))
    assert summary["versions"]["rodfem"] == version
    import dolfinx

    if "dolfinx" in line:
        assert f"dolfinx {dolfinx.__version__}" in line
        assert summary["versions"]["dolfinx"] == dolfinx.__version__
