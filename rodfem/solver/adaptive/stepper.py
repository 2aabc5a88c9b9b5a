"""Adaptive steps of any method: each step's error estimated and controlled, rejected steps taken
again, and a step ending where contact begins or ends.

**Steps of any size.** A method is set up for one Δt (its operators and factorisations); the
run's method (``home``, of the first step Δt₀) holds the state, and a step of another size h is
taken by a method made for h (:meth:`rodfem.discrete.discretisation.Discretisation.at_step`),
kept for the next step of that size (the controller's ladder makes sizes repeat): the state is
handed to it and back. The state's D is the displacement the velocity makes over a step, Δt V:
the home method's holds Δt₀ V always (what the history, the energy and the fields read), and a
step of size h starts from D h/Δt₀ and hands back D Δt₀/h. Both schemes keep their properties
at any step: each step is the paper's backward-Euler step or Crank–Nicolson's midpoint step of
its own size from the same velocity, so the paper scheme's energy decays and Crank–Nicolson's
identity holds exactly, step by step (docs/time-schemes.md).

**Contact events.** Contact is on where the obstacle pushes: u(1) > g for an elastic obstacle,
u(1) − g + h p > 0 for the rigid one (its multiplier p > 0 holds u(1) at g; h the cell, any
positive weight would do). Where a step changes that, the step's size is found where it changes,
by secants on the step's own results (:func:`.events.locate`), to a bracket 1e-10 wide
in time; the step ends at the far end of the bracket, with contact already changed, and its
history row is marked. The error estimate then starts again from that state (its derivatives
jump at an impact).

**The contact force measured** is the force of the state at the step's end, φ'(Uⁿ(1)) for an
elastic obstacle. The paper scheme's step force is that one; Crank–Nicolson's is the discrete
gradient over the step, the force near its middle (for the linear law φ' at (Uⁿ⁻¹(1) + Uⁿ(1))/2),
which belongs to the time tⁿ − h/2. Measured as a value at tⁿ, its error is first order in the
step wherever the force changes: the halves' force is that of tⁿ − h/4, the whole step's that of
tⁿ − h/2, and an extrapolation from steps of other sizes is off by half their difference, times
the force's rate (ε⁻¹ u_t(1)). Just after an impact on ``stiff`` that error asked for steps
below 1e-9 at tolerance 1e-7 (the run stopped), and at 1e-6 for steps of 1e-9 all through the
contact (339,859 steps, against 844 with the end force).

**The paper's first step**, U¹ = U⁰ + h P u₁, keeps the initial velocity and solves no
equation of motion. With a mass at the end its error is that of two halves (the special step,
then a step of the equations), and it is taken smaller where they ask. A rod that starts at the
obstacle and pushes it meets it in the second half, never in the special step: there the halves'
error is measured all the same and only the first half kept (:meth:`AdaptiveStepper._halves`);
the next step meets the contact. With a massless end (a redistributed mass) the end jumps to its
equilibrium in that step whatever its size: it is taken at Δt₀ as the fixed-step scheme takes
it, with no estimate, and the estimate starts after it (two halves, that step and a step of the
equations, differ by what need not fall with the step: on the impact scene with 100 cells no
step was accepted down to time.dt_min).

**Failures.** A step that Picard's iteration or Newton's method does not solve is taken again at
a quarter of its size; for Picard, whose iteration contracts only for steps short enough while in
contact (w/ε < 1, ``rodfem stability``), the failed size bounds every later step that starts in
contact at half of it: w grows as Δt^1.5 to Δt², so that is about a third of the failed
contraction, near w/ε = 0.2, where the work in contact, steps per unit time times iterations per
step (∝ 1/|log(w/ε)|), is least.
Out of contact the iteration contracts at any step, and the error control alone sets the step:
bounding those steps too cost paper1 against 1/ε = 1e4 64,260 Picard iterations instead of
48,299 (the paper's scheme), 34,954 instead of 25,226 (Crank–Nicolson's).
A direct step whose equation with a heat exchange that depends on the contact is not shown to
have one root (rodfem.solver.methods.exchange_step: the exchange's feedback on the motion grows
with the step) is taken again at a quarter of its size too.
Below time.dt_min the run stops (exit code 3): with the method's failure where the method did not
solve the last step tried (or one of its halves), else with :class:`StepTooSmall`, the error
control's.
"""

from __future__ import annotations

import numpy as np

from rodfem.model.robin import temperature
from rodfem.scene.schema import TOLERANCES
from rodfem.solver.adaptive.control import (Controller, ErrorNorm, extrapolate, force_jumps,
                                           force_measured, milne, rung)
from rodfem.solver.adaptive.events import locate
from rodfem.solver.errors import NotConverged, NoUniqueStep, PicardNotConverged, StepTooSmall
from rodfem.solver.linalg import free_garbage

RETRIED = (PicardNotConverged, NoUniqueStep)
KEPT = 64  # the most step sizes of the ladder whose methods are kept (the least recent go)


class AdaptiveStepper:
    """Accepted steps of ``home`` (a :class:`~rodfem.solver.methods.base.Method` of the first
    step Δt₀), one :meth:`step` at a time. ``make(h, once)`` returns (method for step h, its
    compiled loop or None), ``once`` for a size off the ladder (it takes a step or two);
    ``loop`` is the home method's compiled loop or None; ``record(dt, event, whole)`` is called
    with home in each accepted state, ``whole`` where the stepper's state is that of the end of
    a :meth:`step` (a checkpoint may be written; not after the first of two halves)."""

    def __init__(self, home, scene, make, loop, record, width: int):
        self.home, self.make, self.loop, self.record = home, make, loop, record
        self.dt0 = home.dt
        self.end = scene["time.end"]
        self.tolerance = scene["time.tolerance"] or TOLERANCES[scene["time.scheme"]]
        self.order = home.time_scheme.order
        self.nodes = home.values.size // 3
        self.controller = Controller(self.dt0, self.order, scene["time.dt_min"],
                                     scene["time.dt_max"])
        self.rigid, self.gap = home.law.rigid, home.law.gap
        # Crank–Nicolson's step force with a mass at the end is the discrete gradient (the
        # module's docstring): the state's own force, φ'(U(1)), is measured in its place. A
        # massless end's force is its settled one, ψ'(y), already the state's.
        self.end_force = (home.time_scheme.gradient_contact and not self.rigid
                          and not home.disc.redistributed)
        # p is measured but where it is an impulse; where it jumps at an impact, the step to the
        # event is measured without it and the estimate restarts after the event (control.py)
        self.norm = ErrorNorm(self.nodes, 1.0 / scene["mesh.cells"], scene["model.b"],
                              self.dt0, home.disc.redistributed,
                              force=force_measured(scene.__getitem__))
        self.jumps = force_jumps(scene.__getitem__)
        self.cell = 1.0 / scene["mesh.cells"]
        self.t, self.h = 0.0, self.dt0
        self.cap = np.inf  # Picard: half the smallest step it failed at
        self.past_t: list[float] = []
        self.past: list[np.ndarray] = []
        self._methods: dict[float, tuple] = {}  # of the ladder's sizes, the most recent last
        self._located: tuple | None = None  # (h, its method and loop): the last size off it
        self._home_at: dict | None = None  # the saved state home is at, if known
        self.made = 0  # methods made for the ladder's sizes (a count, for a table of them)
        self._rows = np.zeros((1, width))
        self.steps = self.rejected = self.events = 0

    # -- the state ---------------------------------------------------------------------------

    def y(self) -> np.ndarray:
        """[Θ; D; U; p] of the home state, p the contact force at its time (the module's
        docstring)."""
        if self.end_force:
            return np.append(self.home.values, self.home.law.force(float(self.home.values[-1])))
        return np.append(self.home.values, self.home.pressure)

    def contact(self) -> float:
        """> 0 while the obstacle pushes (the module's docstring): of the home state."""
        return self._contact(float(self.home.values[-1]), self.home.pressure)

    def contact_of(self, state: dict) -> float:
        """:meth:`contact` of a saved state."""
        return self._contact(float(state["state"][-1]), float(state["pressure"][0]))

    def _contact(self, u_1: float, p: float) -> float:
        if self.rigid:
            return u_1 - self.gap + self.cell * p
        return u_1 - self.gap

    def start(self) -> None:
        """Count the initial state (call once, at n = 0, before the first step)."""
        self.past_t, self.past = [self.t], [self.y()]
        self.norm.seed(self.past[0], self._temperature(), self.home.disc.scene["model.a"])

    def _temperature(self) -> float:
        """max |θ| over the initial temperature, θ_A and the obstacle's θ_O: the size of the
        temperatures, and (times a) of the stress they can put in a rod at rest
        (ErrorNorm.seed)."""
        scene, home = self.home.disc.scene, self.home
        x = home.disc.nodes.x
        theta = temperature(home.values[:self.nodes], x, scene)
        return float(max(np.abs(theta).max(), abs(scene["model.theta_A"]),
                         abs(scene["obstacle.temperature"])))

    # -- one step of a given size ------------------------------------------------------------

    def _method(self, h: float):
        """The method and loop of the step h: kept for the ladder's sizes, which repeat; a
        size off it (an event's, the last step's) is tried once or twice in a row."""
        if h == self.dt0:
            return self.home, self.loop
        made = self._methods.pop(h, None)
        if made is None and self._located is not None and self._located[0] == h:
            return self._located[1]
        if made is None:
            once = rung(self.dt0, h) != h
            made = self.make(h, once)
            if once:  # the one before it is freed at once: unfreed, made at every step, they
                # grew a run at tolerance 1e-6 to 24 GB (a loop bound to home holds no PETSc
                # object: nothing to collect)
                self._located = (h, made)
                if made[0] is not self.home:
                    free_garbage(self.home.disc.comm)
                return made
            if len(self._methods) >= KEPT:
                del self._methods[next(iter(self._methods))]  # the least recently used
                if made[0] is not self.home:
                    free_garbage(self.home.disc.comm)
            self.made += 1
        self._methods[h] = made
        return made

    def _take(self, h: float, start: dict, made: tuple | None = None) -> tuple:
        """Home from the state ``start`` (at self.t) one step h on, by ``made`` (h's method and
        loop, if at hand): those returned. The state goes to the method of h as it is, with D
        scaled (the module's docstring), and back."""
        method, loop = made = made or self._method(h)
        n = self.nodes
        bound = method is self.home and h != self.dt0  # a loop of h on home's own state
        if method is not self.home:
            method.restore(start)
            method.values[n:2 * n] *= h / self.dt0
        elif self._home_at is not start:
            method.restore(start)
        self._home_at = None
        if bound:
            method.values[n:2 * n] *= h / self.dt0
        method.clock = self.t
        if loop is not None and not method.first_step_special:
            loop.advance(1, self._rows)
        elif bound:
            loop.first_step()
        else:
            method.advance()
        if method is not self.home:
            self.home.take_state(method)
        if method is not self.home or bound:
            self.home.values[n:2 * n] *= self.dt0 / h
        return made

    # -- the step ----------------------------------------------------------------------------

    def _proposal(self, touching: bool) -> float:
        h = self.controller.ladder(min(self.h, self.cap) if touching else self.h)
        left = self.end - self.t
        return left if h >= left * (1.0 - 1e-9) else h

    def step(self) -> None:
        """One accepted step (two at a restart of the estimate), each recorded."""
        start = self._home_at = self.home.saved_state()
        before = self.contact() > 0.0
        while True:
            h = self._proposal(before)
            try:
                if self._attempt(h, start, before):
                    return
            except RETRIED as failure:
                self._failed(h, start, failure)

    def _attempt(self, h: float, start: dict, before: bool) -> bool:
        """Try the step h from ``start``: accepted (True), or rejected with the next size set."""
        # The paper scheme's first step (U¹ = U⁰ + Δt₀ P u₁) with a massless end: the end jumps
        # to its equilibrium in it whatever its size, which no estimate of a smooth error sees
        # shrink; it is taken at Δt₀ as it is, and the estimate starts after it. With a mass at
        # the end its error is measured as any step's.
        f0 = self.contact_of(start)
        first = self.home.first_step_special
        special = first and self.home.disc.redistributed
        self._take(h, start)
        event = (self.contact() > 0.0) != before
        if event:
            h = self._locate(h, start, f0, before)
        y = self.y()
        if len(self.past) > self.order:  # a jump of p at the event is no error (jumps)
            error = self._predicted(h, y, measured=not (event and self.jumps))
            if error <= 1.0:
                self._accept([(h, event, None, y)], error)
                return True
        elif event or special:
            self._accept([(h, event, None, y)], None, restart=special)
            return True
        else:
            error, halves = self._halves(h, start, y, first)
            if error <= 1.0:
                self._accept(halves, error)
                return True
            if isinstance(halves, NotConverged):
                self._reject(h, start, error, halves)
                return False
        self._reject(h, start, error)
        return False

    def _accept(self, steps, error, restart: bool = False) -> None:
        """Record the accepted step(s) (``restart``: the estimate starts again after them, as
        after an event), the next step's size set before the last is recorded: a checkpoint
        written as it is recorded holds the controller of the step after it."""
        last = steps[-1][0]
        if error is not None:
            following = self.controller.accepted(last, error)
        else:
            following = max(self.h, last)
        for k, (h, event, state, y) in enumerate(steps):
            if state is not None:
                self.home.restore(state)
                self._home_at, y = state, self.y()
            self.t = self.end if abs(self.end - (self.t + h)) <= 1e-12 * self.end else self.t + h
            self.norm.maxima = self.norm.grown(y)
            self.past_t.append(self.t)
            self.past.append(y)
            if event or restart:
                self.past_t, self.past = ([], []) if event and self.jumps else ([self.t], [y])
                self.events += int(event)
            del self.past_t[:-(self.order + 1)], self.past[:-(self.order + 1)]
            self.steps += 1
            whole = k == len(steps) - 1
            if whole:
                self.h = following
            self.record(h, event, whole)

    def _reject(self, h: float, start: dict, error: float,
                failure: NotConverged | None = None) -> None:
        """The step h not accepted: the next size set, or below time.dt_min the run stopped by
        what rejected it, the error control or (``failure``) a half the method did not solve."""
        self.rejected += 1
        self.home.restore(start)
        self._home_at = start
        self.h = self.controller.rejected(h, error)
        if self.h < self.controller.dt_min:
            if failure is not None:
                raise failure
            raise StepTooSmall(self.home.name, self.home.n + 1, self.t + h, self.h,
                               self.controller.dt_min)

    def _failed(self, h: float, start: dict, failure: NotConverged) -> None:
        """A step the method did not solve: a quarter of it next (Picard: never again half of
        it in contact)."""
        self.rejected += 1
        self.home.restore(start)
        self._home_at = start
        if self.home.name == "picard":
            self.cap = min(self.cap, 0.5 * h)
        self.h = 0.25 * h
        if self.h < self.controller.dt_min:
            raise failure

    def _predicted(self, h: float, y: np.ndarray, measured: bool = True) -> float:
        """The local error of the step just taken (to y), by Milne's device (``measured``:
        with p's, where the norm measures it)."""
        k = self.order + 1
        times, states = self.past_t[-k:], self.past[-k:]
        gaps = [times[-1] - times[-2], times[-2] - times[-3]] if k == 3 else [times[1] - times[0]]
        difference = extrapolate(times, states, self.t + h)
        np.subtract(y, difference, out=difference)
        difference *= milne(self.order, h, gaps)
        if not measured:
            difference[-1] = 0.0
        return self.norm(difference, y, self.tolerance)

    def _halves(self, h: float, start: dict, whole: np.ndarray, first: bool = False):
        """The step h again as two halves: (their error, [(h/2, False, state, None)] * 2), the
        error infinite if a half meets an event or fails (the step is then taken smaller; in
        place of the halves, the method's failure).

        ``first``: the step is the paper scheme's first (U¹ = U⁰ + Δt P u₁), which keeps the
        initial velocity and cannot meet an event its second half, a step of the equations, may
        meet (a rod started at the obstacle and pushing it). There the error is measured all
        the same, and only the first half is kept, with a quarter of it: its local error, of
        order two, is a quarter of the whole step's. The next step then meets the event."""
        before, t0, half = self.contact_of(start) > 0.0, self.t, 0.5 * h
        kept, state = [], start
        try:
            for k in range(2):
                self._take(half, state)
                if (self.contact() > 0.0) != before:
                    if not (first and k == 1):
                        return np.inf, []
                    y = self.y()
                    error = self.norm((y - whole) / (2.0**self.order - 1.0), y, self.tolerance)
                    return error / 4.0, kept
                state = self._home_at = self.home.saved_state()
                kept.append((half, False, state, None))
                self.t = t0 + half
        except RETRIED as failure:
            return np.inf, failure
        finally:
            self.t = t0
        y = self.y()
        return self.norm((y - whole) / (2.0**self.order - 1.0), y, self.tolerance), kept

    def _locate(self, h: float, start: dict, fa: float, before: bool) -> float:
        """The step's size where contact changes (:func:`.events.locate`); home is left there."""
        return locate(self, h, start, fa, before)

    def counts(self) -> dict:
        """What the run's summary reports of the steps."""
        return {"steps": self.steps, "rejected": self.rejected, "events": self.events,
                "t": self.t}

    # -- a checkpoint ------------------------------------------------------------------------

    def saved(self) -> dict[str, np.ndarray]:
        """What the next steps depend on, beyond the method's state."""
        return {"controller": np.array([self.t, self.h, self.controller.previous, self.cap,
                                        *self.norm.maxima], dtype=float),
                "past_t": np.array(self.past_t, dtype=float),
                "past": np.array(self.past, dtype=float).reshape(len(self.past),
                                                                 3 * self.nodes + 1)}

    def restore(self, saved: dict[str, np.ndarray], counts: dict | None = None) -> None:
        """Continue from :meth:`saved` (with the home method restored to the same step) and the
        :meth:`counts` kept beside it. The methods of other step sizes are made again as they
        are needed: a step's result does not depend on when its method was made."""
        self.steps = self.home.n
        if counts is not None:
            self.rejected, self.events = int(counts["rejected"]), int(counts["events"])
        c = saved["controller"]
        self.t, self.h, self.controller.previous, self.cap = (float(v) for v in c[:4])
        self.norm.maxima = np.array(c[4:8], dtype=float)
        self.past_t = [float(v) for v in saved["past_t"]]
        self.past = [np.array(row) for row in saved["past"]]
