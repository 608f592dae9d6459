"""Physical contact: restitution and Coulomb friction on point masses, obstacles, backends."""
import warnings

import numba

import numpy as np
import pytest

from conftest import make_box_model
from jellysim.body import Body
from jellysim.kernels import numba_backend as nbk
from jellysim.kernels import numpy_backend as npk
from jellysim.model import finalize
from jellysim.errors import StabilityWarning
from jellysim.params import GroundModel, GroundParams, ImplicitParams
from jellysim.physics.contact import Box, Plane, Sphere, pack_obstacles
from jellysim.simulator import Simulator

G = 9.8


def particles(points, mass=0.01):
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    body = Body(points=pts, springs=np.zeros((0, 2), dtype=np.int64))
    return finalize(body, point_mass=mass, gravity=(0.0, -G, 0.0))


def _integrator(name):
    """Simulator keywords for "symplectic", "implicit" (backward Euler) or "implicit-bdf2"."""
    if name == "implicit-bdf2":
        return {"integrator": "implicit", "implicit": ImplicitParams(scheme="bdf2")}
    return {"integrator": name}


def contact_ground(e, mu):
    return GroundParams(model=GroundModel.CONTACT, restitution=e, friction=mu)


@pytest.mark.parametrize("integrator,backend", [("symplectic", "numpy"),
                                                ("symplectic", "numba"),
                                                ("symplectic", "warp"),
                                                ("implicit", "numba"),
                                                ("implicit-bdf2", "numba"),
                                                ("implicit-bdf2", "numpy")])
def test_point_mass_rebounds_to_e_squared_h(integrator, backend):
    h, e, dt = 0.5, 0.6, 1e-4
    model = particles([0.0, h, 0.0])
    sim = Simulator(model, dt=dt, backend=backend, ground=contact_ground(e, 0.5),
                    **_integrator(integrator))
    bounced = False
    top = 0.0
    for _ in range(int(1.2 / dt)):
        sim.advance(1)
        y, vy = sim.state.x[0, 1], sim.state.v[0, 1]
        if vy > 0:
            bounced = True
        if bounced:
            top = max(top, y)
            if vy < 0:
                break
    assert bounced
    assert top == pytest.approx(e**2 * h, rel=0.01)


def tilted_plane(t_deg, mu_s, mu_k, slip_distance=0.0):
    """(D_c = 0: the coefficient is mu_k from the first substep of slip on, Coulomb's law of
    the closed forms below)"""
    t = np.radians(t_deg)
    normal = (-np.sin(t), np.cos(t), 0.0)  # the slope goes down towards +x
    return t, Plane(point=(0.0, 0.0, 0.0), normal=normal, restitution=0.0, friction=mu_k,
                    static_friction=mu_s, slip_distance=slip_distance)


@pytest.mark.parametrize("backend", ["numpy", "numba", "warp"])
def test_slip_weakening_shortens_a_slide_by_its_closed_form(backend):
    """Slip-weakening friction, mu(s) = mu_s - (mu_s - mu_k) min(s / D_c, 1): a point sliding
    from v0 on a level plane loses g (mu_k s + (mu_s - mu_k) D_c / 2) of v^2 / 2 over a slip
    s >= D_c, so it stops at v0^2 / (2 mu_k g) - (mu_s - mu_k) D_c / (2 mu_k); with D_c = 0 at
    v0^2 / (2 mu_k g) (Coulomb)."""
    v0, mu_s, mu_k, dt = 1.0, 0.6, 0.3, 1e-4
    stops = {}
    for dc in (0.0, 0.02):
        model = particles([0.0, 0.0, 0.0])
        plane = Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0), restitution=0.0,
                      friction=mu_k, static_friction=mu_s, slip_distance=dc)
        sim = Simulator(model, dt=dt, backend=backend, obstacles=[plane])
        sim.state.v[0] = (v0, 0.0, 0.0)
        sim.advance(int(0.5 / dt))  # stops after v0 / (mu_k g) = 0.34 s
        assert abs(sim.state.v[0, 0]) < 1e-12
        stops[dc] = float(sim.state.x[0, 0])
    coulomb = v0**2 / (2 * mu_k * G)
    assert stops[0.0] == pytest.approx(coulomb, abs=2 * v0 * dt)
    assert stops[0.02] == pytest.approx(coulomb - (mu_s - mu_k) * 0.02 / (2 * mu_k),
                                        abs=2 * v0 * dt)


@pytest.mark.parametrize("integrator", ["symplectic", "implicit", "implicit-bdf2"])
def test_point_on_slope_below_friction_angle_stays_put(integrator):
    mu_s, mu_k = 0.6, 0.3
    t, plane = tilted_plane(25.0, mu_s, mu_k)  # tan 25 deg = 0.47 < 0.6
    assert np.tan(t) < mu_s
    model = particles([0.0, 0.0, 0.0])
    sim = Simulator(model, dt=1e-3, obstacles=[plane], **_integrator(integrator))
    sim.advance(1000)
    assert np.linalg.norm(sim.state.x[0]) < 1e-9
    assert np.linalg.norm(sim.state.v[0]) < 1e-9


@pytest.mark.parametrize("integrator", ["symplectic", "implicit", "implicit-bdf2"])
def test_point_on_slope_above_friction_angle_slides_at_coulomb_rate(integrator):
    mu_s, mu_k = 0.6, 0.3
    t, plane = tilted_plane(35.0, mu_s, mu_k)  # tan 35 deg = 0.70 > 0.6
    model = particles([0.0, 0.0, 0.0])
    dt, n = 1e-3, 500
    sim = Simulator(model, dt=dt, obstacles=[plane], **_integrator(integrator))
    sim.advance(n)
    down = np.array([np.cos(t), np.sin(t), 0.0])  # down the slope: +x, +y tilted... sign below
    down = -down if down[1] > 0 else down
    speed = float(sim.state.v[0] @ down)
    expected = G * (np.sin(t) - mu_k * np.cos(t))
    assert speed / (n * dt) == pytest.approx(expected, rel=0.01)
    # and it stays on the plane
    assert abs(sim.state.x[0] @ np.array(plane.normal)) < 1e-9


@pytest.mark.parametrize("integrator", ["symplectic", "implicit", "implicit-bdf2"])
def test_nothing_ends_inside_sphere_or_box_obstacles(integrator):
    rng = np.random.default_rng(4)
    pts = rng.uniform((-0.3, 0.6, -0.3), (0.3, 1.0, 0.3), (200, 3))
    model = particles(pts)
    # apart from each other and from the ground: one projection pass per step cannot resolve
    # a point wedged between two obstacles (a documented limitation)
    sphere = Sphere(center=(-0.15, 0.35, 0.0), radius=0.2, restitution=0.2, friction=0.4)
    box = Box(lower=(0.1, 0.0, -0.3), upper=(0.3, 0.3, 0.3), restitution=0.2, friction=0.4)
    sim = Simulator(model, dt=2e-3, obstacles=[sphere, box], ground=contact_ground(0.2, 0.4),
                    **_integrator(integrator))
    touched = np.zeros(len(pts), bool)
    for _ in range(60):
        sim.advance(10)
        x = sim.state.x
        r = np.linalg.norm(x - sphere.center, axis=1)
        inside_box = np.all((x > np.array(box.lower) + 1e-9) & (x < np.array(box.upper) - 1e-9),
                            axis=1)
        assert r.min() >= 0.2 - 1e-9
        assert not inside_box.any()
        assert x[:, 1].min() >= -1e-12
        touched |= (np.abs(r - 0.2) < 1e-6) | ((np.abs(x[:, 1] - 0.3) < 1e-6) & (x[:, 0] > 0.1))
    assert touched.sum() > 10  # many landed on the sphere or the box top


def test_contact_kernels_agree():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (500, 3))
    v = rng.standard_normal((500, 3))
    kind, data = pack_obstacles([
        Plane(point=(0, -0.2, 0), normal=(0.1, 1, 0), restitution=0.4, friction=0.3,
              static_friction=0.5, slip_distance=0.02),
        Sphere(center=(0.3, 0.2, 0.1), radius=0.4, restitution=0.1, friction=0.8),
        Box(lower=(-0.9, 0.0, -0.5), upper=(-0.2, 0.7, 0.5), restitution=0.0, friction=0.2)])
    _kernels_agree(x, v, kind, data)


def _kernels_agree(x, v, kind, data):
    """The numpy spec's and the numba kernel's contact on the same points agree to 1e-13
    (positions, velocities and the slip state, from slips on both sides of D_c) and change
    the velocities."""
    out = []
    slip0 = np.random.default_rng(1).uniform(0.0, 0.04, len(x)) * (np.arange(len(x)) % 3 > 0)
    for k in (npk, nbk):
        xx, vv, ss = x.copy(), v.copy(), slip0.copy()
        k.contact(xx, vv, kind, data, 0.05, 1e-3, ss)
        out.append((xx, vv, ss))
    for a, b in zip(*out):
        assert np.allclose(a, b, rtol=0, atol=1e-13)
    assert not np.allclose(out[0][1], v)
    assert not np.array_equal(out[0][2], slip0)


def _implicit_sim(backend, threads=None, n=300, scheme="theta"):
    m = make_box_model(n, stiffness=40.0, damping=0.01, point_mass=0.02,
                       lower=(0, 0.03, 0), upper=(1, 1.03, 1))
    return Simulator(m, dt=1 / 60, integrator="implicit", backend=backend, threads=threads,
                     ground=contact_ground(0.3, 0.6),
                     implicit=ImplicitParams(theta=0.7, scheme=scheme),
                     obstacles=[Sphere(center=(0.5, -0.41, 0.5), radius=0.43)])  # top: 2 cm


@pytest.mark.parametrize("scheme", ["theta", "bdf2"])
def test_implicit_steps_agree(scheme):
    # contact decisions (v_n <= 0, phi <= margin) are discontinuous, so round-off differences
    # between the backends would grow over many steps: compare one step at a time from the
    # same state
    ref, fast = _implicit_sim("numpy", scheme=scheme), _implicit_sim("numba", scheme=scheme)
    landed = False
    for _ in range(30):
        ref.advance(1)
        fast.advance(1)
        assert np.allclose(ref.state.x, fast.state.x, rtol=0, atol=1e-12)
        # BDF2 sets a constrained point's normal velocity from its step, (x_new - x_n) / dt:
        # round-off in x is divided by dt
        assert np.allclose(ref.state.v, fast.state.v, rtol=0,
                           atol=1e-10 if scheme == "theta" else 1e-9)
        assert np.array_equal(ref._cobs, fast._cobs)
        landed |= bool((ref._cobs >= 0).any())
        assert np.array_equal(ref._fresh, fast._fresh)
        for dst, src in zip([fast.state.x, fast.state.v, fast.state.a, *fast._cg,
                             fast._cobs, fast._contact_state, fast._hist, fast._fresh],
                            [ref.state.x, ref.state.v, ref.state.a, *ref._cg, ref._cobs,
                             ref._contact_state, ref._hist, ref._fresh]):
            dst[...] = src
        fast._last = ref._last
    assert landed


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
@pytest.mark.parametrize("scheme", ["theta", "bdf2"])
def test_implicit_one_and_two_threads_bitwise_equal(scheme):
    results = []
    for threads in (1, 2):
        sim = _implicit_sim("numba", threads=threads, n=2000, scheme=scheme)
        sim.advance(20)
        results.append(sim.state)
    assert np.array_equal(results[0].x, results[1].x)
    assert np.array_equal(results[0].v, results[1].v)


def test_bad_obstacles_are_refused():
    """When made (a ParameterError naming the value), and a contact ground's by the Simulator
    (a SceneError naming the ground)."""
    from jellysim.errors import ParameterError, SceneError

    with pytest.raises(ParameterError, match="restitution"):
        Plane(restitution=1.5)
    with pytest.raises(ParameterError, match="static friction"):
        Plane(friction=0.5, static_friction=0.2)
    with pytest.raises(ParameterError, match="normal must be a non-zero vector"):
        Plane(normal=(0.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="slip_distance"):
        Sphere(radius=0.1, slip_distance=-1e-3)
    model = particles([0.0, 1.0, 0.0])
    with pytest.raises(SceneError, match=r"ground: static friction \(0.2\) must be >= kinetic"):
        Simulator(model, dt=1e-3, ground=GroundParams(model=GroundModel.CONTACT, friction=0.5,
                                                      static_friction=0.2))


def _sliding_gelatin_block(integrator, backend="numba", mu=0.3, v0=1.0, frames=36):
    """A 4 x 2 x 4 cm springs-gelatin block launched at v0 on a plate at dt = 1/60 s: its
    centre of mass [m] and speed [m/s] per frame, and its top [m] per frame."""
    from bodies import kuhn_box
    from jellysim.params import Material
    from jellysim.physics.policy import physical_model

    body = kuhn_box((4, 2, 4), upper=(0.04, 0.02, 0.04))
    model = physical_model(body, Material(model="springs"), gravity=(0.0, -G, 0.0))
    sim = Simulator(model, dt=1 / 60, backend=backend, threads=1,
                    ground=contact_ground(0.0, mu), **_integrator(integrator))
    sim.state.v[:, 0] = v0
    m = model.point_mass / model.point_mass.sum()
    com, speed, top = [m @ sim.state.x[:, 0]], [m @ sim.state.v[:, 0]], [sim.state.x[:, 1].max()]
    for _ in range(frames):
        sim.advance(1)
        com.append(m @ sim.state.x[:, 0])
        speed.append(m @ sim.state.v[:, 0])
        top.append(sim.state.x[:, 1].max())
    return np.array(com) - com[0], np.array(speed), np.array(top), sim


@pytest.mark.parametrize("integrator", ["implicit", "implicit-bdf2"])
def test_implicit_sliding_block_obeys_coulomb(integrator):
    """Coulomb in the implicit integrator at the frame step: a block sliding at 1 m/s on a plate
    (mu = 0.3) slows by exactly mu g dt per frame (its weight on the plate, friction at every
    point inside the solve), does not pitch forward, and stops where the integrator's own
    discretisation of v0^2 / (2 mu g) says: backward Euler moves a point by dt v_new, which
    takes v0 dt / 2 off (first order); BDF2 (second order) lands on it."""
    mu, v0, dt = 0.3, 1.0, 1 / 60
    com, speed, top, _ = _sliding_gelatin_block(integrator, mu=mu, v0=v0)
    # while it slides (frames 2-14, after the first contact settled the support) the plate
    # carries its weight on average, so the mean deceleration is mu g; frame by frame the
    # support (and so the friction) breathes by a few % as the block settles
    decel = -np.diff(speed[2:15]) / dt
    mean = (speed[2] - speed[14]) / (12 * dt)
    print(f"deceleration mean {mean:.4f} m/s^2 (mu g = {mu * G:.4f}), per frame "
          f"{decel.min():.4f}..{decel.max():.4f}; slid {com[-1]:.4f} m; "
          f"top rose {top.max() - top[0]:.2e} m")
    assert mean == pytest.approx(mu * G, rel=0.01)
    assert np.allclose(decel, mu * G, rtol=0.05)
    assert abs(speed[-1]) < 5e-3
    assert top.max() - top[0] < 1e-3
    expected = v0**2 / (2 * mu * G) - (v0 * dt / 2 if integrator == "implicit" else 0.0)
    assert com[-1] == pytest.approx(expected, rel=0.01)


def test_implicit_friction_spec_and_numba_agree():
    """The active-set friction of the numba implicit kernels follows the numpy spec."""
    a = _sliding_gelatin_block("implicit", backend="numpy", frames=6)
    b = _sliding_gelatin_block("implicit", backend="numba", frames=6)
    assert np.allclose(a[3].state.x, b[3].state.x, rtol=0, atol=1e-12)
    assert np.allclose(a[3].state.v, b[3].state.v, rtol=0, atol=1e-12)


def test_a_no_slip_plate_holds_what_coulomb_friction_lets_slide():
    """A gelatin block (FEM tets) on a plate tilted 30 deg (gravity tilted: tan 30 = 0.58 >
    mu = 0.3): with Coulomb friction it slides down at about g (sin - mu cos) (> 20 cm in
    0.5 s); on a no-slip plate (a wet plate's adhesion) it stays, leaning over its base (centre
    of mass < 2 mm, base points < 0.5 mm: a touching point never moves along the plate, the
    upslope edge may lift and land again).  The numpy spec and the numba
    kernel agree on the no-slip rule; the implicit integrator refuses it."""
    from bodies import kuhn_box
    from jellysim.errors import SceneError
    from jellysim.params import GroundModel, GroundParams
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin

    t = np.radians(30.0)
    body = kuhn_box((3, 2, 3), upper=(0.03, 0.02, 0.03))
    model = physical_model(body, gelatin(), gravity=(G * np.sin(t), -G * np.cos(t), 0.0))
    m = model.point_mass / model.point_mass.sum()
    moved = {}
    for no_slip in (False, True):
        ground = GroundParams(model=GroundModel.CONTACT, friction=0.3, no_slip=no_slip)
        sim = Simulator(model, dt=1 / 60, ground=ground)
        sim.advance(30)
        moved[no_slip] = float(m @ sim.state.x[:, 0] - m @ model.point_x0[:, 0])
        base = model.point_x0[:, 1] < 1e-9
        if no_slip:  # the base stays put (the upslope edge may lift and land again nearby)
            assert np.abs(sim.state.x[base][:, [0, 2]] - model.point_x0[base][:, [0, 2]]).max() \
                < 5e-4
    assert moved[False] > 0.2 and abs(moved[True]) < 2e-3
    rng = np.random.default_rng(1)
    x, v = rng.uniform(-1, 1, (400, 3)), rng.standard_normal((400, 3))
    kind, data = pack_obstacles([Plane(point=(0, 0, 0), normal=(0.2, 1, 0), no_slip=True),
                                 Sphere(center=(0.3, 0.2, 0.1), radius=0.4, friction=0.5)])
    _kernels_agree(x, v, kind, data)
    with pytest.raises(SceneError, match="no_slip .* explicit integrators"):
        Simulator(finalize_springs(), dt=1e-3, integrator="implicit",
                  ground=GroundParams(model=GroundModel.CONTACT, no_slip=True))


def finalize_springs():
    from jellysim.model import finalize
    from bodies import kuhn_box

    return finalize(kuhn_box((2, 2, 2), upper=(0.02, 0.02, 0.02)), stiffness=50.0)


@pytest.mark.parametrize("mu_k", [0.5, 0.3])
def test_a_block_tilted_slowly_holds_to_its_friction_angle_and_slips_past_it(mu_k):
    """The classroom plank: a gelatin block (its own 3 x 1.5 x 2.5 cm, E = 30 kPa, nu = 0.45)
    settled on the contact ground, then gravity turned 1 deg every 0.1 s.  With mu_s = 0.5
    (atan 26.57 deg) it holds still through 23 deg (centre of mass < 0.1 mm along the slope,
    at rest; through 25 deg with mu_k = mu_s) and slides by 30 deg, whether mu_k is 0.5 or
    0.3 (atan 16.7 deg): slip-weakening keeps the static coefficient over the first D_c of
    slip, which the creep of the base's edges stays below (docs/physics.md section 2).
    Sliding at mu_k = 0.3 it speeds up near g (sin t - mu_k cos t), far above what mu_s
    would let it."""
    import dataclasses

    import jellysim as js

    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=300)
    mat = js.material("gelatin", youngs_modulus=3e4, poisson_ratio=0.45, damping_ratio=0.05,
                      damping_frequency=20.0)
    model = js.physical_model(body, mat)
    sim = js.Simulator(model, dt=1 / 240, ground=GroundParams(
        model=GroundModel.CONTACT, friction=mu_k, static_friction=0.5, restitution=0.0))
    sim.settle()
    m = model.point_mass / model.point_mass.sum()
    x0 = float(m @ sim.state.x[:, 0])
    for theta in range(1, 31):
        t = np.radians(theta)
        sim.model = dataclasses.replace(sim.model, gravity=np.array(
            [G * np.sin(t), -G * np.cos(t), 0.0]))
        sim.advance(24)
        moved, speed = float(m @ sim.state.x[:, 0]) - x0, float(m @ sim.state.v[:, 0])
        if theta <= (25 if mu_k == 0.5 else 23):  # (atan(mu_k) = 16.7 deg for mu_k = 0.3)
            assert abs(moved) < 1e-4 and abs(speed) < 1e-3, (theta, moved, speed)
        if theta == 29:
            before = speed
        if theta == 30:
            assert moved > 5e-3 and speed > 0.05, (moved, speed)
            if mu_k < 0.5:  # sliding, the kinetic coefficient rules: x is the slope's
                # direction (gravity is turned, the ground stays y = 0), so the block gains
                # g (sin t - mu cos t) along x: 2.354 m/s^2 at mu_k = 0.3 (measured 2.356),
                # 0.656 at mu_s = 0.5
                rate = (speed - before) / 0.1
                assert rate == pytest.approx(G * (np.sin(t) - mu_k * np.cos(t)), rel=0.05)


def test_the_slip_state_is_checkpointed_and_resumes_bitwise():
    """The slip-weakening state is part of a run's internal state: a sliding gelatin block
    (mu_s 0.8, mu_k 0.3, D_c 1 cm) resumed from another's state and internal_state ends
    bitwise equal to it; resumed with every point's slip reset (a file of an earlier
    version: 9-column obstacle rows, no slip) it is accepted and the runs part."""
    import jellysim as js

    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=200)
    model = js.physical_model(body, js.material("gelatin", youngs_modulus=3e4))
    ground = GroundParams(model=GroundModel.CONTACT, friction=0.3, static_friction=0.8,
                          slip_distance=0.01, restitution=0.0)

    def sim():
        return Simulator(model, dt=1 / 120, ground=ground)

    a = sim()
    a.state.v[:, 0] = 0.5
    a.advance(6)
    state, inner = a.state.copy(), a.internal_state()
    s = inner["_slip"]
    assert np.any((s > 0.0) & (s < 0.01))  # some points still weakening
    a.advance(6)
    b = sim()
    b.state.assign(state)
    b.restore_internal_state(inner)
    b.advance(6)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    old = {k: v for k, v in inner.items() if k != "_slip"}
    old["_obstacle_data"] = a._obstacle_data[:, :9]  # (older files held it; read, ignored)
    c = sim()
    c.state.assign(state)
    c.restore_internal_state(old)
    c.advance(6)
    assert not np.array_equal(a.state.x, c.state.x)


@pytest.mark.parametrize("slip_distance", [1e-4, 1e-3])
def test_a_block_set_down_on_a_slope_between_its_friction_angles_stays_put(slip_distance):
    """A gelatin block (3 x 1.5 x 2.5 cm, 30 kPa) settled directly on a 24 deg slope with
    mu_s 0.5 and mu_k 0.3 (atan 26.6 and 16.7 deg) is held by static friction: settling
    sets it down gently (the slip of its base spreading under its own weight is healed as
    it goes: measured ~0.16 mm, more than a D_c of 0.1 mm, with which it slid at 22 deg when
    settling did not heal it), and over the next second its centre of mass moves
    < 0.1 mm; a rigid block sliding on mu_k would cover g (sin t - mu_k cos t) / 2 = 0.65 m."""
    import dataclasses

    import jellysim as js

    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=300)
    mat = js.material("gelatin", youngs_modulus=3e4, poisson_ratio=0.45, damping_ratio=0.05,
                      damping_frequency=20.0)
    model = js.physical_model(body, mat)
    sim = js.Simulator(model, dt=1 / 240, ground=GroundParams(
        model=GroundModel.CONTACT, friction=0.3, static_friction=0.5, restitution=0.0,
        slip_distance=slip_distance))
    t = np.radians(24.0)
    sim.model = dataclasses.replace(sim.model, gravity=np.array(
        [G * np.sin(t), -G * np.cos(t), 0.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # it comes to rest
        sim.settle()
    m = model.point_mass / model.point_mass.sum()
    x0 = float(m @ sim.state.x[:, 0])
    sim.advance(240)
    assert abs(float(m @ sim.state.x[:, 0]) - x0) < 1e-4


@pytest.mark.parametrize("mu, ratio", [(0.8, 0.9), (0.6, 0.9), (0.6, 1.05)])
def test_a_block_set_down_on_a_slope_holds_below_its_friction_angle(mu, ratio):
    """A gelatin block (3 x 1.5 x 2.5 cm, E = 30 kPa, 280 points) set down at rest on a slope
    (gravity tilted) with mu_s = mu_k = mu and settled: below the friction angle (tan t =
    0.9 mu) it stays put for 1 s (centre of mass < 0.1 mm, at rest), above it (1.05 mu) it
    slides (the rigid-block answer: it holds while tan t <= mu).  Before settle turned the
    load on gently (SETTLE_RAMP), gravity's dynamic overshoot broke the base loose at 0.875
    atan(mu) (mu = 0.8) and the block then slid down for ever."""
    import jellysim as js

    t = np.arctan(ratio * mu)
    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=280)
    mat = js.material("gelatin", youngs_modulus=3e4, poisson_ratio=0.45, damping_ratio=0.05,
                      damping_frequency=20.0)
    model = js.physical_model(body, mat, gravity=(G * np.sin(t), -G * np.cos(t), 0.0))
    sim = Simulator(model, dt=1 / 60, ground=GroundParams(
        model=GroundModel.CONTACT, friction=mu, restitution=0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # above the angle settle warns that it slid
        sim.settle(max_seconds=1.0)
    m = model.point_mass / model.point_mass.sum()
    x0 = float(m @ sim.state.x[:, 0])
    sim.advance(60)
    moved, speed = float(m @ sim.state.x[:, 0]) - x0, float(m @ sim.state.v[:, 0])
    if ratio < 1.0:
        assert abs(moved) < 1e-4 and abs(speed) < 1e-3, (moved, speed)
    else:
        assert moved > 0.02 and speed > 0.05, (moved, speed)


def test_settle_under_a_standing_force_that_drags_the_block_says_so():
    """A force with no release is a load the body settles under; one that beats friction
    (2 mu M g) drags the block while it settles, and the warning names the standing force
    (it named only a slope: session 16's teacher trial).  The ramped load still reaches it in
    full: the block has moved about the free answer (F/M - mu g) t^2 / 2 damped by settle's
    drag, i.e. a lot, and its speed is set back to zero."""
    import jellysim as js

    body = js.Body.box(lower=(0, 0, 0), upper=(0.03, 0.015, 0.025), points=120)
    model = js.physical_model(body, js.material("gelatin", youngs_modulus=3e4))
    sim = Simulator(model, dt=1 / 60, ground=GroundParams(
        model=GroundModel.CONTACT, friction=0.3, restitution=0.0))
    weight = float(model.point_mass.sum()) * G
    sim.apply_force(np.arange(model.point_count), (2 * 0.3 * weight, 0.0, 0.0))
    with pytest.warns(StabilityWarning, match=r"did not come to rest.*standing point force"):
        sim.settle(max_seconds=0.5)
    m = model.point_mass / model.point_mass.sum()
    assert float(m @ sim.state.x[:, 0] - m @ model.point_x0[:, 0]) > 0.01
    assert not sim.state.v.any()


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_a_resting_body_is_at_rest_whatever_its_restitution(backend):
    """The preset's 10 cm gelatin cube (216 points) settled on the contact ground with the
    default restitution 0.3 and then left for 1 s is at rest: kinetic energy < 1e-9 J and its
    base points' normal speed < 1e-6 m/s (the body's load drove each base point into the plate
    faster than the rest speed 2|g|dt, so each bounced at e every substep: 4.0e-5 J and
    +0.065 m/s while the positions stayed put, session 16's teacher trial).  A point that
    touched at a step's start is in resting contact (contact_numpy.touching); a point mass
    dropped still bounces at e (test_point_mass_rebounds_to_e_squared_h, validate_bounce)."""
    import jellysim as js

    body = js.Body.box(points=216)
    model = js.physical_model(body, js.material("gelatin"))
    sim = Simulator(model, dt=1 / 60, backend=backend, ground=GroundParams(
        model=GroundModel.CONTACT, friction=0.5))
    assert sim._obstacle_data[0, 6] == pytest.approx(0.3)  # (the default restitution)
    sim.settle()
    sim.advance(60)
    base = model.point_x0[:, 1] < 1e-9
    assert sim.energy()["kinetic"] < 1e-9
    assert np.abs(sim.state.v[base, 1]).max() < 1e-6
