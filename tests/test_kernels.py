"""The numba kernels agree with the numpy reference; thread count does not change results."""
import numba
import numpy as np
import pytest

from conftest import make_box_model
from jellysim.kernels import numba_backend as nbk
from jellysim.kernels import numpy_backend as npk
from jellysim.kernels import records as rec
from jellysim.params import GroundParams, ProvotParams
from jellysim.simulator import Simulator


def model_args(m):
    return (m.spring_ij, m.spring_rest_length, m.spring_stiffness, m.point_first_ptr,
            m.point_second_ptr, m.spring_second_slot, m.point_second_other)


def perturbed(m, seed=0, scale=0.03):
    rng = np.random.default_rng(seed)
    x = m.point_x0 + scale * rng.standard_normal(m.point_x0.shape)
    v = rng.standard_normal(x.shape)
    return x, v


def test_each_point_visits_exactly_its_springs():
    """The visit lists the numba sweeps read (records.visit_lists): point p's list is its
    springs as first point in spring order, then its springs as second point in slot order,
    each with the other end and that spring's own rest length and stiffness; checked against
    a loop over the springs, on a body with points of no spring and a stiffness per spring."""
    rng = np.random.default_rng(3)
    n, k = 40, 90
    pairs = set()
    while len(pairs) < k:
        i, j = sorted(rng.integers(0, n - 5, 2))  # (the last 5 points: no spring)
        if i != j:
            pairs.add((int(i), int(j)))
    ij = np.array(sorted(pairs), dtype=np.int64)
    rest, stiff = rng.uniform(0.1, 1.0, k), rng.uniform(1.0, 9.0, k)
    first_ptr = np.searchsorted(ij[:, 0], np.arange(n + 1))
    second = np.lexsort((ij[:, 0], ij[:, 1]))  # slots: by second point, then first
    second_ptr = np.searchsorted(ij[second, 1], np.arange(n + 1))
    ptr, other, vrest, vstiff = rec.visit_lists(ij, rest, stiff, first_ptr, second_ptr, second)
    assert ptr[0] == 0 and ptr[-1] == 2 * k and other.dtype == np.int32
    for p in range(n):
        want = [(int(j), rest[s], stiff[s]) for s, (i, j) in enumerate(ij) if i == p]
        want += [(int(ij[s, 0]), rest[s], stiff[s]) for s in second if ij[s, 1] == p]
        got = list(zip(other[ptr[p]:ptr[p + 1]].tolist(), vrest[ptr[p]:ptr[p + 1]],
                       vstiff[ptr[p]:ptr[p + 1]]))
        assert got == want, p
    assert not other.flags.writeable and not vrest.flags.writeable


@pytest.mark.parametrize("uniform", [True, False])
def test_accelerations_agree(uniform):
    """numba (each spring from both ends, over each point's visit list with its own copies of
    the rest lengths and stiffnesses) = the numpy spec = a per-spring transcription of eq. 1, also
    with a different stiffness on every spring; and the report's ordered sums the same."""
    m = make_box_model(400, stiffness=30.0, damping=0.3)
    if not uniform:
        import dataclasses

        k = np.random.default_rng(5).uniform(10.0, 50.0, m.spring_count)
        k.setflags(write=False)
        m = dataclasses.replace(m, spring_stiffness=k)
    x, v = perturbed(m)
    out = []
    for k in (npk, nbk):
        a = np.zeros_like(x)
        sc = np.zeros(m.spring_count)  # scratch (numba computes each spring from both ends)
        k.accelerations(x, v, rec.point_arrays(m), rec.spring_arrays(m), sc, a)
        out.append(a)
    scale = np.abs(out[0]).max()
    assert np.max(np.abs(out[0] - out[1])) <= 1e-12 * scale
    # and against an independent per-spring transcription of report eq. 1
    ij = m.spring_ij
    d = x[ij[:, 1]] - x[ij[:, 0]]
    length = np.linalg.norm(d, axis=1)
    f = (m.spring_stiffness * (length - m.spring_rest_length) / length)[:, None] * d
    force = np.zeros_like(x)
    np.add.at(force, ij[:, 0], f)
    np.add.at(force, ij[:, 1], -f)
    want = (force - 0.3 * v) / m.point_mass[:, None] + m.gravity
    assert np.max(np.abs(out[1] - want)) <= 1e-12 * scale
    from jellysim.kernels.forces_numba import accelerations_ordered

    a = np.zeros_like(x)
    accelerations_ordered(x, v, rec.point_arrays(m), rec.spring_arrays(m),
                          np.zeros(m.spring_count), a)
    assert np.max(np.abs(a - want)) <= 1e-12 * scale


@pytest.mark.parametrize("all_pairs", [False, True])
@pytest.mark.parametrize("gauss_seidel", [False, True])
def test_provot_agrees(all_pairs, gauss_seidel):
    m = make_box_model(150, r=0.4)
    x, _ = perturbed(m, 1, 0.01)
    n = m.point_count
    results = []
    for k in (npk, nbk):
        xx = x.copy()
        res = k.provot(xx, rec.point_arrays(m), rec.spring_arrays(m), 0.002, 4, 0.0, all_pairs,
                       gauss_seidel, rec.explicit_scratch(n, m.spring_count))
        results.append((xx, res))
    assert np.allclose(results[0][0], results[1][0], rtol=0, atol=1e-12)
    assert results[0][1][0] == results[1][1][0]
    assert results[0][1][1] == pytest.approx(results[1][1][1], rel=1e-10)
    assert not np.allclose(results[0][0], x)  # corrections did happen


@pytest.mark.parametrize("integrator", ["paper", "symplectic"])
@pytest.mark.parametrize("pairs,loops", [("springs", 1), ("springs", 3), ("all", 2)])
def test_run_steps_agree(integrator, pairs, loops):
    m = make_box_model(200, stiffness=20.0, damping=0.02, point_mass=0.05,
                       lower=(0, 0.02, 0), upper=(1, 1.02, 1))
    states = []
    for backend in ("numpy", "numba"):
        sim = Simulator(m, dt=0.002, integrator=integrator, backend=backend,
                        provot=ProvotParams(tau=0.001, loops=loops, pairs=pairs),
                        ground=GroundParams(), check_stability=False)
        sim.advance(60)
        states.append(sim.state)
    assert states[0].x[:, 1].min() == 0.0  # the ground rule was exercised
    assert np.allclose(states[0].x, states[1].x, rtol=0, atol=1e-12)
    assert np.allclose(states[0].v, states[1].v, rtol=0, atol=1e-10)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
@pytest.mark.parametrize("order", ["jacobi", "gauss-seidel"])
def test_one_and_two_threads_bitwise_equal(order):
    m = make_box_model(6000, stiffness=20.0, damping=0.01, point_mass=0.05,
                       lower=(0, 0.01, 0), upper=(1, 1.01, 1))
    results = []
    for threads in (1, 2):
        sim = Simulator(m, dt=0.002, integrator="symplectic", threads=threads,
                        provot=ProvotParams(tau=0.001, loops=2, order=order),
                        ground=GroundParams(), check_stability=False)
        sim.advance(30)
        results.append(sim.state)
    assert np.array_equal(results[0].x, results[1].x)
    assert np.array_equal(results[0].v, results[1].v)
    assert np.array_equal(results[0].a, results[1].a)
