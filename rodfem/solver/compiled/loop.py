"""What both compiled time loops share: the base class that a method's loop derives from, the
checks of the C side against the Python tables (the contact laws, the heat-exchange laws, the raw
row), and the tables of distinct coefficient rows.

A loop is built on a :class:`~rodfem.solver.methods.base.Method` and the run's
:class:`~rodfem.output.history.History`, reading only their public attributes: the state
``values`` = [Θ; D; U] (3n), ``u_prev``, ``n``, ``pressure``, ``iterations``, ``last`` (the node
x = 1), ``law``, ``time_scheme``, ``inertia``, ``sources``, ``disc.redistributed`` and
``massless`` (the eliminated end, :mod:`rodfem.solver.methods.massless`: its ``row``,
``constant`` and ``law``); and the history's positions ``u_1``, ``du_1``, ``half`` in the state
and its ``energy``. :meth:`CompiledLoop.advance` does ``steps``
steps as ``method.advance()`` followed by ``history.record(method)`` would, writing raw rows
(:data:`rodfem.solver.record.RAW`).
"""

from __future__ import annotations

import weakref

import numpy as np

from rodfem.model.contact import LinearLaw, PowerLaw, RigidObstacle
from rodfem.model.exchange import ConstantLaw, GapLaw, PressureLaw
from rodfem.solver.record import RAW

# What a loop reads off a history's energy, by the history's Energy: the same for every loop of
# a run (an adaptive run makes one for each step size; its energy rows are the home step's).
_energy_tables: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def energy_tables(history, key: tuple, make):
    """``make()`` of ``history.energy``, once for each ``key``: kept while that energy lives
    (its arrays are read only)."""
    kept = _energy_tables.setdefault(history.energy, {})
    if key not in kept:
        kept[key] = make()
    return kept[key]


def end_supported(method) -> bool:
    """Whether the compiled loops do the method's end x = 1: with its mass, without it, or
    eliminated (:mod:`rodfem.solver.methods.massless`) with the linear law or the rigid obstacle,
    whose series with the last cell is the linear law and whose settled end is in closed form
    (contact.h's rc_end_settle). The power law in series (``InSeries``) is not."""
    end = method.massless
    return end is None or isinstance(end.law, LinearLaw)


def check_library(lib) -> None:
    """The C side agrees with the Python tables: the raw row's slots (record.h against
    rodfem.solver.record.RAW) and the contact laws' codes (contact.h against
    rodfem.model.contact, and exchange.h against rodfem.model.exchange). RuntimeError otherwise."""
    expected = {f"RAW_{slot.name.upper()}": i for i, slot in enumerate(RAW)}
    expected["RAW_SLOTS"] = len(RAW)
    expected.update(RC_LINEAR=LinearLaw.code, RC_POWER=PowerLaw.code, RC_RIGID=RigidObstacle.code)
    if hasattr(lib, "RX_CONSTANT"):  # the loops with the heat exchange (exchange.h)
        expected.update(RX_CONSTANT=ConstantLaw.code, RX_PRESSURE=PressureLaw.code,
                        RX_GAP=GapLaw.code)
    wrong = {name: (getattr(lib, name, None), value) for name, value in expected.items()
             if getattr(lib, name, None) != value}
    if wrong:
        raise RuntimeError(f"the compiled loop disagrees with rodfem's tables: {wrong}")


def classes(columns: dict[str, np.ndarray], compress: bool = True):
    """Nodes classed by their coefficient rows: ``columns`` are n-row arrays (a row per node);
    two nodes share a class if their rows are the same bit for bit in every array (compared as
    int64 words: -0.0 and 0.0 differ, as they may in a product's sign). Returns the class of
    each node (n, int) and the arrays reduced to a row per class, in order of first occurrence.
    ``compress=False``: a class per node, the arrays as they are."""
    columns = {k: np.ascontiguousarray(v, dtype=float) for k, v in columns.items()}
    n = next(iter(columns.values())).shape[0]
    assert all(v.ndim == 2 and v.shape[0] == n for v in columns.values())
    if not compress:
        return np.arange(n, dtype=np.intc), columns
    # a row's bytes as a dict key: classes numbered by first occurrence in one pass (NumPy's
    # unique over rows sorts them as void records: 2–4 times slower)
    bits = np.ascontiguousarray(np.concatenate([v.view(np.int64) for v in columns.values()],
                                               axis=1))
    data, width = bits.tobytes(), bits.shape[1] * 8
    seen: dict[bytes, int] = {}
    first: list[int] = []
    rows = []
    for i in range(n):
        c = seen.setdefault(data[i * width:(i + 1) * width], len(first))
        if c == len(first):
            first.append(i)
        rows.append(c)
    cls = np.array(rows, dtype=np.intc)
    tables = {k: np.ascontiguousarray(v[first]) for k, v in columns.items()}
    assert all(np.array_equal(t[cls].view(np.int64), columns[k].view(np.int64))
               for k, t in tables.items())
    return cls, tables


class CompiledLoop:
    """Steps of a method in compiled code. Subclasses build their C problem in ``__init__``
    (after this one) and do the steps in :meth:`_run`."""

    what = "compiled loop"

    def __init__(self, method, history):
        if any(f is not None for f in method.sources.values()):
            raise ValueError(f"the {self.what} does not do source terms")
        if not end_supported(method):
            raise ValueError(f"the {self.what} does not do the eliminated end with the "
                             f"{method.law.name} law (its series with the last cell has no "
                             "closed form)")
        n = method.values.size // 3
        if method.last != n - 1 or history.u_1 != 3 * n - 1 or history.du_1 != 2 * n - 1:
            raise ValueError(f"the {self.what} needs x = 1 at the last node")
        self.method, self.n = method, n
        self.first_step_special = method.time_scheme.special_first_step(method.inertia)
        self.velocity_update = int(method.time_scheme.velocity_update(method.inertia))
        self.done = 0
        self.width = len(RAW)

    @staticmethod
    def set_obstacle(target, method) -> None:
        """Fill contact.h's rc_obstacle from the law of the method's steps (the obstacle's, or an
        eliminated end's law in series) and time scheme."""
        law = method.law if method.massless is None else method.massless.law
        target.law = law.code
        target.gradient = int(method.time_scheme.gradient_contact and not law.rigid)
        target.gap, target.epsilon, target.exponent = law.gap, law.epsilon, law.exponent

    @staticmethod
    def set_exchange(target, method) -> None:
        """Fill exchange.h's rx_exchange from the method's heat-exchange law, time scheme and
        offset."""
        law = method.exchange
        target.law = law.code
        target.k1 = law.k1
        target.exponent = getattr(law, "exponent", 1.0)
        target.gap, target.length = getattr(law, "gap", 0.0), getattr(law, "length", 1.0)
        target.weight, target.offset = method.time_scheme.weight, method.offset

    def set_end(self, target, lib) -> None:
        """Fill contact.h's rc_end: the end with its mass, without it (a redistributed mass), or
        eliminated, with the row of its free position y on Θ and U of the nodes n − 2, n − 1
        (ValueError if y reads any other entry of the state)."""
        method, n = self.method, self.n
        end = method.massless
        if end is None:
            target.kind = lib.RC_END_MASSLESS if method.disc.redistributed else lib.RC_END_MASS
            return
        entries = [n - 2, n - 1, 3 * n - 2, 3 * n - 1]  # Θ(n−2), Θ(n−1), U(n−2), U(n−1)
        others = np.delete(end.row, entries)
        if n < 2 or np.any(others != 0.0):
            raise ValueError(f"the {self.what} needs the end's free position on Θ and U of the "
                             "last two nodes")
        target.kind = lib.RC_END_ELIMINATED
        target.theta = [float(end.row[n - 2]), float(end.row[n - 1])]
        target.u = [float(end.row[3 * n - 2]), float(end.row[3 * n - 1])]
        target.constant = float(end.constant)
        target.epsilon = float(method.law.epsilon)  # the obstacle's own: 0 for the rigid one

    def set_record(self, target, history) -> None:
        """Fill a problem's ``width`` and ``readings`` (record.h's rr_readings) from the
        history's readings, kept alive on ``self``."""
        self.width = history.width
        target.width = history.width
        readings = history.readings
        if readings is None:
            target.readings.count = target.readings.terms = 0
            return
        self._readings = (np.ascontiguousarray(readings.index, dtype=np.intc),
                          np.ascontiguousarray(readings.weight, dtype=np.float64),
                          np.ascontiguousarray(readings.constant, dtype=np.float64))
        index, weight, constant = self._readings
        target.readings.count, target.readings.terms = readings.count, readings.terms
        target.readings.index = self.pointer(index, "int *")
        target.readings.weight = self.pointer(weight)
        target.readings.constant = self.pointer(constant)

    def checked_steps(self, steps: int, rows: np.ndarray) -> int:
        """The arguments of :meth:`advance`, checked: ``steps`` ≥ 0 as an int, not from the paper
        scheme's special first step, ``rows`` a writable C-contiguous float64 array of at least
        ``steps`` raw rows. ValueError otherwise."""
        steps = int(steps)
        if steps < 0:
            raise ValueError(f"steps = {steps} < 0")
        if steps and self.method.n == 0 and self.first_step_special:
            raise ValueError("the paper scheme's first step (n = 0 -> 1, with inertia) is "
                             "Method._first_step: take it with method.advance()")
        width = self.width
        if steps and not (rows.dtype == np.float64 and rows.ndim == 2 and rows.shape[1] == width
                          and rows.shape[0] >= steps and rows.flags.c_contiguous
                          and rows.flags.writeable):
            raise ValueError("rows must be a writable C-contiguous float64 array of shape "
                             f"(>= {steps}, {width}), not {rows.dtype} {rows.shape}")
        values = self.method.values
        assert values.flags.c_contiguous and values.size == 3 * self.n
        return steps

    def advance(self, steps: int, rows: np.ndarray) -> None:
        """``steps`` steps of the method, from its step n to n + steps, in place (its state
        ``values``, ``u_prev``, ``n``, ``pressure``, ``iterations``); ``rows[k]`` receives the raw
        row of step n + 1 + k (e.g. ``History.reserve(steps)``).

        Sets ``self.done`` to the steps done. If a step fails, the method stays at the last step
        that did not, ``rows[:self.done]`` hold their rows (commit those), and the subclass's
        error is raised (with ``done`` set on it too)."""
        method = self.method
        self.done = 0
        steps = self.checked_steps(steps, rows)
        if steps == 0:
            return
        done, pressure, iterations, error = self._run(steps, rows)
        for vector in (method.state, method.theta, method.du, method.u, method.u_prev):
            vector.stateIncrease()  # written behind PETSc's back: no cached norms
        self.done = done
        method.n += done
        method.pressure = pressure
        method.iterations = iterations
        if error is not None:
            error.done = done
            raise error

    def _run(self, steps: int, rows: np.ndarray):
        """Do the steps; return (steps done, the last p, the last iterations, an error or
        None)."""
        raise NotImplementedError

    def pointer(self, array: np.ndarray, kind: str = "double *"):
        return self._ffi.cast(kind, self._ffi.from_buffer(array))
