"""GetFEM's figures on the impact benchmark: its singular dynamic mass (Renard) with Newmark
β = 1/4, γ = 1/2 and Signorini's condition imposed at the end of each step, as GetFEM 5.4's
``demo_dynamic_contact_1D`` does it (``mass_matrix_type = 2``, ``version = 0``), written again for
rodfem's geometry and measure: the bar on (0, 1) clamped at x = 0, the wall at x = 1, u₀ = −x/2 at
rest, and the L¹ error of u(1, ·) over the steps (Σₙ Δt |Uⁿ(1) − u(1, tⁿ)|, as
:func:`rodfem.model.impact.errors` measures it) to T = 3.

GetFEM assembles the P1 mass and stiffness; the singular dynamic mass then takes the contact
node's row and column out of the consistent mass and gives its neighbour 7h/12 (GetFEM's
choice). The step is GetFEM's: a predictor without contact, and where it crosses the wall the
same system again with U(1) = 0, the force read off its residual.

    .venv/bin/python benchmarks/getfem_impact.py [--h 1e-2 2e-3 1e-3 5e-4] [--ratio 1 0.5]

Runs only where ``import getfem`` works (GetFEM's Python interface, Debian's python3-getfem,
which rodfem's environment sees through the system's site-packages). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import subprocess

import getfem as gf
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from mpi4py import MPI

from rodfem.model import impact
from rodfem.studies.common import machine


def matrices(cells: int) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """GetFEM's P1 consistent mass and stiffness on (0, 1), nodes ordered by x."""
    mesh = gf.Mesh("cartesian", np.linspace(0.0, 1.0, cells + 1))
    mf = gf.MeshFem(mesh, 1)
    mf.set_classical_fem(1)
    mim = gf.MeshIm(mesh, 4)
    order = np.argsort(mf.basic_dof_nodes()[0])

    def scipy(matrix) -> sp.csr_matrix:
        indptr, indices = matrix.csc_ind()
        csc = sp.csc_matrix((matrix.csc_val(), indices, indptr), shape=matrix.size())
        return csc.tocsr()[order][:, order]

    return scipy(gf.asm_mass_matrix(mim, mf)), scipy(gf.asm_laplacian(mim, mf, mf,
                                                                      np.ones(mf.nbdof())))


def run(cells: int, dt: float, end: float = 3.0, beta: float = 0.25,
        gamma: float = 0.5) -> dict[str, float]:
    """The singular dynamic mass with Newmark (β, γ) and Signorini at x = 1: the L¹ error of
    u(1, ·), as rodfem measures it (``u1_l1``) and by the trapezoidal rule in time
    (``trapezoid``, which GetFEM's figures quoted in docs/time-schemes.md use; never larger),
    and the energy at ``end``."""
    h = 1.0 / cells
    M, K = matrices(cells)
    M, K = M.tolil(), K.tolil()
    last = cells  # the contact node x = 1; x = 0 (node 0) is clamped
    M[last, :] = 0.0
    M[:, last] = 0.0
    M[last - 1, last - 1] = 7.0 * h / 12.0  # GetFEM's singular dynamic mass
    for A in (M, K):  # the clamp: identity row and column at x = 0
        A[0, :] = 0.0
        A[:, 0] = 0.0
        A[0, 0] = 1.0
    M, K = M.tocsr(), K.tocsr()
    M_solve = M.tolil()
    M_solve[last, last] = 1.0  # for the velocity: the end's is set from its displacement
    M_solve = spla.splu(M_solve.tocsc())
    x = np.linspace(0.0, 1.0, cells + 1)
    U0 = -x / 2.0
    V0 = np.zeros_like(x)
    MV0 = M @ V0
    MA0 = -(K @ U0)
    MA0[last] = 0.0
    KN = (M + beta * dt * dt * K).tocsc()
    free = spla.splu(KN)
    KNC = KN.tolil()
    KNC[last, :] = 0.0
    KNC[last, last] = 1.0
    contact = spla.splu(KNC.tocsc())
    steps = round(end / dt)
    u1 = np.empty(steps)
    for n in range(steps):
        B = M @ U0 + dt * MV0 + dt * dt * (1.0 - 2.0 * beta) / 2.0 * MA0
        B[0] = 0.0
        U1 = free.solve(B)
        Fc = np.zeros_like(B)
        if U1[last] > 0.0:  # across the wall: the same step with U(1) = 0
            B2 = B.copy()
            B2[last] = 0.0
            U1 = contact.solve(B2)
            Fc = (KN @ U1 - B) / (beta * dt * dt)
        MA1 = Fc - K @ U1
        MA1[0] = 0.0
        MV1 = MV0 + dt * ((1.0 - gamma) * MA0 + gamma * MA1)
        V1 = M_solve.solve(MV1)
        V1[0] = 0.0
        V1[last] = (U1[last] - U0[last]) / dt
        U0, V0, MV0, MA0 = U1, V1, MV1, MA1
        u1[n] = U0[last]
    error = np.abs(u1 - impact.end_displacement(dt * np.arange(1, steps + 1)))  # 0 at t = 0
    return {"u1_l1": float(dt * error.sum()),
            "trapezoid": float(dt * (error.sum() - error[-1] / 2)),
            "energy": float(0.5 * (V0 @ (M @ V0) + U0 @ (K @ U0)))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[1e-2, 2e-3, 1e-3, 5e-4])
    parser.add_argument("--ratio", type=float, nargs="+", default=[1.0, 0.5],
                        help="Δt/h of each row")
    args = parser.parse_args()
    print("| GetFEM, singular dynamic mass, Newmark ¼, ½: L¹ of u(1, ·), Σ Δt (trapezoid) | "
          + " | ".join(f"h = {h:g}" for h in args.h) + " |")
    print("|---|" + "---|" * len(args.h))
    for ratio in args.ratio:
        rows = [run(round(1.0 / h), ratio / round(1.0 / h)) for h in args.h]
        print(f"| Δt = {ratio:g} h | " + " | ".join(
            f"{r['u1_l1']:.3g} ({r['trapezoid']:.3g})" for r in rows) + " |")
    m = machine(MPI.COMM_SELF)
    print(f"\n{m['cpu']}, {m['cpus']} cores; GetFEM {version()}, NumPy {m['numpy']}")


def version() -> str:
    """GetFEM's version, from the system's package (its Python module does not say)."""
    try:
        return subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "python3-getfem"],
                              capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "(version unknown)"


if __name__ == "__main__":
    main()
