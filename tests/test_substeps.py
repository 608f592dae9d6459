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


def test_auto_substeps_of_the_springs_symplectic_path_keep_it_stable():
    """substeps = 'auto' (the default) on the springs' symplectic path: dt over 0.9 of the
    estimated stable step, so a dt 20x beyond it runs bounded where one step per dt blows up
    (undamped, gravity off, random start: the energy, measured per frame, fluctuates -- the
    highest modes run near the limit, where symplectic Euler conserves a modified energy --
    but stays within 0.5-2.5x of its start with no drift); an explicit substep count is kept
    and warned about with the count that would do."""
    from conftest import spring_energy
    from jellysim.params import GroundParams, ProvotParams

    m = make_box_model(150, stiffness=400.0, gravity=(0.0, 0.0, 0.0))
    limit = estimate_stability(m, "symplectic", 1.0).dt_max
    dt = 20.0 * limit
    free = dict(provot=ProvotParams(enabled=False), ground=GroundParams(enabled=False))
    sim = Simulator(m, dt=dt, integrator="symplectic", **free)
    assert sim.substeps == int(np.ceil(dt / (0.9 * limit)))
    rng = np.random.default_rng(0)
    sim.state.x += rng.standard_normal(sim.state.x.shape) * 0.005
    start = sim.state.x.copy()
    e0 = spring_energy(m, sim.state.x)
    ratio = []
    for _ in range(40):
        sim.advance(1)
        ratio.append((spring_energy(m, sim.state.x)
                      + 0.5 * np.sum(m.point_mass[:, None] * sim.state.v**2)) / e0)
    assert 0.5 < min(ratio) and max(ratio) < 2.5
    assert abs(np.mean(ratio[-10:]) / np.mean(ratio[:10]) - 1) < 0.15
    with pytest.warns(StabilityWarning, match=r"or substeps >= 23 \(or 'auto'"):
        one = Simulator(m, dt=dt, integrator="symplectic", substeps=1, **free)
    one.state.x[:] = start
    with pytest.raises(Exception, match="unstable"):
        one.advance(40)
    # the report's own step keeps one step per dt (the paper integrator is not substepped)
    with pytest.warns(StabilityWarning):
        assert Simulator(m, dt=dt, integrator="paper").substeps == 1
