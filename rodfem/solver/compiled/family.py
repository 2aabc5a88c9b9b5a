"""Compiled loops for any step size, made in microseconds: an adaptive run's new sizes.

An adaptive run (:mod:`rodfem.solver.adaptive.stepper`) takes steps of many sizes h from one
state, the home method's (the run's :class:`~rodfem.solver.methods.base.Method`, of Δt₀). The
operators of a step are Laurent polynomials in its size, whose parts are read once per run
(:mod:`.laurent`); :class:`StepFamily` holds them in the compiled loops' own layouts, and
:meth:`StepFamily.loop` forms the loop of a size h from them: the coefficient tables combined at
λ = Δt₀/h and the step's operator factored. No dolfinx, UFL or PETSc work, no form, no
assembly.

The loop it returns (:class:`FamilyDirect`, :class:`FamilyPicard`) is a
:class:`~.direct.DirectKernel` or :class:`~.picard.PicardKernel` **bound to the home method**: its
``advance(steps, rows)`` steps the home method's own arrays (``values``, ``u_prev``, ``n``,
``pressure``, ``iterations``) with the operators of a step h, the state's D being that of a step h
(the caller scales it: D = h V). Its C problem (``loop._problem``, an ``rk_problem *`` or
``pk_problem *``) is complete on its own: the energy and record tables are the home loop's (the
history's energy is the home step's, as for any loop of the run), its work arrays its own.

What differs from a loop made by ``make_method(disc, h)`` and ``compiled_loop`` is the operators'
rounding only (:mod:`.laurent`: the parts recombined against the forms assembled at h), and the
classes of the coefficient rows: computed once, from the parts stacked, so a node's class is the
same at every h (two nodes share one where all their parts are equal bit for bit). A size is
formed by one C call, ``rk_form`` (direct_form.h: the banded LU of LAPACK's ``dgbtf2``, which
``dgbtrf`` runs for bands this narrow) or ``pk_form`` (picard_form.h: ``pk_factor``): 7–25 µs on
paper1, against 3–4 ms for a method made for the size (benchmarks/bench_step_family.py).

**The paper scheme's first step** (U¹ = U⁰ + h P u₁, Θ¹ from (3.1)) is :meth:`first_step` of the
loop (its heat solve at h in NumPy), for an adaptive run's first step and its halves.

:func:`.families.step_family` makes none (None: the caller makes methods as before) where the home method
has no compiled loop (Newton, sources, ``RODFEM_KERNEL=0``, an eliminated end with the power
law: whatever :func:`~rodfem.solver.compiled.compiled_loop` refuses) and where the parts fail
their check. On several ranks every rank reads the same parts (the node-ordered operators are the
serial ones: in 1D a node's entry sums two cells' terms, in either order the same) and forms the
same loops, as the state is every rank's (the loops are rank-local).
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.compiled.laurent import LaurentParts, combine, read_parts
from rodfem.solver.compiled.loop import classes


def tridiagonal_parts(parts: LaurentParts, key: str, n: int) -> np.ndarray:
    """The parts of a node-ordered tridiagonal operator as 3 × n × 3 (part, row, i − 1 .. i + 1).
    ValueError if it couples more than neighbours."""
    rows, cols, values = parts.matrix(key)
    offset = cols - rows
    if np.any(np.abs(offset[np.any(values != 0.0, axis=0)]) > 1):
        raise ValueError(f"{key} is not tridiagonal in node order")
    near = np.abs(offset) <= 1
    out = np.zeros((3, n, 3))
    out[:, rows[near], offset[near] + 1] = values[:, near]
    return out


def tabled(columns: dict[str, np.ndarray]):
    """Classes of the nodes by all parts of their rows: ``columns`` of 3 × n × m parts. Returns
    (class per node, tables of 3 × classes × m)."""
    flat = {f"{k}|{p}": v[p] for k, v in columns.items() for p in range(3)}
    cls, tables = classes(flat)
    return cls, {k: np.stack([tables[f"{k}|{p}"] for p in range(3)]) for k in columns}


class StepFamily:
    """The loops of any step size of one run (the module's docstring). Subclasses form a size's
    arrays in :meth:`_form`."""

    def __init__(self, home, history, kernel, parts: LaurentParts):
        self.home, self.history, self.kernel, self.parts = home, history, kernel, parts
        self.dt0 = home.dt
        self.made = 0  # loops formed

    def loop(self, h: float):
        """The compiled loop of a step h, bound to the home method."""
        loop = object.__new__(self.bound)  # the home loop's attributes, its own arrays
        loop.__dict__.update(self.kernel.__dict__)
        loop.family, loop.h = self, float(h)
        self._form(loop, self.dt0 / float(h))
        self.made += 1
        return loop

    @property
    def forms_in_c(self) -> bool:
        """Whether a size is formed by one C call alone (``F``, ``template``, ``struct_size``
        and ``size`` of the layout): compiled adaptive steps then form an event's tries
        themselves (:mod:`rodfem.solver.adaptive.compiled`)."""
        return True

    def _form(self, loop, lam: float) -> None:
        raise NotImplementedError


class Bound:
    """What the bound loops add to a compiled loop: the time of a failed step is that of a step
    h, and the paper scheme's first step (:meth:`first_step`)."""

    family: StepFamily
    h: float

    def _run(self, steps: int, rows: np.ndarray):
        method = self.method
        dt, method.dt = method.dt, self.h  # the failed step's time (the errors read method.dt)
        try:
            return super()._run(steps, rows)
        finally:
            method.dt = dt

    def first_step(self) -> None:
        """The paper scheme's first step U¹ = U⁰ + h P u₁ of the home method (its D the step's:
        h P u₁), Θ¹ from (3.1) at h: :meth:`Method._first_step` with the operators of h."""
        from rodfem.solver.compiled.direct import solve_tridiagonal

        method, family = self.method, self.family
        lam, n, last = family.dt0 / self.h, self.n, method.last
        values = method.values
        theta, d, u = values[:n], values[n:2 * n], values[2 * n:]
        heat = family.first_step_operators(lam)
        rhs = heat["theta_prev"] @ theta + heat["b"] + heat["du"] @ d
        banded = heat["A"]
        dtheta = solve_tridiagonal(banded, rhs)
        if method.exchange.variable:  # Method._first_exchange, at h
            q = method.exchange.extra(float(u[last] + d[last]), 0.0)
            if q != 0.0:
                v = solve_tridiagonal(banded, -heat["e"])
                T = (float(theta[last]) + method.offset) + dtheta[last]
                dtheta += q * T / (1.0 - q * v[last]) * v
        theta += dtheta
        u_prev = method.u_prev.array
        u_prev[:] = u
        u += d
        if method.disc.redistributed:
            values[2 * n - 1] = values[3 * n - 1] - u_prev[last]
        for vector in (method.state, method.theta, method.du, method.u, method.u_prev):
            vector.stateIncrease()
        method.iterations = 0
        method.pressure = 0.0
        method.n += 1


def heat_first_step(parts: LaurentParts, n: int):
    """The heat operators of the first step as functions of λ: A_h banded (solve_banded's 3 × n),
    N_Θ' and N_U as tridiagonal products (:class:`Tridiagonal`), b_h and e."""
    A = tridiagonal_parts(parts, "heat.A", n)
    tridiagonal = {name: tridiagonal_parts(parts, f"heat.{name}", n)
                   for name in ("theta_prev", "du")}

    def at(lam: float) -> dict:
        tri = combine(A, lam)  # n × 3: (i − 1, i, i + 1) per row
        banded = np.zeros((3, n))
        banded[0, 1:] = tri[:-1, 2]
        banded[1, :] = tri[:, 1]
        banded[2, :-1] = tri[1:, 0]
        out = {"A": banded, "b": combine(parts.vector("heat.b"), lam),
               "e": combine(parts.vector("contact.e"), lam)}
        for name, operator in tridiagonal.items():
            out[name] = Tridiagonal(combine(operator, lam))
        return out

    return at


class Tridiagonal:
    """``operator @ x`` of a node-ordered tridiagonal matrix given as n × 3 rows (i − 1, i,
    i + 1): each row's terms summed in column order, as a CSR product does."""

    def __init__(self, rows: np.ndarray):
        self.rows = rows

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        t = self.rows
        y = t[:, 1] * x
        y[1:] = t[1:, 0] * x[:-1] + y[1:]
        y[:-1] += t[:-1, 2] * x[1:]
        return y
