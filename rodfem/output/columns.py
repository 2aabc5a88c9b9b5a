"""The recorded quantities: the table of history.h5's columns, each made from the raw rows a
time loop stores (:data:`rodfem.solver.record.RAW`, then the scene's readings). Importing this
module needs NumPy only (the figures read it).

Each column of ``history.h5`` is computed from a block of raw rows by its ``compute``, given the
run's :class:`Context` (Δt, the obstacle of :mod:`rodfem.model.contact`, k). The default columns
(:data:`COLUMNS`) are always recorded; a scene adds the quantities of :data:`QUANTITIES` it names
in ``output.history`` and, for each point x of ``output.probes``, the columns of
:data:`PROBES` (:func:`for_scene`). A column that needs a field's value at a point of the rod
names it in ``reads``: a *reading* ``(field, x)``, which the time loop evaluates at every step
after the raw slots (:meth:`rodfem.output.pointwise.Pointwise.reading`). No other module writes a
column index.

The model is nondimensional (the paper's scaling): lengths in units of the rod's length, times,
temperatures and stresses in the units that make its coefficients 1 (docs/outputs.md).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from rodfem.scene.measures import point  # noqa: F401 (re-exported)
from rodfem.solver.record import RAW, RAW_INDEX  # noqa: F401 (re-exported)


@dataclasses.dataclass(frozen=True)
class Context:
    """What a column's ``compute`` may use besides the raw rows."""

    dt: float
    obstacle: object
    exchange: object  # the heat-exchange law (rodfem.model.exchange)


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of history.h5: its name, meaning, and how it is computed from the raw rows
    (a dict of slot name → array, readings named ``field@x``) and the :class:`Context`."""

    name: str
    meaning: str
    compute: Callable[[dict[str, np.ndarray], Context], np.ndarray]
    integer: bool = False
    reads: tuple[tuple[str, float], ...] = ()  # the readings (field, x) it needs


def reading_name(field: str, x: float) -> str:
    return f"{field}@{point(x)}"


def _sigma_1(raw, c):
    if c.obstacle.rigid:  # σ(1) is the multiplier
        return -raw["pressure"] + 0.0  # no −0 in the file
    return c.obstacle.stresses(raw["u_1"])


def _force(raw, c):
    """The obstacle's force on the rod, p = −σ(1) = φ'(u(1)) ≥ 0."""
    return -_sigma_1(raw, c) + 0.0


COLUMNS = (
    Column("t", "time tⁿ = nΔt (adaptive steps: the sum of the steps so far)",
           lambda raw, c: raw["t"] if "t" in raw else raw["n"] * c.dt),
    Column("u_1", "displacement u(1, tⁿ) of the end at the obstacle",
           lambda raw, c: raw["u_1"]),
    Column("u_half", "displacement u(0.5, tⁿ) at the middle of the rod",
           lambda raw, c: raw["u_half"]),
    Column("ut_1", "velocity u_t(1, tⁿ): δⁿ(1) = (Uⁿ(1) − Uⁿ⁻¹(1))/Δt in the paper's scheme, "
           "Vⁿ(1) in Crank–Nicolson's", lambda raw, c: raw["d_1"] / c.dt),
    Column("sigma_1", "contact stress σ(1, tⁿ) = −φ'(u(1)) of the obstacle's law (the rigid "
           "obstacle: −p, its multiplier)", _sigma_1),
    Column("energy", "the discrete energy Êⁿ of Remark 4.4, with the obstacle's energy φ(u(1))",
           lambda raw, c: raw["bulk_energy"] + c.obstacle.energies(raw["u_1"])),
    Column("iterations", "iterations of the method at the step (picard, newton; direct: 1)",
           lambda raw, c: raw["iterations"], integer=True),
)
NAMES = tuple(column.name for column in COLUMNS)
INDEX = {name: i for i, name in enumerate(NAMES)}

# What output.history may add (rodfem.scene.schema.QUANTITIES names them).
QUANTITIES = (
    Column("theta_1", "temperature θ(1, tⁿ) at the obstacle (physical, not the shifted Θ)",
           lambda raw, c: raw[reading_name("theta", 1.0)], reads=(("theta", 1.0),)),
    Column("heat_flux_1", "heat flux −θ_x(1, tⁿ) = h (θ(1, tⁿ) − θ_O) from the rod into the "
           "obstacle, h the exchange law's coefficient at u(1, tⁿ) and the contact force",
           lambda raw, c: c.exchange.flux(raw[reading_name("theta", 1.0)], raw["u_1"],
                                          _force(raw, c)), reads=(("theta", 1.0),)),
    Column("contact_force", "the obstacle's force p on the rod, p = φ'(u(1)) ≥ 0 = −σ(1, tⁿ) "
           "(the rigid obstacle: its multiplier)", _force),
    Column("contact", "1 while the obstacle pushes on the rod (p > 0), else 0",
           lambda raw, c: (_force(raw, c) > 0.0).astype(float), integer=True),
    Column("penetration", "u(1, tⁿ) − g, signed: how far the end is past the obstacle's face "
           "(negative: the gap still open; the rigid obstacle: ≤ 0 to round-off)",
           lambda raw, c: raw["u_1"] - c.obstacle.gap),
)


# The columns of a run with adaptive steps (time.adaptive), after the default ones.
ADAPTIVE = (
    Column("dt", "the step Δtⁿ = tⁿ − tⁿ⁻¹ (0 at n = 0)", lambda raw, c: raw["dt"]),
    Column("event", "1 where the step ends where contact begins or ends, else 0",
           lambda raw, c: raw["event"], integer=True),
)


def _probe_sigma(x: float) -> Column:
    if x == 1.0:  # the boundary condition σ(1) = −φ'(u(1)), as sigma_1
        return Column(reading_name("sigma", x), "", _sigma_1)
    name = reading_name("sigma", x)
    return Column(name, "", lambda raw, c: raw[name], reads=(("sigma", x),))


def _probe(field: str) -> Callable[[float], Column]:
    def column(x: float) -> Column:
        name = reading_name(field, x)
        return Column(name, "", lambda raw, c: raw[name], reads=((field, x),))
    return column


# The columns of each point x of output.probes: (name pattern, meaning, the column at x).
PROBES = (
    ("u@x", "displacement u(x, tⁿ), interpolated", _probe("u")),
    ("theta@x", "temperature θ(x, tⁿ) (physical), interpolated", _probe("theta")),
    ("sigma@x", "stress σ(x, tⁿ) = u_x + ζ u_xt − aθ: its value on the cell holding x, at a node "
     "the mean of its two cells, at x = 1 the obstacle's −φ'(u(1)) as sigma_1", _probe_sigma),
)


def for_scene(scene) -> tuple[Column, ...]:
    """The columns of a scene's history.h5: the default ones, the quantities its
    output.history names, per probe x the columns of :data:`PROBES`, then the columns its
    declared measures name that are none of these (a measure's column is recorded)."""
    chosen = {column.name: column for column in QUANTITIES}
    adaptive = ADAPTIVE if scene["time.adaptive"] else ()
    columns = (*COLUMNS, *adaptive, *(chosen[name] for name in scene["output.history"]),
               *(make(x) for x in scene["output.probes"] for _, _, make in PROBES))
    have = {column.name for column in columns}
    wanted = dict.fromkeys(m.column for m in scene.measures if m.column not in have)
    return (*columns, *named(wanted))


def named(names) -> tuple[Column, ...]:
    """The columns of a history.h5 header (KeyError for a name rodfem does not write)."""
    table = {column.name: column for column in (*COLUMNS, *ADAPTIVE, *QUANTITIES)}
    makers = {pattern.split("@")[0]: make for pattern, _, make in PROBES}

    def column(name: str) -> Column:
        if name in table:
            return table[name]
        field, _, x = name.partition("@")
        if field in makers and x:
            made = makers[field](float(x))
            if made.name == name:
                return made
        raise KeyError(name)

    return tuple(column(name) for name in names)


def readings(columns) -> tuple[tuple[str, float], ...]:
    """The readings (field, x) that the columns need, each once, in order."""
    return tuple(dict.fromkeys(r for column in columns for r in column.reads))


def columns_of(raw_rows: np.ndarray, context: Context, columns=COLUMNS,
               reads: tuple[tuple[str, float], ...] = (),
               clock: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """The history.h5 rows of a block of raw rows (the raw slots, then the readings
    ``reads``); ``clock``: the times of adaptive steps, their sizes and events (t, dt, event)."""
    raw = {slot.name: raw_rows[:, i] for i, slot in enumerate(RAW)}
    raw.update({reading_name(*r): raw_rows[:, len(RAW) + i] for i, r in enumerate(reads)})
    raw.update(clock or {})
    return np.column_stack([column.compute(raw, context) for column in columns])
