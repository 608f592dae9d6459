"""Substeps: n substeps of dt / n are n steps of dt / n; the guard checks dt / n."""
import warnings

import numpy as np
import pytest

from conftest import make_box_model
from jellysim.simulator import Simulator, StabilityWarning
from jellysim.stability import estimate_stability


@pytest.mark.parametrize("integrator", ["symplectic", "implicit"])
def test_substeps_equal_small_steps(integrator):
    m = make_box_model(150, stiffness=40.0, damping=0.01)
    a = Simulator(m, dt=0.004, integrator=integrator, substeps=4, check_stability=False)
    b = Simulator(m, dt=0.001, integrator=integrator, check_stability=False)
    a.advance(10)
    b.advance(40)
    assert np.array_equal(a.state.x, b.state.x)
    assert a.state.t == pytest.approx(b.state.t, rel=1e-12) and a.state.step == 10


def test_guard_checks_the_substep():
    m = make_box_model(150, stiffness=400.0)
    limit = estimate_stability(m, "symplectic", 1.0).dt_max
    with pytest.warns(StabilityWarning, match="substeps >= 4"):
        Simulator(m, dt=3.5 * limit, integrator="symplectic", substeps=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", StabilityWarning)
        Simulator(m, dt=3.5 * limit, integrator="symplectic", substeps=4)
