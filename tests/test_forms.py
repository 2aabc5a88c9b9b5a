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

    from rodfem.discrete import compat

    source = ROOT / "tests" / "ufl" / "copetti_p1.py"
    subprocess.run([sys.executable, *compat.ffcx_command(source, tmp_path)], check=True,
                   cwd=ROOT, capture_output=True)
    c_file, h_file = tmp_path / "copetti_p1.c", tmp_path / "copetti_p1.h"
    assert c_file.is_file() and h_file.is_file()
    code = c_file.read_text()
    assert code.count("tabulate_tensor") >= 30  # a kernel per integral of the 32 forms
    # The generated C compiles.
    subprocess.run(["cc", "-c", "-std=c99", "-O1", f"-I{ffcx.codegeneration.get_include_path()}",
                    "-I", str(tmp_path), str(c_file), "-o", str(tmp_path / "copetti_p1.o")],
                   check=True, capture_output=True)
    assert (tmp_path / "copetti_p1.o").stat().st_size > 0


def test_increment_forms_are_the_paper_forms():
    """heat_increment/momentum_increment are (3.1)/(3.2) with Θ = Θ' + ΔΘ, U = U' + ΔU,
    U'' = U' − ΔU': their residuals agree to round-off for arbitrary functions."""
    import numpy as np
    import ufl
    from dolfinx import fem

    import forms.copetti as copetti
    import rodfem.scene
    from rodfem.discrete import compat
    from rodfem.discrete.discretisation import Discretisation

    for mass in ("lumped", "consistent"):
        disc = Discretisation(rodfem.scene.load("paper1", ["mesh.cells=16",
                                                            f"discretisation.mass={mass}"]))
        rng = np.random.default_rng(3)
        f = {}
        for name in ("Θ", "Θ_prev", "U_prev", "ΔΘ", "ΔU", "ΔU_prev"):
            f[name] = disc.function(name)
            compat.petsc_vector(f[name]).array[:] = rng.standard_normal(
                compat.petsc_vector(f[name]).getLocalSize())
            f[name].x.scatter_forward()
        w = ufl.TestFunction(disc.V)
        # Θ = Θ' + ΔΘ, U = U' + ΔU, U'' = U' − ΔU' as UFL expressions of the same functions.
        Θ, U, U2 = f["Θ_prev"] + f["ΔΘ"], f["U_prev"] + f["ΔU"], f["U_prev"] - f["ΔU_prev"]
        args = (0.001, 0.017, 1.0)
        pairs = [
            (copetti.heat(Θ, f["Θ_prev"], U, f["U_prev"], w, *args, disc.dx_m, disc.dx, disc.ds_1),
             copetti.heat_increment(f["ΔΘ"], f["Θ_prev"], f["ΔU"], w, *args, disc.dx_m, disc.dx,
                                    disc.ds_1)),
            (copetti.momentum(U, f["U_prev"], U2, f["Θ"], w, 0.001, 1.3, 0.2, 0.017, 10.0, disc.r,
                              disc.dx_m, disc.dx),
             copetti.momentum_increment(f["ΔU"], f["ΔU_prev"], f["U_prev"], f["Θ"], w, 0.001,
                                        1.3, 0.2, 0.017, 10.0, disc.r, disc.dx_m, disc.dx)),
        ]
        for paper, increment in pairs:
            a = compat.assemble_vector(fem.form(paper)).array
            b = compat.assemble_vector(fem.form(increment)).array
            # The paper's form sums terms as large as its largest entry (|U|/Δt² h) that cancel:
            # round-off of a few ulps of that.
            scale = np.abs(a).max() + np.abs(b).max()
            assert np.abs(a - b).max() <= 64 * np.finfo(float).eps * scale
