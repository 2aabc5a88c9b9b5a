"""An adaptive run's regular steps in compiled code (rodfem/solver/compiled/adaptive.h) decide as
the Python stepper does: the same steps, rejections, events and step sizes, and the same history
bit for bit, on each method and scheme the compiled loops do; what they hand back (events,
restarts, new step sizes, failures) is the stepper's."""

import numpy as np
import pytest

import rodfem.scene
from rodfem.output.columns import for_scene
from rodfem.run import simulate
from rodfem.solver.adaptive import compiled
from rodfem.solver.adaptive.stepper import AdaptiveStepper
from rodfem.solver.errors import StepTooSmall

# Short runs with contact events, rejected steps and both schemes' estimates.
CASES = {
    "paper1 picard": ("paper1", ["time.end=1.2"]),
    "paper1 direct": ("paper1", ["time.end=1.2", "solver.method=direct"]),
    # steps Picard's iteration does not solve, handed back to the stepper
    "paper1 picard failing": ("paper1", ["time.end=2", "obstacle.epsilon=1e-4"]),
    "stiff crank-nicolson": ("stiff", ["time.end=0.3", "time.scheme=crank-nicolson"]),
    "impact direct": ("impact", ["mesh.cells=200", "time.dt=5e-3", "time.end=1.5"]),
    "redistributed mass": ("impact", ["mesh.cells=100", "time.dt=1e-2", "time.end=1.5",
                                      "discretisation.mass=redistributed-lumped"]),
    # the rigid obstacle's impact, its first try where the end's tangent meets the obstacle
    "rigid paper": ("stiff", ["time.end=0.3", "obstacle.kind=rigid"]),
    # a viscous end without mass against the rigid obstacle: its multiplier jumps at the impact,
    # the step ending there is measured without it and the estimate restarts after the event
    "viscous rigid crank-nicolson": ("stiff", ["time.end=0.3", "time.scheme=crank-nicolson",
                                               "obstacle.kind=rigid",
                                               "discretisation.mass=redistributed"]),
    # (at this tolerance the step ending at the impact is rejected where p's jump is measured)
    "viscous rigid paper": ("stiff", ["time.end=0.225", "mesh.cells=100", "obstacle.kind=rigid",
                                      "discretisation.mass=redistributed-lumped",
                                      "time.tolerance=1e-6"]),
}


def run(name, overrides, regular: bool, monkeypatch=None):
    """The run without files, its regular steps compiled or all taken by the Python stepper;
    (result, calls of the compiled steps)."""
    calls = []
    advance = compiled.CompiledSteps.advance

    def counted(self, *args):
        calls.append(1)
        return advance(self, *args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(compiled.CompiledSteps, "advance", counted)
        if not regular:
            patch.setattr(compiled.CompiledSteps, "ready", lambda self: False)
        scene = rodfem.scene.load(name, [*overrides, "time.adaptive=true"])
        return simulate(scene, None, progress=False), len(calls), scene


@pytest.mark.parametrize("case", CASES)
def test_compiled_regular_steps_decide_as_the_stepper(case):
    name, overrides = CASES[case]
    python, none, scene = run(name, overrides, regular=False)
    fast, calls, _ = run(name, overrides, regular=True)
    assert none == 0 and calls > 0
    assert fast.summary["adaptive"] == python.summary["adaptive"]
    assert python.summary["adaptive"]["rejected"] + python.summary["adaptive"]["events"] > 0
    names = [column.name for column in for_scene(scene)]
    for j, column in enumerate(names):  # the same arithmetic in the same order
        np.testing.assert_array_equal(fast.history[:, j], python.history[:, j], err_msg=column)


def test_most_steps_are_taken_in_compiled_calls():
    """On paper1 the Python stepper takes only the events' and restarts' steps."""
    taken = []
    step = AdaptiveStepper.step

    def counted(self):
        taken.append(1)
        return step(self)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(AdaptiveStepper, "step", counted)
        result, calls, _ = run(*CASES["paper1 direct"], regular=True)
    steps = result.summary["adaptive"]["steps"]
    assert len(taken) < 0.05 * steps, (len(taken), steps)


@pytest.mark.parametrize("case", ["paper1 picard", "paper1 direct", "stiff crank-nicolson"])
def test_events_are_located_in_compiled_calls(case):
    """With the run's step sizes formed in C, an event's tries are too: the stepper locates
    none, and the run's events are all there."""
    located = []
    locate = AdaptiveStepper._locate

    def counted(self, *args):
        located.append(1)
        return locate(self, *args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(AdaptiveStepper, "_locate", counted)
        result, calls, _ = run(*CASES[case], regular=True)
    assert result.summary["adaptive"]["events"] > 0 and not located


def test_a_step_below_dt_min_is_refused_as_by_the_stepper():
    """Where the first regular step would be taken, the tolerance is made one no step meets: the
    run stops with the stepper's StepTooSmall, at the same step and time, whether the rejections
    are compiled or the stepper's."""
    messages = []
    ready = compiled.CompiledSteps.ready
    for regular in (False, True):
        tightened = []

        def tighten(self):
            is_ready = ready(self)
            if is_ready and not tightened:
                self.stepper.tolerance = self.R.tolerance = 1e-14
                tightened.append(1)
            return is_ready and regular

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(compiled.CompiledSteps, "ready", tighten)
            scene = rodfem.scene.load("paper1", ["time.end=1.2", "solver.method=direct",
                                                 "time.adaptive=true", "time.dt_min=1e-5"])
            result = simulate(scene, None, progress=False)
        assert tightened and result.status == "failed"
        assert isinstance(result.error, StepTooSmall)
        messages.append(str(result.error))
    assert messages[0] == messages[1]
    assert "time.dt_min = 1e-05" in messages[0]


def test_the_pool_of_sizes_changes_no_decision():
    """The sizes a compiled call forms are kept in a pool, the least recently used formed again:
    with the smallest pool (four slots) more sizes are formed, and the run is the same bit for
    bit, the stepper's too."""
    formed, histories = [], []
    advance = compiled.CompiledSteps.advance

    def kept(self, *args):
        code = advance(self, *args)
        formed[-1] = self.formed
        return code

    for budget in (compiled.POOL_BYTES, 0):
        formed.append(0)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(compiled, "POOL_BYTES", budget)
            patch.setattr(compiled.CompiledSteps, "advance", kept)
            result, calls, _ = run(*CASES["stiff crank-nicolson"], regular=True)
        histories.append(result)
    python, _, _ = run(*CASES["stiff crank-nicolson"], regular=False)
    assert formed[1] > formed[0] > 10
    for result in histories:
        assert result.summary["adaptive"] == python.summary["adaptive"]
        np.testing.assert_array_equal(result.history, python.history)
