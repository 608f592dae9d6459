"""The Warp backend (NVIDIA Warp; here on Warp's CPU device) against the numba backend.

One Warp module compiles once per session (about 10-20 s cold, then Warp's kernel cache).
The float64 kernels repeat the numba arithmetic operation for operation, so agreement is
asserted at 1e-12 m per step (in practice it is bitwise on the CPU device); float32 within the
documented bound :data:`FLOAT32_PAPER_CUBE_BOUND_M`.
"""
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import make_box_model
from jellysim.errors import SceneError, SimulationError
from jellysim.params import GroundParams, ProvotParams
from jellysim.physics.contact import Box, Sphere
from jellysim.scene import Scene
from jellysim.simulator import Simulator

ROOT = Path(__file__).resolve().parents[1]

FLOAT32_PAPER_CUBE_BOUND_M = 2e-4
"""float32 Warp vs float64 numba on the paper cube (1 m, 600 points, 100 steps of 0.01 s) with
Provot's Jacobi pass and the velocity update: the largest point distance [m] at any step
(measured 5.4e-5 m; the all-pairs Provot band
tau = 0.1 % of the rest length switches on rounding-level differences)."""


@pytest.fixture(scope="module")
def warp():
    return pytest.importorskip("warp", reason="warp-lang is the optional [gpu] extra")


def _paper_cube():
    scene = Scene.load(ROOT / "examples" / "paper_cube.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scene, scene.build_model()


def test_paper_scene_agrees_with_numba_every_step_float64(warp):
    scene, model = _paper_cube()
    ref = scene.simulator(model, backend="numba")
    sim = scene.simulator(model, backend="warp", device="cpu")
    assert sim._k.device == "cpu" and sim._k.precision == "float64"
    worst = 0.0
    for _ in range(100):
        ref.advance(1)
        sim.advance(1)
        worst = max(worst, np.abs(sim.state.x - ref.state.x).max())
        assert np.abs(sim.state.x - ref.state.x).max() <= 1e-12
        assert np.abs(sim.state.v - ref.state.v).max() <= 1e-10
        assert np.abs(sim.state.a - ref.state.a).max() <= 1e-8
    assert sim.state.step == ref.state.step == 100
    assert np.sum(ref.state.x[:, 1] == 0.0) > 10  # the ground rule acted
    # Provot (all pairs, the report's sequential order) acted: without it the cube differs
    from jellysim.params import ProvotParams

    free = scene.simulator(model, backend="numba", provot=ProvotParams(enabled=False))
    free.advance(100)
    assert np.abs(free.state.x - ref.state.x).max() > 1e-6


def test_paper_scene_float32_within_documented_bound(warp):
    scene, model = _paper_cube()
    # the averaged-Jacobi Provot with the velocity update (a bounded run): the report's literal
    # sequential step splashes chaotically, where float32 rounding grows to metres
    scene.params["provot"].update(order="jacobi", velocity_update=True)
    ref = scene.simulator(model, backend="numba")
    sim = scene.simulator(model, backend="warp", device="cpu", precision="float32")
    worst = 0.0
    for _ in range(100):
        ref.advance(1)
        sim.advance(1)
        worst = max(worst, np.abs(sim.state.x - ref.state.x).max())
    assert 0.0 < worst <= FLOAT32_PAPER_CUBE_BOUND_M
    # the state really was float32 on the device
    assert np.all(sim.state.x == sim.state.x.astype(np.float32))


OBSTACLES = (Sphere(center=(0.5, -0.39, 0.5), radius=0.4, restitution=0.5, friction=0.4),
             Box(lower=(0.8, -1.0, 0.8), upper=(1.5, 0.01, 1.5), restitution=0.2, friction=0.3))
"""Both just below the body's start (y >= 0.02): it falls onto them."""

CASES = {
    "paper-springs-fused": dict(integrator="paper", provot=ProvotParams(loops=1),
                                ground=GroundParams()),
    "paper-springs-3-tolerance": dict(integrator="paper",
                                      provot=ProvotParams(loops=3, tolerance=1e-5),
                                      ground=GroundParams()),
    "symplectic-springs-2": dict(integrator="symplectic", provot=ProvotParams(loops=2),
                                 ground=GroundParams()),
    "symplectic-gauss-seidel": dict(integrator="symplectic",
                                    provot=ProvotParams(loops=2, order="gauss-seidel"),
                                    ground=GroundParams()),
    "symplectic-contact": dict(integrator="symplectic", obstacles=OBSTACLES,
                               ground=GroundParams(model="contact", restitution=0.4,
                                                   friction=0.5)),
    "paper-contact-provot": dict(integrator="paper", provot=ProvotParams(loops=1),
                                 ground=GroundParams(model="contact"), obstacles=OBSTACLES),
}


@pytest.mark.parametrize("case", list(CASES))
def test_paths_agree_with_numba(warp, case):
    m = make_box_model(300, stiffness=20.0, damping=0.02, point_mass=0.05,
                       lower=(0, 0.02, 0), upper=(1, 1.02, 1))
    out = []
    for backend in ("numba", "warp"):
        sim = Simulator(m, dt=0.002, backend=backend, check_stability=False, **CASES[case])
        sim.state.v[:, 0] = 0.5  # sliding into the obstacles: friction and restitution act
        sim.state.v[:, 1] = -1.0
        sim.advance(150)
        out.append(sim.state)
    assert out[0].x[:, 1].min() <= 0.0  # the ground was reached
    assert np.abs(out[0].x - out[1].x).max() <= 1e-12
    assert np.abs(out[0].v - out[1].v).max() <= 1e-10
    assert np.abs(out[0].a - out[1].a).max() <= 1e-8


@pytest.mark.parametrize("integrator", ["paper", "symplectic"])
def test_provot_tolerance_stops_the_passes_on_the_device(warp, integrator):
    # a tolerance no correction exceeds: the device's "converged" flag skips passes 2 and 3,
    # so three loops give exactly one loop's result (as numba's break does)
    m = make_box_model(300, stiffness=20.0, damping=0.02, point_mass=0.05,
                       lower=(0, 0.02, 0), upper=(1, 1.02, 1))
    out = {}
    for backend, loops, tol in (("warp", 3, 0.5), ("warp", 1, 0.0), ("numba", 3, 0.5),
                                ("warp", 3, 0.0)):
        sim = Simulator(m, dt=0.002, integrator=integrator, backend=backend,
                        provot=ProvotParams(loops=loops, tolerance=tol), ground=GroundParams(),
                        check_stability=False)
        sim.state.v[:, 1] = -1.0
        sim.advance(100)
        out[backend, loops, tol] = sim.state.x
    assert np.array_equal(out["warp", 3, 0.5], out["warp", 1, 0.0])
    assert np.abs(out["warp", 3, 0.5] - out["numba", 3, 0.5]).max() <= 1e-12
    assert not np.array_equal(out["warp", 3, 0.0], out["warp", 1, 0.0])  # passes 2, 3 acted


def test_contact_acts_on_the_obstacles(warp):
    # the sphere and the box push the points out: nothing ends inside them
    m = make_box_model(300, stiffness=20.0, damping=0.02, point_mass=0.05,
                       lower=(0, 0.02, 0), upper=(1, 1.02, 1))
    sim = Simulator(m, dt=0.002, backend="warp", check_stability=False,
                    **CASES["symplectic-contact"])
    sim.state.v[:, 1] = -1.0
    sim.advance(150)
    x = sim.state.x
    r = np.linalg.norm(x - np.array([0.5, -0.39, 0.5]), axis=1)
    assert r.min() >= 0.4 - 1e-12 and x[:, 1].min() >= -1e-12
    near = r < 0.41  # points resting on the sphere
    assert near.sum() > 0


def test_two_runs_bitwise_equal_whatever_the_batching(warp):
    m = make_box_model(400, stiffness=20.0, damping=0.02, point_mass=0.05,
                       lower=(0, 0.01, 0), upper=(1, 1.01, 1))
    kw = dict(dt=0.002, integrator="paper", backend="warp", check_stability=False,
              provot=ProvotParams(loops=2), ground=GroundParams())
    a = Simulator(m, **kw)
    a.advance(60)
    b = Simulator(m, **kw)
    for _ in range(6):
        b.advance(10)
    for f in ("x", "v", "a"):
        assert np.array_equal(getattr(a.state, f), getattr(b.state, f))
    assert a.state.step == b.state.step == 60


def test_blow_up_stops_at_the_same_step_as_numba(warp):
    m = make_box_model(200, stiffness=500.0, damping=0.0, point_mass=0.01)
    rng = np.random.default_rng(1)
    kick = 0.01 * rng.standard_normal(m.point_x0.shape)
    results = []
    for backend in ("numba", "warp"):
        st = m.state()
        st.x += kick
        sim = Simulator(m, dt=0.02, integrator="paper", backend=backend, state=st,
                        check_stability=False)
        with pytest.raises(SimulationError) as info:
            sim.advance(500)
        results.append((info.value.step, info.value.status, sim.state.x.copy()))
    assert results[0][0] == results[1][0] < 500
    assert results[0][1] == results[1][1]
    finite = np.isfinite(results[0][2])
    assert np.array_equal(finite, np.isfinite(results[1][2]))
    assert np.allclose(results[0][2][finite], results[1][2][finite], rtol=1e-12, atol=0)


def test_missing_warp_is_a_clear_error(monkeypatch):
    from jellysim.kernels import get_backend

    monkeypatch.setitem(sys.modules, "warp", None)  # import warp -> ImportError
    with pytest.raises(SceneError, match=r"pip install 'jellysim\[gpu\]'"):
        get_backend("warp")


def test_unsupported_integrator_is_refused():
    m = make_box_model(50)
    with pytest.raises(SceneError, match="backend = 'warp' supports integrators paper and "
                                         "symplectic; name = 'implicit'"):
        Simulator(m, dt=0.01, integrator="implicit", backend="warp")
    # the implicit integrator in a scene file: the file and key are named
    text = (ROOT / "examples" / "paper_cube.toml").read_text()
    with pytest.raises(SceneError, match=r"cube\.toml: \[integrator\] backend = 'warp'"):
        Scene.from_text(text.replace('name = "paper"', 'name = "implicit"\nbackend = "warp"'),
                        name="cube.toml")
    with pytest.raises(SceneError, match="apply to backend = 'warp' only"):
        Simulator(m, dt=0.01, backend="numba", device="cuda")


def test_demo_accepts_backend_warp(warp, tmp_path):
    # the physical path runs on Warp (tests/test_warp_physical.py compares it with numba)
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.trajectory import load_trajectory

    r = CliRunner().invoke(cli, ["demo", "--backend", "warp", "--out", str(tmp_path),
                                 "--frames", "2", "--size", "64x48", "--points", "200",
                                 "--quiet"])
    assert r.exit_code == 0, r.output
    traj = load_trajectory(tmp_path / "demo" / "trajectory.npz")
    assert traj.params["integrator"]["backend"] == "warp"
    assert traj.frame_count == 2 and np.all(np.isfinite(traj.positions))
    assert (tmp_path / "demo.mp4").stat().st_size > 0


def test_cli_run_backend_warp_reproduces_numba(warp, tmp_path):
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.trajectory import load_trajectory

    trajs = []
    for backend in ("numba", "warp"):
        out = tmp_path / backend
        r = CliRunner().invoke(cli, ["run", str(ROOT / "examples" / "paper_cube.toml"),
                                     "--backend", backend, "--steps", "30",
                                     "--out", str(out), "--quiet", "--no-vtu"])
        assert r.exit_code == 0, r.output
        trajs.append(load_trajectory(out / "trajectory.npz"))
    assert trajs[1].params["integrator"]["backend"] == "warp"
    assert trajs[0].positions.shape == trajs[1].positions.shape == (31, 600, 3)
    assert np.abs(trajs[0].positions - trajs[1].positions).max() <= 1e-12
