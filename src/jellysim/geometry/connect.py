"""Spring builders.  Here: the report's "implicit" builder (section 4.3).

Every pair of points at most ``r`` apart (the report: "within radius r") is joined by
a spring, found with ``scipy.spatial.cKDTree.query_pairs``.  The tet-based builders
(marching grid, Delaunay, TetGen) live in :mod:`jellysim.geometry.tetra`.
"""
from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["radius_springs", "canonical_springs"]


def canonical_springs(pairs: np.ndarray) -> np.ndarray:
    """Springs as (k, 2) int64 with ``i < j`` in each row, rows unique and sorted.

    Raises ``ValueError`` for a self-spring (``i == j``).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if np.any(pairs[:, 0] == pairs[:, 1]):
        raise ParameterError("a spring joins a point to itself")
    pairs = np.sort(pairs, axis=1)
    return np.unique(pairs, axis=0)


GRID_MIN_POINTS = 50_000
"""From this many points on, ``method="auto"`` uses the parallel cell grid."""


def radius_springs(points: np.ndarray, r: float, *, method: str = "auto") -> np.ndarray:
    """All pairs of points at most ``r`` apart (report: the "implicit" connection).

    Parameters
    ----------
    points: positions [m], shape (n, 3).
    r: connection radius [m], > 0.  Pairs at distance exactly ``r`` are included
       (``query_pairs`` semantics: ``distance <= r``).
    method: ``"kdtree"`` (``scipy.spatial.cKDTree.query_pairs``), ``"grid"`` (a numba-parallel
       cell grid that emits the pairs already sorted; falls back to the kd-tree for very
       sparse sets) or ``"auto"`` (grid from :data:`GRID_MIN_POINTS` points on).  Both give
       the same springs; the grid is several times faster for large sets (BENCHMARKS.md).

    Returns
    -------
    Springs, shape (k, 2), int64, ``i < j``, unique, sorted lexicographically.
    """
    from scipy.spatial import cKDTree

    if not (r > 0 and np.isfinite(r)):
        raise ParameterError(f"connection radius r must be a positive finite length in m, got {r}")
    if method not in ("auto", "kdtree", "grid"):
        raise ParameterError(f"method must be 'auto', 'kdtree' or 'grid', got {method!r}")
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise ParameterError(f"points must be finite positions [m] of shape (n, 3), got "
                             f"shape {points.shape}" + ("" if points.ndim != 2 or points.shape[1]
                                                        != 3 else " with NaN or inf"))
    if method == "grid" or (method == "auto" and len(points) >= GRID_MIN_POINTS):
        from ._grid_pairs import grid_pairs

        csr = grid_pairs(points, float(r))
        if csr is not None:
            ptr, j = csr
            i = np.repeat(np.arange(len(points), dtype=np.int64), np.diff(ptr))
            return np.stack([i, j], axis=1)
    pairs = cKDTree(points).query_pairs(r, output_type="ndarray").astype(np.int64)
    if pairs.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    pairs.sort(axis=1)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return np.ascontiguousarray(pairs[order])


def choose_radius(points: np.ndarray, neighbours: float = 24.0, *, sample: int = 4000,
                  seed: int = 0, among: np.ndarray | None = None,
                  reach_all: float = 1.0) -> float:
    """Connection radius [m] giving about ``neighbours`` springs per point on average.

    Binary search on the mean neighbour count of (up to ``sample``) points, counted exactly
    with a kd-tree over all points.  Boundary points have fewer neighbours, so the interior
    has a few more than the mean.  ``among`` [m] (k, 3): average over these of ``points``
    only (a body whose surface points are far denser than its interior: averaged over all,
    the radius followed the surface's spacing and left interior points with no spring, API
    trial, session 28).  ``reach_all`` > 1: raise the radius to the farthest nearest-neighbour
    distance when that is within ``reach_all`` times it, so every point has a spring (the
    re-trial's 100-point capsule left 5 alone).
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64)
    n = len(points)
    if n < 2:
        raise ParameterError("need at least 2 points to choose a radius")
    if not 0 < neighbours < n:
        raise ParameterError(f"target neighbour count must lie in (0, {n}), got {neighbours}")
    tree = cKDTree(points)
    rng = np.random.default_rng(seed)
    probe = points if among is None or len(among) < 2 else np.asarray(among, dtype=np.float64)
    idx = rng.choice(len(probe), size=min(sample, len(probe)), replace=False)
    kmax = int(min(n, 4 * neighbours + 2))
    dist, _ = tree.query(probe[idx], k=kmax)
    dist = dist[:, 1:]  # drop the point itself
    lo, hi = 0.0, float(dist[:, -1].max())
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        mean = np.mean(np.sum(dist <= mid, axis=1))
        if mean < neighbours:
            lo = mid
        else:
            hi = mid
    if reach_all > 1.0:
        far = float(tree.query(points, k=2)[0][:, 1].max())
        hi = far * 1.0001 if hi <= far <= reach_all * hi else hi
    return hi
