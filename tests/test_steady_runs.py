"""Time runs of barber settle on the stable steady states rodfem steady predicts: started cool
and at rest, on the separated one; started hot and touching, on the pressed one."""

import numpy as np
import pytest

import rodfem.scene
from rodfem.model import steady

STATES = steady.of_scene(rodfem.scene.load("barber", [])).states()
HOT = ("initial.theta0=10*x", "initial.u0=0.02*x")


@pytest.mark.parametrize("method", ["direct", "newton", "picard"])
@pytest.mark.parametrize("start, index", [((), 0), (HOT, 2)])
def test_runs_settle_on_the_predicted_state(simulate, method, start, index):
    result, _ = simulate("barber", *start, f"solver.method={method}")
    assert result.status == "complete"
    exact = STATES[index].displacement(result.x)
    assert np.max(np.abs(result.u - exact)) < 1e-9
