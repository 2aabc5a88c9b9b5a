"""The error of an adaptive step, and the size of the next: NumPy only.

**The error estimate** compares a step's result y (the state [Θ; D; U] and the contact force p)
with a prediction from the steps before it, the polynomial through the last q + 1 accepted
states extrapolated to the new time (q the scheme's order: 1 for the paper's, 2 for
Crank–Nicolson's). Both differ from the exact y(t + h) by a multiple of the same derivative, so
their difference gives the step's local error (Milne's device), for any step sizes h, h₁, h₂:

* paper (backward Euler): y − y(t + h) ≈ h²y''/2, the line through two points is off by
  −h(h + h₁)y''/2, so the local error is h/(2h + h₁) (y − ŷ);
* Crank–Nicolson: y − y(t + h) ≈ h³y'''/12, the parabola through three points is off by
  −h(h + h₁)(h + h₁ + h₂)y'''/6, so the local error is (h³/12)/(h³/12 + h(h + h₁)(h + h₁ + h₂)/6)
  times (y − ŷ).

Where there are not yet q + 1 states since the start (for the paper's scheme with a massless
end, the end of its first step, taken at Δt₀ without an estimate: :mod:`.stepper`) or the last
contact event (whose impact breaks the smoothness the extrapolation needs), the step is taken
again as two half steps, and the local error of the halves is their difference from the whole
step over 2^q − 1 (Richardson); the two halves are kept, which gives the next step its three
states.

**The norm** is relative, per field: the root mean square over the nodes of the error in Θ, in
the velocity and in U, each over the largest max-norm that field has had in the run so far, and
the error in p over the largest contact force or strain (a stress) so far (not for the rigid
obstacle's multiplier at a node with mass, an impulse at an impact), each size at least the one
the scene gives a field that starts at nothing (:meth:`ErrorNorm.seed`); the step's error is the
largest of these over ``time.tolerance`` (0, the default: 5e-5 for the paper's scheme, 1e-3 for
Crank–Nicolson's, :data:`rodfem.scene.schema.TOLERANCES`), and a step is accepted where it is at
most 1.

**The next step** follows Gustafsson's PI controller (Hairer & Wanner, IV.8; Söderlind):
h_new = h · 0.9 · err^(−0.7/k) · err_prev^(0.4/k), k = q + 1, within [h/5, 5h]; after a rejected
step h · 0.9 · err^(−1/k), no larger than 0.9 h. Step sizes are rounded down to a ladder Δt₀ 2^(j/4)
(Δt₀ the first step): the steps repeat, and so do their factorisations.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rodfem.scene.schema import REDISTRIBUTED

RUNGS = 4  # ladder rungs per doubling of the step
SAFETY, GROW, SHRINK = 0.9, 5.0, 0.2
TINY = 1e-10  # the smallest error the controller divides by
ROUNDOFF = 1e-12  # Θ⁰ at most this of the temperatures: the rod starts at its steady one


def force_measured(value) -> bool:
    """Whether the norm measures the contact force p (``value``: a scene's value of a dotted
    key): not the rigid obstacle's multiplier at an end with mass, an impulse at an impact
    (the node's momentum over the step, ~ m v/h whatever h: not a function of time whose error a
    smaller step reduces), where only the fields are measured."""
    return not (value("obstacle.kind") == "rigid" and value("model.b") != 0.0
                and value("discretisation.mass") not in REDISTRIBUTED)


def force_jumps(value) -> bool:
    """Whether the measured p jumps at an impact: the rigid obstacle's multiplier where the
    end's equation has the viscosity's time derivative (ζ > 0) and no mass, where the end is
    stopped at once (the viscous stress ~ ζ v/cell, relaxing after it over ~ cell²/ζ). Its value
    at the event is the one before the jump: an extrapolation through it asked for steps below
    time.dt_min (stiff, redistributed mass, 1,000 cells: 6.6e-10 at tolerance 1e-4), and the
    paper scheme's step to the event, measured against the steps before it, for 1e-11 at 1e-7.
    That step is measured without p (the jump is no error of the step), and the estimate
    restarts from the states after the event only (:class:`~.stepper.AdaptiveStepper`)."""
    return (value("obstacle.kind") == "rigid" and value("model.zeta") != 0.0
            and force_measured(value))


def rung(dt0: float, h: float) -> float:
    """The largest step of the ladder Δt₀ 2^(j/RUNGS) that is at most h."""
    j = math.floor(RUNGS * math.log2(h / dt0) + 1e-9)
    step = dt0 * 2.0 ** (j / RUNGS)
    return step if step <= h else dt0 * 2.0 ** ((j - 1) / RUNGS)


def extrapolate(times, states, t: float) -> np.ndarray:
    """The polynomial through (times[i], states[i]) at t (Lagrange's form; sequences of floats
    and of equal arrays)."""
    out, term = np.zeros(states[0].shape[0]), np.empty(states[0].shape[0])
    for i, ti in enumerate(times):
        weight = 1.0
        for j, tj in enumerate(times):
            if j != i:
                weight *= (t - tj) / (ti - tj)
        out += np.multiply(states[i], weight, out=term)
    return out


def milne(order: int, h: float, gaps: np.ndarray) -> float:
    """The factor that turns (step − prediction) into the local error, for steps h and the
    previous ones ``gaps`` = [h₁, h₂] (most recent first)."""
    if order == 1:
        return h / (2.0 * h + gaps[0])
    step = h**3 / 12.0
    return step / (step + h * (h + gaps[0]) * (h + gaps[0] + gaps[1]) / 6.0)


@dataclasses.dataclass
class ErrorNorm:
    """The relative norm of an error of y = [Θ; D; U; p] (n nodes, h the cell), against the
    largest size of each field so far (``maxima``: Θ, D, U, and the stress scale). The velocity's
    size is at least that of a stress S carried by a wave, S/√b (where the kinetic and the
    strain energy balance; D = Δt₀ V): a rod released from rest is measured against the speed
    its strain will give it, not against the vanishing speed of its first steps."""

    nodes: int
    cell: float
    b: float = 0.0
    dt0: float = 1.0
    massless_end: bool = False  # a redistributed mass: D(1) is not a velocity, left out
    maxima: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(4))
    force: bool = True  # whether p is measured (not an impulse: see AdaptiveStepper)
    _last: tuple | None = dataclasses.field(default=None, repr=False)  # (y, maxima, grown)

    def seed(self, y: np.ndarray, temperature: float, a: float) -> None:
        """Count the initial state y, and the sizes the scene gives the fields that start at
        nothing and grow from it (any relative error of their first steps is of order one):
        ``temperature`` (the largest |θ| the rod starts at or is held at, θ_A, θ_O) for Θ = θ − L
        where the rod starts at its steady temperature L (Θ⁰ at round-off of it); for a rod at
        rest (U = D = 0), the displacement and the speed that the stress S = a ``temperature``
        makes: S over the rod's unit length, and S/√b."""
        self.maxima = self.grown(y)
        n = self.nodes
        if np.abs(y[:n]).max() <= ROUNDOFF * temperature:
            self.maxima[0] = max(self.maxima[0], temperature)
        stress = a * temperature
        if stress > 0.0 and not np.any(y[n:3 * n]):
            self.maxima[2] = max(self.maxima[2], stress)
            self.maxima[3] = max(self.maxima[3], stress)

    def sizes(self, y: np.ndarray) -> np.ndarray:
        n = self.nodes
        y = self._without_end(y)
        fields = np.abs(y[:3 * n].reshape(3, n)).max(axis=1)  # Θ, D, U
        u = y[2 * n:3 * n]
        strain = float(np.abs(u[1:] - u[:-1]).max()) / self.cell if n > 1 else 0.0
        return np.array([fields[0], fields[1], fields[2], max(abs(float(y[3 * n])), strain)])

    def _without_end(self, y: np.ndarray) -> np.ndarray:
        if not self.massless_end:
            return y
        y = y.copy()
        y[2 * self.nodes - 1] = 0.0
        return y

    def grown(self, y: np.ndarray) -> np.ndarray:
        """The maxima with y counted (those of the last y measured, without counting it
        again)."""
        last = self._last
        if last is not None and last[0] is y and last[1] is self.maxima:
            return last[2]
        return np.maximum(self.maxima, self.sizes(y))

    def __call__(self, error: np.ndarray, y: np.ndarray, tolerance: float) -> float:
        n, grown = self.nodes, self.grown(y)
        self._last = (y, self.maxima, grown)
        scale = grown.copy()
        if self.b > 0.0:
            scale[1] = max(scale[1], self.dt0 * scale[3] / np.sqrt(self.b))
        error = self._without_end(error)
        squares = error[:3 * n].reshape(3, n)
        parts = [*np.sqrt(np.add.reduce(squares * squares, axis=1) / n),  # RMS per field
                 abs(float(error[3 * n])) if self.force else 0.0]
        ratios = [p / (tolerance * s) if s > 0.0 else (0.0 if p == 0.0 else np.inf)
                  for p, s in zip(parts, scale)]
        return float(max(ratios))


@dataclasses.dataclass
class Controller:
    """The PI controller of the module's docstring, with ``dt_min`` and ``dt_max`` (0: none)."""

    dt0: float
    order: int
    dt_min: float
    dt_max: float
    previous: float = 1.0  # the last accepted step's error

    @property
    def k(self) -> int:
        return self.order + 1

    def accepted(self, h: float, error: float) -> float:
        """The next step after an accepted step h of the given error."""
        error = max(error, TINY)
        factor = SAFETY * error ** (-0.7 / self.k) * max(self.previous, TINY) ** (0.4 / self.k)
        self.previous = error
        return h * min(GROW, max(SHRINK, factor))

    def rejected(self, h: float, error: float) -> float:
        """The step to try after a rejected step h of the given error."""
        factor = SAFETY * max(error, TINY) ** (-1.0 / self.k)
        return h * min(SAFETY, max(SHRINK, factor))

    def ladder(self, h: float) -> float:
        """h bounded by dt_max and rounded down to the ladder (not below dt_min)."""
        if self.dt_max:
            h = min(h, self.dt_max)
        return max(rung(self.dt0, h), min(self.dt_min, h))
