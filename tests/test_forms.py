"""forms/ is pure UFL: it imports nothing but ufl, and ffcx compiles it ahead of time."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import serial_only

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("path", sorted((ROOT / "forms").glob("*.py")), ids=lambda p: p.name)
def test_forms_import_only_ufl(path):
    imported = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            imported += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            imported.append(node.module or "")
    assert all(name == "ufl" or name.startswith("ufl.") for name in imported), imported


@serial_only
def test_ffcx_compiles_the_forms_ahead_of_time(tmp_path):
    import ffcx.codegeneration

    source = ROOT / "tests" / "ufl" / "copetti_p1.py"
    subprocess.run([sys.executable, "-m", "ffcx", str(source), "-o", str(tmp_path)], check=True,
                   cwd=ROOT, capture_output=True)
    c_file, h_file = tmp_path / "copetti_p1.c", tmp_path / "copetti_p1.h"
    assert c_file.is_file() and h_file.is_file()
    code = c_file.read_text()
    assert code.count("tabulate_tensor") >= 5  # one kernel per integral at least
    # The generated C compiles.
    subprocess.run(["cc", "-c", "-std=c99", "-O1", f"-I{ffcx.codegeneration.get_include_path()}",
                    "-I", str(tmp_path), str(c_file), "-o", str(tmp_path / "copetti_p1.o")],
                   check=True, capture_output=True)
    assert (tmp_path / "copetti_p1.o").stat().st_size > 0
