"""Provot strain limiting in Jacobi order conserves linear momentum (every backend), and a
request at rounding level of the band edge counts for none of them.

Jacobi moves each point by the mean of its requests, so the two ends of a pair move unequally
(their means are over different numbers of requests); the pass then removes the moves'
mass-weighted mean (``provot_numpy.momentum_shift``).  Before that, the free chain below
gained 16.5 kg m/s in its first step and its centre of mass went from 1.75 m to 14.15 m in
1 s; a request of c = 1.1e-16 (a spring put exactly on its band edge by the previous pass)
was active on one backend and not the other: 3 cm apart after one step.
"""
import numba
import numpy as np
import pytest

from jellysim.body import Body
from jellysim.model import finalize
from jellysim.params import ProvotParams
from jellysim.simulator import Simulator

from conftest import make_box_model

try:
    import warp  # noqa: F401
    _warp = []
except ImportError:
    _warp = [pytest.mark.skip(reason="warp-lang (the optional [gpu] extra) is not installed")]
BACKENDS = ["numpy", "numba", pytest.param("warp", marks=_warp)]


def _chain_sim(backend, *, order="jacobi", pairs="springs", integrator="symplectic", loops=5,
               tau=0.001, velocity_update=True, threads=None):
    """4 free unit masses at x = 0, 1, 2, 4 (rest 0, 1, 2, 3), springs 0-1, 1-2, 2-3 of rest
    length 1 and k = 10 N/m, no gravity, no ground, dt = 0.01 s."""
    body = Body(points=np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]),
                springs=np.array([[0, 1], [1, 2], [2, 3]]), rest_length=np.ones(3))
    model = finalize(body, stiffness=10.0, point_mass=1.0, gravity=(0, 0, 0))
    state = model.state()
    state.x[3, 0] = 4.0
    provot = ProvotParams(order=order, pairs=pairs, loops=loops, tau=tau,
                          velocity_update=velocity_update)
    return Simulator(model, dt=0.01, integrator=integrator, provot=provot, backend=backend,
                     threads=threads, state=state, substeps=1, check_stability=False)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("pairs", ["springs", "all"])
@pytest.mark.parametrize("integrator,loops", [("symplectic", 5), ("paper", 5), ("paper", 1)])
def test_jacobi_free_chain_keeps_momentum_and_centre_of_mass(backend, pairs, integrator,
                                                             loops):
    # ("paper", 1) on numba is the fused two-sweep step; ("paper", 5) its fused first pass
    sim = _chain_sim(backend, pairs=pairs, integrator=integrator, loops=loops)
    m = sim.model.point_mass
    sim.advance(1)
    assert np.abs(m @ sim.state.v).max() < 1e-12  # was 16.5 kg m/s after this step
    sim.advance(99)  # 1 s
    assert np.abs(m @ sim.state.v).max() < 1e-12
    com = m @ sim.state.x / m.sum()
    assert com == pytest.approx([1.75, 0.0, 0.0], abs=1e-12)  # was 14.15 m
    # and Provot did act: the stretched last spring was pulled well into its band
    assert np.linalg.norm(sim.state.x[3] - sim.state.x[2]) < 1.5


@pytest.mark.parametrize("backend", BACKENDS)
def test_jacobi_unequal_masses_keep_momentum(backend):
    # 1 kg and 9 kg on one spring stretched 20 %: the light end takes 9/10 of the correction
    body = Body(points=np.array([[0.0, 0, 0], [1, 0, 0]]), springs=np.array([[0, 1]]),
                rest_length=np.ones(1), masses=np.array([1.0, 9.0]))
    model = finalize(body, stiffness=10.0, gravity=(0, 0, 0))
    state = model.state()
    state.x[1, 0] = 1.2
    sim = Simulator(model, dt=0.01, integrator="symplectic", backend=backend, state=state,
                    provot=ProvotParams(tau=0.01, loops=1, velocity_update=True), substeps=1,
                    check_stability=False)
    m = model.point_mass
    com0 = m @ state.x / m.sum()
    sim.advance(1)
    assert np.abs(m @ sim.state.v).max() < 1e-13
    assert m @ sim.state.x / m.sum() == pytest.approx(com0, abs=1e-14)
    length = sim.state.x[1, 0] - sim.state.x[0, 0]
    assert length == pytest.approx(1.01, abs=1e-12)  # put on the band edge (1 + tau) L0
    sim.advance(200)
    assert np.abs(m @ sim.state.v).max() < 1e-12


def test_numpy_and_numba_agree_where_a_spring_sits_on_its_band_edge():
    # loops = 5 put springs exactly on (1 + tau) L0; the next pass saw c ~ 1.1e-16 there,
    # an active request on one backend only, and the backends ended 3 cm apart
    xs = []
    for backend in ("numpy", "numba"):
        sim = _chain_sim(backend, loops=5, tau=0.01, velocity_update=False)
        sim.advance(1)
        xs.append(sim.state.x.copy())
    assert np.allclose(xs[0], xs[1], rtol=0, atol=1e-15)
    lengths = np.diff(xs[0][:, 0])
    assert lengths[0] == pytest.approx(1.01, abs=1e-12)  # the end springs on the band edge
    assert lengths[2] == pytest.approx(1.01, abs=1e-12)


def test_a_request_at_rounding_level_is_inside_the_band():
    from jellysim.kernels import numba_backend as nb
    from jellysim.kernels import numpy_backend as npb

    rest, tau = 1.0, 0.01
    edge = (1 + tau) * rest
    for length in (edge, np.nextafter(edge, 2), edge + 5e-13, edge - 5e-13):
        assert npb._provot_scalar(np.array([length]), rest, tau)[0] == 0.0
        assert nb._provot_c(length, rest, tau) == 0.0
        assert nb._provot_c_inv(length, 1 / length, rest, tau) == 0.0
    out = edge + 1e-9  # a real excess still acts, the same everywhere
    c = 0.5 * (out - edge) / out
    assert npb._provot_scalar(np.array([out]), rest, tau)[0] == pytest.approx(c, rel=1e-6)
    assert nb._provot_c(out, rest, tau) == pytest.approx(c, rel=1e-6)


def _spinning_box(backend, integrator, threads=None, loops=5):
    """200 points spinning at 20 rad/s about the vertical axis through their centre, with
    gravity, Jacobi Provot (the defaults: 5 loops, velocity update)."""
    model = make_box_model(200, stiffness=200.0, point_mass=0.01)
    state = model.state()
    c = model.point_x0.mean(axis=0)
    r = state.x - c
    state.v[:] = 20.0 * np.stack([r[:, 2], np.zeros(len(r)), -r[:, 0]], axis=1)
    return Simulator(model, dt=1e-3, integrator=integrator, provot=ProvotParams(loops=loops),
                     backend=backend, threads=threads, state=state, substeps=1,
                     check_stability=False)


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("integrator", ["symplectic", "paper"])
def test_spinning_box_momentum_changes_by_gravity_only(backend, integrator):
    sim = _spinning_box(backend, integrator)
    m = sim.model.point_mass
    p0 = m @ sim.state.v
    sim.advance(100)
    # was 0.021 m/s of centre-of-mass velocity drift in 0.5 s (numba, symplectic)
    g_impulse = m.sum() * np.array([0.0, -9.8, 0.0]) * 0.1
    assert np.abs(m @ sim.state.v - p0 - g_impulse).max() / m.sum() < 1e-10


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
@pytest.mark.parametrize("integrator", ["symplectic", "paper"])
@pytest.mark.parametrize("loops", [1, 5])
def test_jacobi_momentum_shift_same_for_one_and_two_threads(integrator, loops):
    runs = []
    for threads in (1, 2):
        sim = _spinning_box("numba", integrator, threads=threads, loops=loops)
        sim.advance(40)
        runs.append((sim.state.x.copy(), sim.state.v.copy()))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert np.array_equal(runs[0][1], runs[1][1])



@pytest.mark.skipif(bool(_warp), reason="warp-lang is not installed")
def test_warp_momentum_sum_in_fixed_blocks_as_on_a_gpu(monkeypatch):
    # a GPU sums the momentum in 256 fixed blocks, then the blocks in order: the same
    # conservation, the same run to rounding as the serial sum, and repeatable bitwise
    from jellysim.kernels import warp_backend

    def run():
        sim = _chain_sim("warp", integrator="paper", loops=2)
        sim.advance(100)
        return sim.model.point_mass, sim.state.x.copy(), sim.state.v.copy()

    _, x_serial, _ = run()
    monkeypatch.setitem(warp_backend.MOMENTUM_BLOCKS, "cpu", 3)  # 4 points: 1, 1, 2
    m, x, v = run()
    assert np.abs(m @ v).max() < 1e-12
    assert np.allclose(x, x_serial, rtol=0, atol=1e-13)
    _, x_again, v_again = run()
    assert np.array_equal(x, x_again) and np.array_equal(v, v_again)
