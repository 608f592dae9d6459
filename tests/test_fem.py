"""The physical material (Stable Neo-Hookean tets + damping branch) and its explicit path."""
from __future__ import annotations

import numpy as np
import pytest

from jellysim.body import Body
from jellysim.kernels import fem_numba, fem_numpy
from jellysim.params import GroundModel, GroundParams, Material
from jellysim.physics.fem import (damping_parameters, fem_arrays, lame_parameters, loss_factor)
from jellysim.physics.policy import physical_model
from jellysim.simulator import Simulator

from bodies import kuhn_box

RHO = 1141.0


def _tuple(fem, g=0.0, decay=0.0, q=None):
    q = np.zeros((fem.tet_count, 6)) if q is None else q
    return fem.kernel_tuple(q, 1.0, damping=False)[:8] + (g, decay, q) + (
        fem.point_tet_ptr, fem.point_tet_slot)


def _one_tet(scale=0.01):
    return np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]) * scale


def test_linearisation_is_linear_elasticity():
    """Under a small affine displacement u = G x the corner forces are those of linear
    elasticity with the requested E and nu: -V sigma grad(phi_c)."""
    pts = _one_tet() + np.array([[0, 0, 0], [0.001, 0, 0], [0, 0.002, 0.001], [0.001, 0, 0]])
    for E, nu in ((1e4, 0.4), (5e3, 0.25), (2e5, 0.45)):
        fem = fem_arrays(pts, [[0, 1, 2, 3]], youngs_modulus=E, poisson_ratio=nu)
        G = np.random.default_rng(1).standard_normal((3, 3)) * 1e-7
        out = np.zeros((4, 3))
        fem_numpy.tet_forces(pts + pts @ G.T, _tuple(fem), 0.0, 0.0, np.zeros((1, 6)), out,
                             np.zeros(1))
        mu_l, lam_l = lame_parameters(E, nu)
        eps = (G + G.T) / 2
        sig = 2 * mu_l * eps + lam_l * np.trace(eps) * np.eye(3)
        Dm = np.stack([pts[c] - pts[0] for c in (1, 2, 3)], axis=1)
        H = -abs(np.linalg.det(Dm)) / 6 * sig @ np.linalg.inv(Dm).T
        assert np.allclose(out[1:], H.T, rtol=0, atol=1e-5 * np.abs(H).max())


def test_forces_conserve_momentum_and_resist_inversion():
    """Any deformation: corner forces sum to zero and exert no torque; an inverted tet's
    forces point back towards positive volume."""
    rng = np.random.default_rng(3)
    pts = _one_tet()
    fem = fem_arrays(pts, [[0, 1, 2, 3]], youngs_modulus=1e4, poisson_ratio=0.4,
                     damping_ratio=0.1, damping_frequency=3.0)
    g, tau = fem.branch_ratio, fem.branch_time
    for _ in range(20):
        x = pts + rng.standard_normal((4, 3)) * 0.004
        out = np.zeros((4, 3))
        q = rng.standard_normal((1, 6)) * 0.01
        fem_numpy.tet_forces(x, _tuple(fem, g, 0.5, q), g, 0.5, q, out, np.zeros(1))
        assert np.allclose(out.sum(axis=0), 0, atol=1e-12 * np.abs(out).max())
        torque = np.cross(x, out).sum(axis=0)
        assert np.allclose(torque, 0, atol=1e-10 * np.abs(out).max() * 0.01)
    inverted = pts.copy()
    inverted[3, 2] = -0.004  # the apex pushed through its base
    out = np.zeros((4, 3))
    j = np.zeros(1)
    fem_numpy.tet_forces(inverted, _tuple(fem), 0.0, 0.0, np.zeros((1, 6)), out, j)
    assert j[0] < 0 and out[3, 2] > 0  # pushed back up


@pytest.mark.parametrize("cells", [(3, 3, 3), (13, 13, 12)])
@pytest.mark.parametrize("g", [0.2, 0.0])
def test_numba_agrees_with_numpy_spec(cells, g):
    """The numba tets (computed in vectorised blocks of LANES tets, the last one partial:
    162 tets, and 12,168 in 381 blocks dealt to 256 chunks; with and without the damping branch) give the spec's forces and
    branch strains, bitwise the same on 1 and 2 threads."""
    import numba

    from jellysim.kernels.fem_lanes_numba import LANES

    body = kuhn_box(cells, upper=(0.03, 0.03, 0.03))
    fem = fem_arrays(body.points, body.tets, youngs_modulus=1e4, poisson_ratio=0.4,
                     damping_ratio=0.05, damping_frequency=4.0)
    assert fem.tet_count % LANES != 0
    rng = np.random.default_rng(0)
    x = body.points + rng.standard_normal(body.points.shape) * 1e-3 * 3 / cells[0]
    res = []
    before = numba.get_num_threads()
    try:
        for mod, threads in ((fem_numpy, 1), (fem_numba, 1), (fem_numba, 2)):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            q = np.full((fem.tet_count, 6), 0.01)
            tf = np.zeros((4 * fem.tet_count, 3))
            j = np.zeros(fem.tet_count)
            out = np.zeros((len(x), 3))
            mod.tet_forces(x, _tuple(fem, g, 0.7, q), g, 0.7, q, tf, j)
            mod.gather_tet_forces(tf, fem.point_tet_ptr, fem.point_tet_slot, out)
            res.append((out, q, j))
    finally:
        numba.set_num_threads(before)
    assert np.allclose(res[0][0], res[1][0], rtol=1e-12, atol=1e-12 * np.abs(res[0][0]).max())
    assert np.allclose(res[0][1], res[1][1], rtol=1e-12, atol=1e-15)
    assert np.allclose(res[0][2], res[1][2], rtol=1e-13, atol=0)
    assert (g > 0) == (not np.all(res[1][1] == 0.01))  # the branch advanced only when on
    for a, b in zip(res[1], res[2]):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("g", [0.2, 0.0])
def test_one_thread_summed_tet_pass_equals_the_gather(g):
    """What one thread runs (each corner force added to its point at once, tets in order) is
    bitwise the parallel path's corner rows gathered per point in tet order, with the same
    smallest J and branch strains."""
    from jellysim.kernels.fem_lanes_numba import tet_forces_summed

    body = kuhn_box((7, 6, 5), upper=(0.03, 0.03, 0.03))
    fem = fem_arrays(body.points, body.tets, youngs_modulus=1e4, poisson_ratio=0.45,
                     damping_ratio=0.05, damping_frequency=4.0)
    x = body.points + np.random.default_rng(2).standard_normal(body.points.shape) * 1e-3
    x[5] = body.points[5] + [0.0, 0.0, -0.02]  # some tets inverted: J < 0
    n, t = len(x), fem.tet_count
    q1 = np.full((t, 6), 0.01)
    q2 = q1.copy()
    tf = np.zeros((4 * t, 3))
    j1, j2 = np.zeros(t), np.zeros(t)
    f1, f2 = np.zeros((n, 3)), np.full((n, 3), np.nan)  # the summed pass starts from 0
    fem_numba.tet_forces(x, _tuple(fem, g, 0.7, q1), g, 0.7, q1, tf, j1)
    fem_numba.gather_tet_forces(tf, fem.point_tet_ptr, fem.point_tet_slot, f1)
    m1 = fem_numba._serial_min(j1, 1.0)
    m2 = np.ones(1)
    tet_forces_summed(x, _tuple(fem, g, 0.7, q2), g, 0.7, q2, f2, j2, m2)
    assert m1 < 0 and m2[0] == m1
    assert np.array_equal(f1, f2) and np.array_equal(j1, j2) and np.array_equal(q1, q2)


def _cube_model(cells=4, size=0.04, lift=0.0, **material):
    body = kuhn_box((cells,) * 3, lower=(0, lift, 0), upper=(size, size + lift, size))
    return physical_model(body, Material(**material))


def test_physical_steps_numpy_numba_and_threads_agree():
    model = _cube_model(lift=0.01, damping_ratio=0.05)
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.3, friction=0.6)
    out = []
    for backend, threads in (("numpy", 1), ("numba", 1), ("numba", 2)):
        sim = Simulator(model, dt=1 / 60, backend=backend, threads=threads, ground=ground)
        sim.state.v[:, 0] = 0.2
        sim.advance(6)
        out.append(sim.state.x.copy())
    assert np.abs(out[0] - out[1]).max() < 1e-10
    assert np.array_equal(out[1], out[2])  # bitwise, whatever the thread count


def test_free_fall_is_exact():
    """No contact: the centre of mass follows the discrete free fall of symplectic Euler and
    momentum grows by M g t, to 1e-9 relative, while the body deforms and spins."""
    model = _cube_model(lift=1.0, damping_ratio=0.1)
    sim = Simulator(model, dt=1 / 60)
    rng = np.random.default_rng(2)
    sim.state.v[:] = rng.standard_normal(sim.state.v.shape) * 0.05
    m = model.point_mass[:, None]
    p0 = (m * sim.state.v).sum(axis=0)
    c0 = (m * sim.state.x).sum(axis=0) / m.sum()
    sim.advance(30)
    n = 30 * sim.substeps
    h = sim.dt_step
    g = model.gravity
    # symplectic Euler: v_k = v0 + k h g;  x_n = x0 + h sum_{k=1..n} v_k
    c_exact = c0 + n * h * p0 / m.sum() + h * h * g * n * (n + 1) / 2
    p_exact = p0 + m.sum() * g * n * h
    c = (m * sim.state.x).sum(axis=0) / m.sum()
    p = (m * sim.state.v).sum(axis=0)
    assert np.allclose(c, c_exact, rtol=0, atol=1e-9 * np.abs(c_exact).max())
    assert np.allclose(p, p_exact, rtol=0, atol=1e-9 * np.abs(p_exact).max())


def test_damping_parameters_peak_at_the_requested_frequency():
    for zeta, f in ((0.02, 3.0), (0.1, 10.0)):
        g, tau = damping_parameters(zeta, f)
        freqs = np.geomspace(f / 10, f * 10, 2001)
        lf = loss_factor(freqs, g, tau)
        assert abs(freqs[np.argmax(lf)] / f - 1) < 0.01
        assert lf.max() / 2 == pytest.approx(zeta, rel=1e-6)


def test_fem_needs_tets():
    body = Body(points=np.random.default_rng(0).random((10, 3)), springs=np.zeros((0, 2)))
    with pytest.raises(ValueError, match="tets"):
        physical_model(body, Material())


def test_an_inverted_tet_is_reported_once():
    """A corner point pushed through the body inverts its tets: the run says so (once), the
    Stable Neo-Hookean forces push them back, and min_tet_volume_ratio keeps the record."""
    import warnings

    from jellysim.errors import StabilityWarning

    model = _cube_model(damping_ratio=0.05)
    sim = Simulator(model, dt=1 / 60)
    corner = int(np.argmin(model.point_x0.sum(axis=1)))
    sim.state.x[corner] = [0.012, 0.012, 0.012]  # through the cube's corner tets
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sim.advance(30)
    said = [w for w in caught if "inside out" in str(w.message)]
    assert len(said) == 1 and issubclass(said[0].category, StabilityWarning)
    assert sim.min_tet_volume_ratio <= 0.0
    from jellysim.geometry.tetra import tet_signed_volumes

    assert np.all(tet_signed_volumes(sim.state.x, model.fem.tets) > 0)  # pushed back out
