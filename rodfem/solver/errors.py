"""What a step raises when it cannot be taken. The run records the steps before it and stops with
exit code 3; the state stays at the last step solved. And what a run raises before its first
step when the compiled loop it needs cannot be built (:class:`KernelUnavailable`, exit code 3,
nothing written)."""

from __future__ import annotations

import numpy as np


class NotConverged(RuntimeError):
    """A step that a method could not solve; the state stays at the last step solved."""

    def __init__(self, method: str, step: int, time: float, detail: str, iterations: int):
        self.method, self.step, self.time = method, step, time
        self.detail, self.iterations = detail, iterations
        super().__init__(f"{self.title} did not converge at step {step} (t = {time:g}): {detail}")

    @property
    def title(self) -> str:
        return {"picard": "Picard iteration", "newton": "Newton's method (SNES)"}.get(
            self.method, self.method)


class SourceNotFinite(NotConverged):
    """A source that is not finite at a step's time: the step cannot be taken."""

    def __init__(self, method: str, step: int, time: float, name: str, t: float):
        super().__init__(method, step, time, f"source.{name} is not finite at t = {t:g}", 0)
        RuntimeError.__init__(self, f"step {step} (t = {time:g}) cannot be taken: {self.detail}")


class PicardNotConverged(NotConverged):
    """The iteration (3.3)–(3.4) did not reach the tolerance within max_iterations, or produced
    values that are not finite. ``u_1`` is the largest U(1) of its iterates, where the contact
    law's contraction is judged."""

    def __init__(self, step: int, time: float, increment: float, iterations: int,
                 u_1: float = np.nan):
        self.increment, self.u_1 = increment, u_1
        if np.isfinite(increment):
            what = f"increment {increment:.3e} after {iterations} iterations"
        else:
            what = f"it diverged to non-finite values at iteration {iterations}"
        super().__init__("picard", step, time, what, iterations)


class NotFinite(NotConverged):
    """A step whose values are not finite (an overflow: data or sources too large for the
    scheme). The run stops before it; unlike a step that did not converge, the method's state is
    already past it, so it is not one to continue from."""

    def __init__(self, method: str, step: int, time: float, quantity: str):
        self.quantity = quantity
        super().__init__(method, step, time, f"{quantity} is not finite", 1)
        RuntimeError.__init__(self, f"step {step} (t = {time:g}) is not finite: {quantity} "
                              "overflowed")


class NoUniqueStep(NotConverged):
    """A step of the direct method whose equation, with a heat exchange that depends on the
    contact, is not shown to have one solution (rodfem.solver.methods.exchange_step): the state
    stays at the last step solved."""

    def __init__(self, method: str, step: int, time: float, detail: str):
        super().__init__(method, step, time, detail, 1)
        RuntimeError.__init__(self, f"step {step} (t = {time:g}) cannot be taken: {detail}")


class StepTooSmall(NotConverged):
    """An adaptive step whose error control asks for a step below ``time.dt_min`` (``h`` the
    step it asks for): the tolerance cannot be met with steps that long. Not a failure of the
    method, which solved every step it was given: the message says what to change."""

    def __init__(self, method: str, step: int, time: float, h: float, dt_min: float):
        self.h, self.dt_min = h, dt_min
        super().__init__(method, step, time, "the error control needs a step below time.dt_min "
                         f"= {dt_min:g} (it asks for {h:.3g}); raise time.tolerance or lower "
                         "time.dt_min", 0)
        RuntimeError.__init__(self, f"step {step} (t = {time:g}) cannot be taken: {self.detail}")


class KernelUnavailable(RuntimeError):
    """The compiled loop a run needs cannot be built or loaded (on some rank): the run cannot
    start (exit code 3), and says so in one line (:meth:`line`)."""

    def line(self) -> str:
        return (f"rodfem: error: {self}; nothing was run. Repair the cause (the C compiler, the "
                "cache directory), or set RODFEM_KERNEL=0 to use the PETSc loop, whose last "
                "digits differ")
