"""The reductions of declared measures (:mod:`rodfem.scene.measures`), computed as a run records
its rows, block by block. Importing this module needs NumPy only.

A measure reduces one history column f over a window [t0, t1] (the whole run without one). f is
the piecewise-linear interpolant in t of the rows of every step (whatever rows history.h5 keeps,
``output.history_every``), taken on [t0, t1] ∩ [0, t_reached]:

- ``max``, ``min``, ``max_abs``: over the rows inside the window and f at its ends (the extremes
  of the interpolant);
- ``integral``: ∫ f dt, exact for the interpolant (the trapezoidal rule on the rows, cut at the
  window's ends); ``mean``: the integral over the length covered;
- ``final``: f at the window's end (without a window, or when the run ended before it: at the
  last row reached);
- ``time_of_max_abs``: the first time |f| reaches its largest value;
- ``time_positive``: the length of {t : f(t) > 0} (a crossing between two rows at the
  interpolant's zero).

Each is NaN where the run never reached the window. Sums are summed one step after another
(``np.cumsum`` is sequential), and a block's first step is taken from the last row of the block
before, kept in the state: the values do not depend on how the rows come in blocks, so that a
run stopped and resumed from its checkpoint (which keeps the state) gives them bit for bit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

NAN = math.nan
EXTREMES = ("max", "min", "max_abs", "time_of_max_abs")  # of the points of the interpolant


@dataclasses.dataclass
class Reduction:
    """The running state of one measure: the last row seen (``t``, ``f``), the extremes and the
    sums over the part of the window covered so far."""

    t0: float = 0.0
    t1: float = math.inf
    reduce: str = "final"  # what is computed: only what this reduction needs
    t: float | None = None  # the last row seen
    f: float | None = None
    covered: bool = False
    low: float = NAN
    high: float = NAN
    top: float = -1.0  # max |f|, and the first time it is reached
    top_t: float = NAN
    last: float = NAN  # f at the last point covered
    integral: float = 0.0
    length: float = 0.0
    positive: float = 0.0

    def update(self, t: np.ndarray, f: np.ndarray) -> None:
        """Count a block of consecutive rows: their times and the column's values."""
        if t.size == 0:
            return
        inside = (t >= self.t0) & (t <= self.t1)
        if self.t is None and inside[0]:  # the first row, which no step ends at
            self._points(t[:1], f[:1])
        times = t if self.t is None else np.concatenate([[self.t], t])
        values = f if self.f is None else np.concatenate([[self.f], f])
        self.t, self.f = float(t[-1]), float(f[-1])
        if times.size >= 2:
            self._steps(times, values)
        if inside[-1] and self.covered:  # the last row reached is inside: f there, as it is
            self.last = float(f[-1])

    def _steps(self, times: np.ndarray, values: np.ndarray) -> None:
        """The pieces of the interpolant between consecutive rows, cut to the window."""
        start, end = times[:-1], times[1:]
        a, b = np.maximum(start, self.t0), np.minimum(end, self.t1)
        kept = a < b
        if not kept.any():
            return
        start, end, a, b = start[kept], end[kept], a[kept], b[kept]
        fs, fe = values[:-1][kept], values[1:][kept]
        if self.reduce == "final":  # f at the last point covered
            self.last = float(_at(b[-1:], start[-1:], end[-1:], fs[-1:], fe[-1:])[0])
            self.covered = True
            return
        fa, fb = _at(a, start, end, fs, fe), _at(b, start, end, fs, fe)
        if self.reduce in EXTREMES:
            self._points(np.column_stack([a, b]).ravel(), np.column_stack([fa, fb]).ravel())
            return
        self.covered = True
        width = b - a
        self.integral = _sum(self.integral, width * ((fa + fb) * 0.5))
        self.length = _sum(self.length, width)
        self.positive = _sum(self.positive, _positive(width, fa, fb))

    def _points(self, t: np.ndarray, f: np.ndarray) -> None:
        """Points of the interpolant inside the window, in the order of time."""
        # np.min and np.max carry a NaN on, as the sums do (Python's min and max would keep
        # or drop it by its place, so by how the rows came in blocks)
        low, high = float(np.min(f)), float(np.max(f))
        self.low = low if not self.covered else float(np.min([self.low, low]))
        self.high = high if not self.covered else float(np.max([self.high, high]))
        size = np.abs(f)
        i = int(np.argmax(size))  # the first of the largest (the first NaN, if any)
        if math.isnan(size[i]) or math.isnan(self.top):
            self.top = self.top_t = NAN
        elif size[i] > self.top:
            self.top, self.top_t = float(size[i]), float(t[i])
        self.last = float(f[-1])
        self.covered = True

    def value(self, reduce: str) -> float:
        """The measure of what the rows so far cover."""
        if not self.covered:
            return NAN
        if reduce == "mean":
            return self.integral / self.length if self.length > 0.0 else NAN
        return {"max": self.high, "min": self.low, "max_abs": self.top,
                "integral": self.integral, "final": self.last, "time_of_max_abs": self.top_t,
                "time_positive": self.positive}[reduce]


def _at(x, start, end, fs, fe):
    """The interpolant at x in [start, end], exactly the row's value at either end."""
    inner = fs + (fe - fs) * ((x - start) / (end - start))
    return np.where(x == start, fs, np.where(x == end, fe, inner))


def _positive(width, fa, fb):
    """The length of each piece [a, b] where the linear f from fa to fb is positive."""
    with np.errstate(divide="ignore", invalid="ignore"):
        up = width * (fb / (fb - fa))  # fa <= 0 < fb: from the zero to b
        down = width * (fa / (fa - fb))  # fa > 0 >= fb: from a to the zero
    return np.where((fa > 0) & (fb > 0), width,
                    np.where(fb > 0, np.where(fa > 0, width, up), np.where(fa > 0, down, 0.0)))


def _sum(total: float, terms: np.ndarray) -> float:
    """total + the terms, added one after another."""
    return float(np.cumsum(np.concatenate([[total], terms]))[-1])


class Reductions:
    """The declared measures of a scene (``Scene.measures``), kept over a run's rows."""

    def __init__(self, declared, state: dict | None = None):
        self.declared = tuple(declared)
        state = state or {}
        self.states = {}
        for m in self.declared:
            window = m.window or (0.0, math.inf)
            self.states[m.name] = Reduction(**{**state.get(m.name, {}), "t0": window[0],
                                               "t1": window[1], "reduce": m.reduce})

    def update(self, t: np.ndarray, columns: dict[str, np.ndarray]) -> None:
        """Count a block of rows of every step: their times and columns by name."""
        for m in self.declared:
            self.states[m.name].update(t, columns[m.column])

    def saved(self) -> dict:
        """The state, as a checkpoint keeps it (JSON: the window is the scene's)."""
        return {name: {k: v for k, v in dataclasses.asdict(s).items()
                       if k not in ("t0", "t1", "reduce")}
                for name, s in self.states.items()}

    def values(self) -> dict[str, float]:
        return {m.name: self.states[m.name].value(m.reduce) for m in self.declared}


def reduce(declared, history: dict[str, np.ndarray]) -> dict[str, float]:
    """The declared measures of a history's rows (columns by name), as a run that recorded them
    all in one block computes them."""
    reductions = Reductions(declared)
    reductions.update(np.asarray(history["t"], dtype=float),
                      {m.column: np.asarray(history[m.column], dtype=float) for m in declared})
    return reductions.values()
