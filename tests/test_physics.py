"""Physics facts: analytic answers, conservation, invariants."""
import numpy as np
import pytest

from conftest import kinetic_energy, make_box_model, spring_energy
from jellysim.body import Body
from jellysim.model import finalize
from jellysim.params import GroundParams, ProvotParams
from jellysim.simulator import Simulator

BACKENDS = ["numpy", "numba"]
try:
    import warp  # noqa: F401
    _warp = []
except ImportError:
    _warp = [pytest.mark.skip(reason="warp-lang (the optional [gpu] extra) is not installed")]
STEP_BACKENDS = BACKENDS + [pytest.param("warp", marks=_warp)]
"""Backends of the whole explicit step (the Warp backend has run_steps only)."""


def two_masses(m=0.5, k=20.0, stretch=0.1):
    body = Body(points=np.array([[0.0, 0, 0], [1.0, 0, 0]]), springs=np.array([[0, 1]]),
                rest_length=np.array([1.0]))
    model = finalize(body, stiffness=k, point_mass=m, gravity=(0, 0, 0))
    state = model.state()
    state.x[1, 0] += stretch
    return model, state


@pytest.mark.parametrize("backend", STEP_BACKENDS)
def test_two_mass_spring_period(backend):
    m, k = 0.5, 20.0
    model, state = two_masses(m, k)
    T = 2 * np.pi * np.sqrt(m / (2 * k))
    dt = T / 2000
    sim = Simulator(model, dt=dt, integrator="symplectic", backend=backend, state=state)
    ext = []
    for _ in range(6000):  # three periods
        sim.advance(1)
        ext.append(sim.state.x[1, 0] - sim.state.x[0, 0] - 1.0)
    ext = np.array(ext)
    # upward zero crossings, linearly interpolated
    idx = np.nonzero((ext[:-1] < 0) & (ext[1:] >= 0))[0]
    times = (idx + 1 + (-ext[idx]) / (ext[idx + 1] - ext[idx])) * dt
    periods = np.diff(times)
    assert len(periods) >= 2
    assert np.allclose(periods, T, rtol=1e-4)


@pytest.mark.parametrize("backend", STEP_BACKENDS)
@pytest.mark.parametrize("integrator", ["paper", "symplectic"])
def test_free_fall_matches_exact_discrete_trajectory(backend, integrator):
    # points in free fall (springs of zero stiffness: the paper integrator, forward Euler,
    # would amplify round-off in stiff springs, see the test below)
    model = make_box_model(50, stiffness=0.0, damping=0.0)
    state = model.state()
    v0 = np.array([0.3, 1.0, -0.2])
    state.v[:] = v0
    dt, n = 0.01, 137
    sim = Simulator(model, dt=dt, integrator=integrator, backend=backend, state=state)
    sim.advance(n)
    g = model.gravity
    # paper: x_{n+1} = x_n + v_n dt, v_{n+1} = v_n + g dt  ->  x_n = x0 + n v0 dt + g dt^2 n(n-1)/2
    # symplectic: v first                                  ->  x_n = x0 + n v0 dt + g dt^2 n(n+1)/2
    tri = n * (n - 1) / 2 if integrator == "paper" else n * (n + 1) / 2
    expected = model.point_x0 + n * dt * v0 + g * dt**2 * tri
    assert np.allclose(sim.state.x, expected, rtol=0, atol=1e-12)
    assert np.allclose(sim.state.v, v0 + n * dt * g, rtol=0, atol=1e-12)


@pytest.mark.parametrize("backend", STEP_BACKENDS)
def test_internal_forces_conserve_momentum(backend):
    model = make_box_model(200, stiffness=80.0, gravity=(0, 0, 0))
    state = model.state()
    rng = np.random.default_rng(1)
    state.x += 0.01 * rng.standard_normal(state.x.shape)
    state.v[:] = rng.standard_normal(state.v.shape)
    p0 = (model.point_mass[:, None] * state.v).sum(axis=0)
    sim = Simulator(model, dt=1e-3, integrator="symplectic", backend=backend, state=state)
    sim.advance(300)
    p1 = (model.point_mass[:, None] * sim.state.v).sum(axis=0)
    scale = np.abs(model.point_mass[:, None] * state.v).sum()
    assert np.all(np.abs(p1 - p0) <= 1e-13 * scale * 300)


def test_symplectic_undamped_energy_stays_bounded():
    model = make_box_model(150, stiffness=40.0, gravity=(0, 0, 0))
    state = model.state()
    rng = np.random.default_rng(2)
    state.x += 0.01 * rng.standard_normal(state.x.shape)
    from jellysim.stability import estimate_stability

    dt = 0.2 / estimate_stability(model, "symplectic", 1.0).omega_max  # stable limit / 10
    sim = Simulator(model, dt=dt, integrator="symplectic", state=state)
    energies = []
    for _ in range(100):
        sim.advance(100)  # 10^4 steps in all
        energies.append(kinetic_energy(model, sim.state.v) + spring_energy(model, sim.state.x))
    e0 = energies[0]
    energies = np.array(energies)
    assert np.max(np.abs(energies - e0)) / e0 < 0.02
    # no secular drift: the last tenth averages the same as the first tenth
    assert abs(energies[-10:].mean() - energies[:10].mean()) / e0 < 0.005


def test_forward_euler_paper_integrator_gains_energy_without_damping():
    # documented fact: the report's order is forward Euler; undamped, energy grows
    model, state = two_masses()
    sim = Simulator(model, dt=1e-3, integrator="paper", state=state, check_stability=False)
    e0 = spring_energy(model, sim.state.x)
    sim.advance(5000)
    e1 = spring_energy(model, sim.state.x) + kinetic_energy(model, sim.state.v)
    omega2 = 2 * 20.0 / 0.5
    # energy grows by (1 + omega^2 dt^2) per step
    assert e1 / e0 == pytest.approx((1 + omega2 * 1e-6) ** 5000, rel=0.02)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("order", ["jacobi", "gauss-seidel"])
def test_provot_springs_enough_loops_puts_every_spring_in_band(backend, order):
    from jellysim.kernels import get_backend

    model = make_box_model(120, r=0.35)
    k = get_backend(backend)
    x = model.point_x0 + 0.02 * np.random.default_rng(5).standard_normal((120, 3))
    n, ns = model.point_count, model.spring_count
    tau = 0.01
    loops = 3000 if order == "jacobi" else 400
    from jellysim.kernels import records as rec

    passes, largest = k.provot(x, rec.point_arrays(model), rec.spring_arrays(model), tau,
                               loops, 1e-13, False, order == "gauss-seidel",
                               rec.explicit_scratch(n, ns))
    L = np.linalg.norm(x[model.spring_ij[:, 1]] - x[model.spring_ij[:, 0]], axis=1)
    strain = np.abs(L / model.spring_rest_length - 1)
    assert strain.max() <= tau + 1e-9
    assert passes < loops  # converged (stopped by the tolerance)


def test_provot_all_pairs_limits_every_pair():
    from jellysim.kernels import numba_backend as k

    model = make_box_model(60, r=0.5)
    x = model.point_x0 + 0.01 * np.random.default_rng(6).standard_normal((60, 3))
    n = 60
    from jellysim.kernels import records as rec

    k.provot(x, rec.point_arrays(model), rec.spring_arrays(model), 0.01, 5000, 1e-13, True,
             False, rec.explicit_scratch(n, model.spring_count))
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    d0 = np.linalg.norm(model.point_x0[:, None] - model.point_x0[None], axis=2)
    iu = np.triu_indices(n, 1)
    assert np.max(np.abs(d[iu] / d0[iu] - 1)) <= 0.01 + 1e-9


@pytest.mark.parametrize("backend", BACKENDS)
def test_ground_rule_on_hand_made_case(backend):
    from jellysim.kernels import get_backend

    k = get_backend(backend)
    x = np.array([[0.0, -0.2, 0.0], [1.0, 0.5, 0.0], [2.0, 0.0, 1.0]])
    v = np.array([[1.0, -3.0, 2.0], [1.0, -3.0, 2.0], [4.0, -1.0, 8.0]])
    a = np.array([[0.0, -9.8, 1.0], [0.0, -9.8, 1.0], [1.0, 5.0, 2.0]])
    mu, nu = 0.1, 0.2
    x1, v1, a1 = x.copy(), v.copy(), a.copy()
    status = k.finish_step(x1, v1, a1, True, 0.0, mu, nu, np.zeros(3), 1e6)
    assert status == 0
    # point 0 is below: y -> 0, vy -> 0, vx, vz *= mu, ay -> ay - nu ay
    assert np.array_equal(x1[0], [0.0, 0.0, 0.0])
    assert np.array_equal(v1[0], [mu * 1.0, 0.0, mu * 2.0])
    assert np.array_equal(a1[0], [0.0, -9.8 - nu * -9.8, 1.0])
    # points above or exactly on the plane are untouched
    assert np.array_equal(x1[1:], x[1:]) and np.array_equal(v1[1:], v[1:])
    assert np.array_equal(a1[1:], a[1:])


def test_nothing_below_ground_after_steps():
    model = make_box_model(300, stiffness=5.0, point_mass=0.05, damping=0.05,
                           lower=(0, 0.05, 0), upper=(1, 1.05, 1))
    sim = Simulator(model, dt=0.005, integrator="symplectic",
                    provot=ProvotParams(tau=0.01, loops=2), ground=GroundParams())
    for _ in range(40):
        sim.advance(5)
        assert sim.state.x[:, 1].min() >= 0.0
    assert np.any(sim.state.x[:, 1] == 0.0)  # it did land


def test_report_order_limit_with_unequal_masses_is_the_light_points():
    """A support made by a heavy mass (the springs path has no pin): a 1e9 kg anchor holding a
    0.5 kg bob on k = 20 N/m with delta = 0.2 kg/s.  The report's order (forward Euler) is
    stable for ``dt < c / omega^2`` with the bob's rate ``c = delta / m`` and ``omega^2 = k (1/m
    + 1/M)``: 0.01 s, and runs just below and above it do what that says."""
    from jellysim.stability import estimate_stability

    body = Body(points=np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                springs=np.array([[0, 1]]), masses=np.array([1e9, 0.5]))
    model = finalize(body, stiffness=20.0, damping=0.2, gravity=(0.0, 0.0, 0.0))
    exact = (0.2 / 0.5) / (20.0 * (1 / 0.5 + 1 / 1e9))
    est = estimate_stability(model, "paper", 0.01)
    assert est.dt_max == pytest.approx(exact / 1.05, rel=0.01)   # (power iteration's 5 % margin)

    def amplitude(dt):
        state = model.state()
        state.x[1, 1] = 1.1
        sim = Simulator(model, dt=dt, integrator="paper", state=state, check_stability=False)
        sim.advance(int(round(20.0 / dt)))
        return abs(sim.state.x[1, 1] - 1.0)

    assert amplitude(0.9 * exact) < 0.1     # decays
    assert amplitude(1.1 * exact) > 0.1     # grows


def test_ground_nu_acts_in_the_reports_step_only_and_a_scene_says_so():
    """The paper ground's ``nu`` rewrites the stored acceleration, which only the report's
    order reuses: with the symplectic step two values of nu give the same run (and a scene
    that sets it is warned), with the paper step they differ."""
    import warnings

    from jellysim.scene import Scene

    text = ("[body]\npoints = 120\ndistribution = 'uniform'\nlower = [0, 0.02, 0]\n"
            "upper = [0.5, 0.52, 0.5]\nseed = 3\n[springs]\nradius = 0.25\nstiffness = 300.0\n"
            "[mass]\npoint_mass = 0.1\n[physics]\ndamping = 0.05\n[integrator]\n"
            "name = '{integ}'\ndt = 0.002\nsteps = 200\n[ground]\nnu = {nu}\n")

    def run(integ, nu):
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            scene = Scene.from_text(text.format(integ=integ, nu=nu), name="nu.toml")
        sim = scene.simulator(settle=False)
        sim.advance(scene.steps)
        return sim.state.x.copy(), [str(w.message) for w in said if "nu =" in str(w.message)]

    a, said_a = run("symplectic", 0.0)
    b, said_b = run("symplectic", 0.9)
    assert np.array_equal(a, b)
    assert said_a == [] and len(said_b) == 1 and "changes nothing here" in said_b[0]
    c, said_c = run("paper", 0.0)
    d, said_d = run("paper", 0.9)
    assert np.max(np.abs(c - d)) > 1e-4 and said_c == said_d == []
