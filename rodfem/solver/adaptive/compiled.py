"""The regular steps of an adaptive run in compiled code (``rodfem/solver/compiled/adaptive.h``).

A regular step is one that neither changes contact nor restarts the estimate: the step of the
controller's proposed size from the last accepted state, its error by Milne's device and the PI
controller's decision, the history row of the accepted state. :class:`AdaptiveStepper` takes
these in Python at 80-100 µs each; here many of them are taken in one C call, with the same
arithmetic in the same order (the norm's sums are NumPy's pairwise sums), so that every decision
is the stepper's: the same steps, rejections and step sizes. The history's rows are the stepper's
to round-off: their bulk energy is summed in C, not by PETSc. The estimate's restarts (the step
taken again as two halves, after an event and at the start) and the events' location are taken
in the same calls, as the stepper takes them.

Everything else stays with the stepper (:meth:`AdaptiveStepper.step`), which the call hands
the run back to with the state of the last accepted step:

* a step that changes contact where the sizes are not formed in C (it is located there), or
  that the method does not solve;
* a restart of the estimate (the two halves, at the start and after an event) that the C call
  does not take (RA_RESTART: adaptive.h says which);
* a step below ``time.dt_min`` (the stepper's error, StepTooSmall, raised here);

a step size with no problem yet is formed in the C call itself, from the run's family of step
sizes (:mod:`rodfem.solver.compiled.family`), in a pool of slots allocated and written here once
(:meth:`CompiledSteps._pool`); without a family formed in C (Picard with a heat exchange that
depends on the contact) it is made between two calls (by the stepper's ``make``, and kept),
without going back to the run's loop;

and the call returns when the history's block is full, a field save is due (a save interval
begun), a row is not finite, or ``max_steps`` are done (the run's agreed checks for a stop).
Under MPI every rank takes the same steps, as it computes the same state.
"""

from __future__ import annotations

import numpy as np

from rodfem.solver.adaptive.events import EVENT_WIDTH, PAST
from rodfem.solver.adaptive.stepper import KEPT
from rodfem.solver.errors import StepTooSmall

SIZES = 80  # the most of the stepper's step sizes one call can step with (it keeps 64)
POOL_BYTES = 2 << 20  # the memory of the sizes a call forms, kept for the next steps


def tridiagonal(E) -> np.ndarray:
    """A tridiagonal PETSc matrix as rows (E(i, i − 1), E(i, i), E(i, i + 1)), 0 where it has no
    entry (ValueError if it has one farther from the diagonal)."""
    indptr, indices, values = E.getValuesCSR()
    rows = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
    offset = indices - rows
    if np.any(np.abs(offset[values != 0.0]) > 1):
        raise ValueError("the energy's matrix is not tridiagonal")
    band = np.zeros((indptr.size - 1, 3))
    near = np.abs(offset) <= 1
    band[rows[near], offset[near] + 1] = values[near]
    return band.reshape(-1)


class CompiledSteps:
    """Regular steps of ``stepper`` (an :class:`AdaptiveStepper` whose home method has a
    compiled loop) recorded in ``history``: :meth:`advance`."""

    def __init__(self, stepper, history, family=None):
        loop = stepper.loop
        self.stepper, self.history = stepper, history
        ffi, lib = loop._ffi, loop._lib
        self._ffi = ffi
        self._run = lib.rk_adaptive if hasattr(lib, "rk_adaptive") else lib.pk_adaptive
        self.codes = {name: getattr(lib, name) for name in
                      ("RA_END", "RA_PAUSE", "RA_NEED", "RA_EVENT", "RA_FAILED", "RA_RESTART",
                       "RA_TOO_SMALL")}
        home, norm, control = stepper.home, stepper.norm, stepper.controller
        n = self.n = stepper.nodes
        R = self.R = ffi.new("ra_run *")
        R.n, R.order = n, stepper.order
        R.rigid, R.gap, R.cell = int(stepper.rigid), float(stepper.gap), stepper.cell
        R.end_force = int(stepper.end_force)
        if stepper.end_force:  # the obstacle's own law (not an eliminated end's in series)
            loop.set_obstacle(R.obstacle, home)
            if home.massless is not None:
                raise ValueError("the end force is measured only at an end with its mass")
        R.dt0, R.dt_min, R.dt_max = stepper.dt0, control.dt_min, control.dt_max
        R.tolerance, R.end = stepper.tolerance, stepper.end
        if norm.dt0 != stepper.dt0:
            raise ValueError("the norm's Δt₀ is not the stepper's")
        R.b, R.massless_end, R.force = norm.b, int(norm.massless_end), int(norm.force)
        R.jumps = int(stepper.jumps)
        energy = history.energy
        arrays = self._arrays = {
            "past": np.zeros((stepper.order + 1) * (3 * n + 1)),
            "size_h": np.zeros(SIZES),
            "e_band": tridiagonal(energy.E),
            "two_w": np.array(energy.two_w.array_r, dtype=float),
            "start": np.zeros(3 * n), "start_u_prev": np.zeros(n), "squares": np.zeros(3 * n),
            "scratch_row": np.zeros(history.width),
            "whole": np.zeros(3 * n + 1), "held": np.zeros(4 * n),
        }
        readings = history.readings
        if readings is not None:
            arrays["r_index"] = np.ascontiguousarray(readings.index, dtype=np.intc)
            arrays["r_weight"] = np.ascontiguousarray(readings.weight, dtype=float)
            arrays["r_constant"] = np.ascontiguousarray(readings.constant, dtype=float)
            R.readings.count, R.readings.terms = readings.count, readings.terms
            R.readings.index = self._pointer(arrays["r_index"], "int *")
            R.readings.weight = self._pointer(arrays["r_weight"])
            R.readings.constant = self._pointer(arrays["r_constant"])
        for name in ("past", "size_h", "e_band", "two_w", "start", "start_u_prev", "squares",
                     "scratch_row", "whole", "held"):
            setattr(R, name, self._pointer(arrays[name]))
        self._problems = ffi.new("void *[]", SIZES)
        R.size_problem = self._problems
        R.width = history.width
        R.u_1, R.du_1 = history.u_1, history.du_1
        i, wi, j, wj = history.half
        R.half_i, R.half_j, R.half_wi, R.half_wj = i, j, wi, wj
        R.event_width, R.event_past = EVENT_WIDTH, PAST
        if family is not None and family.forms_in_c:  # an event's tries formed in C
            problem = "rk_problem *" if hasattr(lib, "rk_form") else "pk_problem *"
            self._scratch = [ffi.new(problem) for _ in range(2)]
            self._memory = [np.empty(family.size) for _ in range(2)]
            R.family, R.template_problem = family.F, family.template
            R.problem_bytes = family.struct_size
            R.scratch = self._scratch
            R.scratch_memory = [self._pointer(memory) for memory in self._memory]
            self._pool(family, problem)
        self._loops: list = []  # the loops whose problems the table points into
        self._seen = None
        self.home = home

    def _pool(self, family, problem: str) -> None:
        """The pool of step sizes formed in the C call (adaptive.h's ra_size): POOL_BYTES of
        slots, from 4 to KEPT, their memory written once here (a page's first touch costs more
        than forming a size on a shared virtual machine, 2–6 µs a page)."""
        ffi, R = self._ffi, self.R
        slots = int(min(KEPT, max(4, POOL_BYTES // (8 * family.size))))
        self._slots = [ffi.new(problem) for _ in range(slots)]
        self._slot_memory = np.zeros((slots, family.size))
        self._slot_memory.fill(0.0)  # np.zeros maps pages without writing them
        self._slot_h, self._slot_used = np.zeros(slots), np.zeros(slots, dtype=np.int64)
        self._slot_pointers = ffi.new("void *[]", self._slots)
        self._slot_memories = ffi.new("double *[]", [self._pointer(row)
                                                     for row in self._slot_memory])
        R.pool = slots
        R.pool_h, R.pool_used = self._pointer(self._slot_h), self._pointer(self._slot_used,
                                                                             "long *")
        R.pool_problem, R.pool_memory = self._slot_pointers, self._slot_memories

    @property
    def formed(self) -> int:
        """The step sizes formed in the C calls so far."""
        return int(self.R.formed)

    def _pointer(self, array: np.ndarray, kind: str = "double *"):
        return self._ffi.cast(kind, self._ffi.from_buffer(array))

    def ready(self) -> bool:
        """Whether the next steps can be taken here: past the paper scheme's first step (a
        restart of the estimate too, from one state on)."""
        return not self.home.first_step_special and len(self.stepper.past) > 0

    def _sizes(self) -> None:
        """The table of step sizes and their problems: home's, the ladder's kept by the
        stepper and the last size off it (made again only when the stepper made one)."""
        stepper = self.stepper
        seen = (stepper.made, stepper._located[0] if stepper._located else None)
        if seen == self._seen:
            return
        loops = [(stepper.dt0, stepper.loop)]
        loops += [(h, made[1]) for h, made in stepper._methods.items()]
        if stepper._located is not None:
            loops.append((stepper._located[0], stepper._located[1][1]))
        loops = [(h, loop) for h, loop in loops if loop is not None][:SIZES]
        sizes = self._arrays["size_h"]
        for k, (h, loop) in enumerate(loops):
            sizes[k] = h
            self._problems[k] = self._ffi.cast("void *", loop._problem)
        self.R.sizes = len(loops)
        self._loops, self._seen = loops, seen

    def advance(self, max_steps: int, interval: float | None, frame: int) -> int:
        """Regular steps from the stepper's state, at most ``max_steps`` and the history's free
        rows, recorded in the history; stops after a step that begins a save interval
        (``frame(t, interval)`` > ``frame``). Returns the code of adaptive.h (``self.codes``)
        that ended it; the rows written are committed, ``self.written`` of them. A step size
        with no problem yet (RA_NEED) is made here, by the stepper, and the steps go on in C
        (RA_NEED is returned only with ``max_steps`` or the rows used up); RA_TOO_SMALL raises
        StepTooSmall."""
        stepper, home, history, R = self.stepper, self.home, self.history, self.R
        past = self._arrays["past"].reshape(stepper.order + 1, -1)
        for k, (t, y) in enumerate(zip(stepper.past_t, stepper.past)):
            past[k] = y
            R.past_t[k] = t
        R.count, R.head = len(stepper.past), 0
        R.t, R.h, R.previous, R.cap = stepper.t, stepper.h, stepper.controller.previous, stepper.cap
        R.maxima = list(stepper.norm.maxima)
        R.values = self._pointer(home.values)
        R.u_prev = self._pointer(home.u_prev.array)
        R.step, R.iterations, R.pressure = home.n, home.iterations, home.pressure
        R.interval = interval or 0.0
        R.frame = float(frame)
        R.rejected = R.events = 0
        written = 0
        while True:  # the state stays in R between the calls: only the sizes change
            self._sizes()
            room = history.free
            R.rows = self._pointer(history.reserve(room))
            R.clock = self._pointer(history.reserve_clock(room))
            R.room = room
            code = int(self._run(R, max_steps - written))
            history.commit(int(R.written))
            written += int(R.written)
            if code == self.codes["RA_NEED"]:
                stepper._method(float(R.wanted))
                if written < max_steps and history.free > 0:
                    continue
            break
        # back to the stepper
        self.written = written
        for vector in (home.state, home.theta, home.du, home.u, home.u_prev):
            vector.stateIncrease()  # written behind PETSc's back
        home.n, home.iterations, home.pressure = int(R.step), int(R.iterations), float(R.pressure)
        stepper._home_at = None
        stepper.t, stepper.h, stepper.controller.previous = R.t, R.h, R.previous
        stepper.norm.maxima = np.array([R.maxima[k] for k in range(4)])
        places = [(R.head + k) % past.shape[0] for k in range(R.count)]
        stepper.past_t = [float(R.past_t[k]) for k in places]
        stepper.past = [past[k].copy() for k in places]
        stepper.steps += written
        stepper.rejected += int(R.rejected)
        stepper.events += int(R.events)
        if code == self.codes["RA_TOO_SMALL"]:
            raise StepTooSmall(home.name, home.n + 1, stepper.t + float(R.wanted), stepper.h,
                               stepper.controller.dt_min)
        return code
