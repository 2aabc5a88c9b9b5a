"""Adaptive steps at tight tolerances through a contact event.

On ``stiff`` (1/ε = 1e4) with 50 cells to just after its impact (t ≈ 0.2219), at tolerance 1e-8:
the run gets past the event without a step below time.dt_min, the event located to its bracket,
with each scheme; and Crank–Nicolson's run stopped at the event (its estimate restarted there:
one state since the event) resumes to the uninterrupted run bit for bit.

Crank–Nicolson's step force is the discrete gradient over the step, the force near its middle;
measured as a value at the step's end its error was first order in the step, and just after the
impact the control asked for steps below 1e-9 (stepper's module docstring). The error measured
now is that of the state's own force, φ'(U(1)), of the order of the scheme.
"""

import json
import os
import signal

import numpy as np
import pytest
from test_resume import assert_same_run, rodfem

from conftest import serial_only
from rodfem.output.readers import read_history
from rodfem.solver.adaptive.events import EVENT_WIDTH

TIGHT = {"mesh.cells": 50, "time.end": 0.2221, "time.adaptive": True, "time.tolerance": 1e-8}
GAP = 0.1  # stiff's obstacle.gap


def run(out, scheme: str, stop_at_event: bool = False):
    """``stiff`` at TIGHT with ``scheme`` into ``out``; ``stop_at_event``: stopped (Ctrl-C, as
    at a terminal) as the event's step is recorded, and the checkpoint written there (the
    compiled steps taken one a call, so that the call that records the event ends with it: a
    request to stop is seen between calls)."""
    import rodfem as api
    from rodfem.run import Simulation
    from rodfem.solver.adaptive.compiled import CompiledSteps

    check = Simulation.check

    def stopping(self, since=None):
        check(self, since)  # called as rows are recorded, by the stepper or compiled steps
        history = self.history
        if history.count and history._clock[history.count - 1, 2] == 1.0:  # an event's row
            os.kill(os.getpid(), signal.SIGINT)  # in the time loop: noted, the step ends

    scene = {**TIGHT, "time.scheme": scheme}
    if not stop_at_event:
        return api.simulate("stiff", scene, out=out)
    advance = CompiledSteps.advance

    def one(self, max_steps, *args):
        return advance(self, 1, *args)

    Simulation.check, CompiledSteps.advance = stopping, one
    try:
        return api.simulate("stiff", scene, out=out)
    finally:
        Simulation.check, CompiledSteps.advance = check, advance


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root, made = tmp_path_factory.mktemp("tight"), {}

    def of(scheme: str):
        if scheme not in made:
            made[scheme] = root / scheme, run(root / scheme, scheme)
        return made[scheme]

    return of


@serial_only
@pytest.mark.parametrize("scheme", ["crank-nicolson", "paper"])
def test_a_tight_tolerance_gets_past_the_impact_with_the_event_located(runs, scheme):
    out, result = runs(scheme)
    assert result.status == "complete", result.summary
    counts = result.summary["adaptive"]
    assert counts["events"] == 1 and counts["t"] == TIGHT["time.end"]
    history = read_history(out / "history.h5")
    at = np.flatnonzero(history["event"])
    assert at.size == 1
    k = int(at[0])
    assert history["t"][k] < TIGHT["time.end"] and k + 1 < len(history.rows)
    # contact begins in the event's step: the end reaches the gap there, from below, and the
    # step ends at most a bracket past it (u(1) moves ut(1) EVENT_WIDTH over the bracket; twice
    # that allows for the velocity's change across it and the discrete velocity's own error)
    before, after = history["u_1"][k - 1] - GAP, history["u_1"][k] - GAP
    assert before < 0.0 < after <= 2.0 * abs(history["ut_1"][k]) * EVENT_WIDTH
    assert min(history["dt"][1:]) >= 1e-9  # time.dt_min: no step below it


@serial_only
def test_a_run_stopped_at_the_event_resumes_to_the_same_run(runs, tmp_path):
    """Stopped as the event's step ends (the checkpoint holds one state since the event: the
    restarted estimate), the resumed run takes the halves and the steps after them as the
    uninterrupted run did."""
    reference, _ = runs("crank-nicolson")
    out = tmp_path / "stopped"
    stopped = run(out, "crank-nicolson", stop_at_event=True)
    assert stopped.status == "interrupted"
    history = read_history(out / "history.h5")
    assert history["event"][-1] == 1.0  # the checkpoint is the event's step
    rodfem("resume", out, "--quiet", check=0)
    assert_same_run(out, reference)
    summary = json.loads((out / "summary.json").read_text())
    expected = json.loads((reference / "summary.json").read_text())
    assert summary["adaptive"] == expected["adaptive"]
