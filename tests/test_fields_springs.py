"""Point fields and radius springs: distributions, determinism, agreement with brute force."""
import numpy as np
import pytest
from scipy import stats

from jellysim.geometry.connect import radius_springs
from jellysim.geometry.sampling import box_field


def test_edge_field_follows_arcsine_distribution():
    pts = box_field(20000, [0, 0, 0], [2, 1, 4], distribution="edge", seed=12345)
    for axis, extent in enumerate([2.0, 1.0, 4.0]):
        t = pts[:, axis] / extent
        # CDF of (1 + cos(2 pi u)) / 2, u ~ U[0, 1): the arcsine law (2/pi) asin(sqrt(t))
        res = stats.kstest(t, lambda s: 2 / np.pi * np.arcsin(np.sqrt(np.clip(s, 0, 1))))
        assert res.pvalue > 0.01, (axis, res)
        # and it is clearly not uniform
        assert stats.kstest(t, "uniform").pvalue < 1e-6


def test_uniform_field_is_uniform_and_inside_box():
    lo, hi = np.array([-1.0, 0.5, 2.0]), np.array([1.0, 1.5, 2.5])
    pts = box_field(20000, lo, hi, distribution="uniform", seed=7)
    assert np.all(pts >= lo) and np.all(pts <= hi)
    for axis in range(3):
        t = (pts[:, axis] - lo[axis]) / (hi[axis] - lo[axis])
        assert stats.kstest(t, "uniform").pvalue > 0.01


def test_same_seed_same_points_other_seed_other_points():
    a = box_field(500, [0, 0, 0], [1, 1, 1], seed=4)
    b = box_field(500, [0, 0, 0], [1, 1, 1], seed=4)
    c = box_field(500, [0, 0, 0], [1, 1, 1], seed=5)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("method", ["kdtree", "grid"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_radius_springs_equal_brute_force(seed, method):
    rng = np.random.default_rng(seed)
    pts = rng.random((400, 3))
    # include exact-distance ties: a pair at distance exactly r (query_pairs includes <= r)
    pts[1] = pts[0] + np.array([0.25, 0.0, 0.0])
    r = 0.25
    springs = radius_springs(pts, r, method=method)
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    i, j = np.nonzero(np.triu(d <= r, k=1))
    expected = np.stack([i, j], axis=1)
    assert springs.dtype == np.int64 and springs.shape[1] == 2
    assert np.all(springs[:, 0] < springs[:, 1])
    assert len(np.unique(springs, axis=0)) == len(springs)
    assert np.array_equal(springs, expected[np.lexsort((expected[:, 1], expected[:, 0]))])


def test_radius_rejects_bad_radius():
    with pytest.raises(ValueError, match="radius"):
        radius_springs(np.zeros((3, 3)), -1.0)


def test_grid_and_kdtree_agree_on_edge_field():
    pts = box_field(30000, [0, 0, 0], [1, 2, 1], distribution="edge", seed=9)
    r = 0.04
    assert np.array_equal(radius_springs(pts, r, method="grid"),
                          radius_springs(pts, r, method="kdtree"))
