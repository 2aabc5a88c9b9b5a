"""The `picard` method's time loop in compiled code: many steps in one C call.

An iteration of :class:`rodfem.solver.methods.picard.PicardMethod` is two mat-vecs, two
triangular solves, two norms and a few vector updates: about eight PETSc calls of a microsecond
each, which at a few hundred cells is nearly all of it. :class:`PicardKernel` reads the operators
off a method and its history once and runs ``steps`` steps of exactly that algebra in
``picard.c``:

    [h; m] = R s + b                  (s = [Θⁿ⁻¹; Dⁿ⁻¹; Uⁿ⁻¹], ``method.R``, ``method.b``), once
    ΔΘ⁰ = 0, ΔU⁰ = 0, c = Uⁿ⁻¹(1)
    for l = 1, 2, …, max_iterations:
        p   = contact force of c + ΔU^{l−1}(1)  (the law at the time scheme's rule: contact.h)
        ΔΘˡ = A_h⁻¹ (h + N_ΔU ΔU^{l−1})          (``method.heat.A``, ``heat.N["du"]``)
              − φ v                             (a variable heat exchange, exchange.h: φ of
                                                 q at c + ΔU^{l−1}(1) and p, v = A_h⁻¹ e,
                                                 ``method.unit_response()``)
        ΔUˡ = A_m⁻¹ (m + N_ΔΘ ΔΘˡ − p e)         (``method.momentum.A``, ``N["dtheta"]``,
                                                 ``method.contact_load``)
        change = max(‖ΔΘˡ − ΔΘ^{l−1}‖∞, ‖ΔUˡ − ΔU^{l−1}‖∞); stop if change < tol (``method.tol``)
        non-finite values: stop at once (failed)
    p = contact force of c + ΔU(1) (``method.pressure``)
    Θⁿ = Θⁿ⁻¹ + ΔΘ, Uⁿ⁻¹ → u_prev, Uⁿ = Uⁿ⁻¹ + ΔU, Dⁿ = ΔU (Crank–Nicolson with inertia:
    2ΔU − Dⁿ⁻¹, as (ΔU − Dⁿ⁻¹) + ΔU)

and for each new state the raw row of :data:`rodfem.solver.record.RAW` (record.h).

A redistributed mass changes only the end x = 1, as in :mod:`.direct`: without its mass,
Dⁿ(1) = Uⁿ(1) − Uⁿ⁻¹(1). An eliminated end (:mod:`rodfem.solver.methods.massless`) needs a = 0,
which this loop leaves to the PETSc loop.

**Tridiagonal in node order.** Every operator couples only neighbouring nodes (anything wider is
refused). A_h is factored L U and A_m U L, without pivoting (the operators are SPD up to the
clamped row x = 0), once, in ``pk_factor``, normalised so that every recurrence is one
multiplication and one subtraction per node. An iteration is then two fused passes over the
nodes: descending, A_h's back substitution and, one node behind, the momentum right-hand side and
A_m's elimination; ascending, A_m's substitution and, one node behind, the next iteration's heat
right-hand side and A_h's elimination. The coefficient rows [R | b], [N_ΔU | N_ΔΘ | e] and
[E | 2w] are tables of their distinct rows with a class per node
(:func:`rodfem.solver.compiled.loop.classes`; bit for bit the same results, ``compress=False``
keeps a row per node for the tests); the factors stay per node, grouped as the sweeps read them.
What each choice saves is measured in docs/performance.md.

**Round-off.** The mat-vecs sum in the CSR's column order, as PETSc's MatMultAdd does; the
solves round differently from PETSc's LU. The difference from PETSc's loop adds up about linearly
in the steps (``tests/test_picard_kernel.py`` bounds it by 64 eps per step). A step whose change
lies within round-off of ``tol`` could take one iteration more or less in the two.

**What it does not do.** Sources, a = 0 (``picard.py`` iterates only the contact force there)
and the rigid obstacle are refused at construction (ValueError); the paper scheme's first step
with inertia is the caller's ``method.advance()``.

**Failure.** If a step does not converge, :meth:`PicardKernel.advance` leaves the method at the
last step that did, with the rows of the steps done in ``rows[:done]``, sets ``kernel.done`` (and
``error.done``) to that count, and raises :class:`rodfem.solver.errors.PicardNotConverged` with
the step, time, increment, iterations and deepest iterate's U(1) that ``PicardMethod._step`` gives.

**Building.** As :mod:`.direct`'s, by :mod:`.build`, under its own module name.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rodfem.solver.compiled.build import CompiledSource
from rodfem.solver.compiled.loop import CompiledLoop, check_library, classes, energy_tables
from rodfem.solver.errors import PicardNotConverged
from rodfem.solver.record import RAW_INDEX

SOURCE = Path(__file__).with_name("picard.c")

_source = CompiledSource(SOURCE, "_rodfem_picard_kernel_", "Picard kernel", check_library)
_library = _source.library
available = _source.available
unavailable_reason = _source.unavailable_reason


def _entries(A) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(row of each entry, column, value) of a PETSc AIJ matrix."""
    ia, ja, a = A.getValuesCSR()
    rows = np.repeat(np.arange(len(ia) - 1), np.diff(ia))
    return rows, np.asarray(ja, dtype=np.int64), np.asarray(a, dtype=float)


def _tridiagonal(A, n: int, row_block: int = 0, col_block: int = 0) -> np.ndarray:
    """The block (row_block, col_block) of n × n of a PETSc AIJ matrix (or of its
    :func:`_entries`) as its three diagonals, an n × 3 array (i − 1, i, i + 1 per row; 0 outside
    the matrix). ValueError if it couples more than neighbours."""
    rows, cols, values = A if isinstance(A, tuple) else _entries(A)
    mine = (rows // n == row_block) & (cols // n == col_block)
    r, c, v = rows[mine] % n, cols[mine] % n, values[mine]
    offset = c - r
    if np.any(np.abs(offset[v != 0.0]) > 1):
        raise ValueError("the Picard kernel needs tridiagonal operators in node order")
    near = np.abs(offset) <= 1
    out = np.zeros((n, 3))
    out[r[near], offset[near] + 1] = v[near]
    return out


def _energy(history, n: int) -> np.ndarray:
    """[E | 2w] by node: E's three diagonal blocks as diagonals and 2w (ValueError if E is not
    block diagonal)."""
    E = _entries(history.energy.E)
    rows, cols, values = E
    if np.any((rows // n != cols // n) & (values != 0.0)):
        raise ValueError("the Picard kernel needs a block-diagonal energy matrix")
    energy = np.zeros((n, 12))
    for k in range(3):
        energy[:, 3 * k:3 * k + 3] = _tridiagonal(E, n, k, k)
        energy[:, 9 + k] = history.energy.two_w.array_r[k * n:(k + 1) * n]
    return energy


class PicardKernel(CompiledLoop):
    """Steps of a :class:`~rodfem.solver.methods.picard.PicardMethod` in compiled code (the
    module's docstring).

    ``PicardKernel(method, history)`` reads the operators once; :meth:`advance` then does steps
    exactly as ``method.advance()`` followed by ``history.record(method)``, from any n ≥ 1 (n ≥ 0
    where the first step is not special: Crank–Nicolson, or no inertia), updating the method in
    place and writing history rows. ``compress=False``: a coefficient row per node instead of
    tables of the distinct rows (the same results bit for bit); ``self.classes`` gives the
    tables' sizes."""

    what = "compiled Picard loop"

    def __init__(self, method, history, compress: bool = True):
        if method.name != "picard":
            raise ValueError(f"the Picard kernel runs a PicardMethod, not {method.name!r}")
        if not method.coupled:
            raise ValueError("the compiled Picard kernel does not do a = 0 (picard.py's "
                             "uncoupled iteration)")
        if method.law.rigid:
            raise ValueError("the compiled Picard kernel does only the elastic obstacle")
        super().__init__(method, history)
        self._ffi, self._lib = ffi, lib = _library()
        n = self.n

        fixed = np.zeros((n, 20))  # a row per node; tabled by _classes below
        R = _entries(method.R)
        for c in range(2):
            for k in range(3):
                fixed[:, 10 * c + 3 * k:10 * c + 3 * k + 3] = _tridiagonal(R, n, c, k)
            fixed[:, 10 * c + 9] = method.b.array_r[c * n:(c + 1) * n]
        heat, momentum = np.zeros((n, 3)), np.zeros((n, 3))  # (p, q, cp) per node
        for A, out, ul in ((method.heat.A, heat, 0), (method.momentum.A, momentum, 1)):
            tri = np.ascontiguousarray(_tridiagonal(A, n).T)
            info = lib.pk_factor(n, *(ffi.cast("double *", ffi.from_buffer(tri[t]))
                                      for t in range(3)), ul,
                                 ffi.cast("double *", ffi.from_buffer(out)), out.shape[1])
            if info:
                raise ValueError(f"zero pivot at node {info - 1} factoring without pivoting")
        coupling = np.zeros((n, 8))
        coupling[:, 0:3] = _tridiagonal(method.heat.N["du"], n)
        coupling[:, 3:6] = _tridiagonal(method.momentum.N["dtheta"], n)
        coupling[:, 6] = method.contact_load.array_r
        blocks = [int(np.any(fixed[:, 10 * c + 3 * k:10 * c + 3 * k + 3] != 0.0))
                  for c in range(2) for k in range(3)]
        self._arrays, self.classes = {}, {}
        energy = energy_tables(history, ("picard", compress),
                               lambda: classes({"energy": _energy(history, n)}, compress))
        for name, table in (("fixed", fixed), ("coupling", coupling), ("energy", None)):
            cls, tables = classes({name: table}, compress) if table is not None else energy
            self._arrays[name + "_class"], self._arrays[name] = cls, tables[name]
            self.classes[name] = tables[name].shape[0]
        self._arrays["descending"] = np.ascontiguousarray(
            np.column_stack([heat[:, 2], momentum[:, 0], momentum[:, 1]]))
        self._arrays["ascending"] = np.ascontiguousarray(
            np.column_stack([momentum[:, 2], heat[:, 0], heat[:, 1]]))
        self._arrays["work"] = np.zeros(10 * (n + 2))

        P = ffi.new("pk_problem *")
        P.n, P.max_iterations = n, int(method.max_iterations)
        P.tol = float(method.tol)
        self.set_obstacle(P.obstacle, method)
        self.set_end(P.end, lib)
        self.set_exchange(P.exchange, method)
        if method.exchange.variable:  # v = A_h⁻¹ e, the PETSc loop's
            self._arrays["unit_response"] = np.ascontiguousarray(
                method.unit_response().array_r, dtype=float)
        P.blocks = blocks
        P.midpoint_inertia = self.velocity_update
        for field, array in self._arrays.items():
            kind = "int" if field.endswith("_class") else "double"
            assert array.flags.c_contiguous and array.dtype == (np.intc if kind == "int"
                                                                else np.float64)
            setattr(P, field, ffi.cast(kind + " *", ffi.from_buffer(array)))
        i, wi, j, wj = history.half  # indices into the state: U's block
        if not (2 * n <= min(i, j) and max(i, j) < 3 * n):
            raise ValueError("the Picard kernel reads U(0.5) off U's block of the state")
        P.half_i, P.half_j, P.half_wi, P.half_wj = i - 2 * n, j - 2 * n, wi, wj
        self.set_record(P, history)
        self._problem = P
        self._pressure = ffi.new("double *")
        self._iterations = ffi.new("int *")
        self._increment = ffi.new("double *")
        self._last_u_1 = ffi.new("double *")

    def _run(self, steps: int, rows: np.ndarray):
        method = self.method
        self._pressure[0] = method.pressure
        self._iterations[0] = method.iterations
        done = int(self._lib.pk_advance(
            self._problem, self.pointer(method.values), self.pointer(method.u_prev.array),
            method.n, steps, self.pointer(rows), self._pressure, self._iterations,
            self._increment, self._last_u_1))
        iterations = (int(rows[done - 1, RAW_INDEX["iterations"]]) if done
                      else method.iterations)
        error = None
        if done < steps:
            step = method.n + done + 1
            error = PicardNotConverged(step, step * method.dt, float(self._increment[0]),
                                       int(self._iterations[0]), float(self._last_u_1[0]))
        return done, float(self._pressure[0]), iterations, error
