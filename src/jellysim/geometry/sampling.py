"""Random point fields in an axis-aligned box (report section 4.2).

Two distributions:

* ``uniform``: each coordinate uniform over the box extent.
* ``edge`` (the report's equation 4): each coordinate is ``(1 + cos(2 pi u)) / 2`` of the box
  extent with ``u`` uniform in [0, 1).  This is the arcsine distribution: its density
  ``1 / (pi sqrt(t (1 - t)))`` on (0, 1) piles points up against the faces of the box, which
  the report wanted so that the faces of the jello are well defined.

Points are returned in Morton (Z-order) order: the order of random points carries no meaning,
and spatially sorted points make the spring kernels' memory access local (a large speed-up for
big bodies, see BENCHMARKS.md).  The same seed always gives the same points.
"""
from __future__ import annotations

from enum import Enum

import numpy as np

__all__ = ["Distribution", "box_field", "morton_order"]


class Distribution(str, Enum):
    """Distribution of a random point field."""

    UNIFORM = "uniform"
    EDGE = "edge"


def box_field(
    count: int,
    lower,
    upper,
    *,
    distribution: Distribution | str = Distribution.EDGE,
    seed: int = 0,
) -> np.ndarray:
    """Random points in the box ``[lower, upper]``.

    Parameters
    ----------
    count: number of points.
    lower, upper: box corners [m], shape (3,).
    distribution: ``"uniform"`` or ``"edge"`` (report eq. 4).
    seed: seed of numpy's PCG64 generator.

    Returns
    -------
    Points [m], shape (count, 3), float64, in Morton order.
    """
    distribution = Distribution(distribution)
    lower = np.asarray(lower, dtype=np.float64).reshape(3)
    upper = np.asarray(upper, dtype=np.float64).reshape(3)
    if count < 1:
        raise ValueError(f"point count must be >= 1, got {count}")
    if not np.all(upper > lower):
        raise ValueError(f"box upper corner {upper.tolist()} must exceed lower {lower.tolist()}")
    rng = np.random.default_rng(seed)
    u = rng.random((count, 3))
    if distribution is Distribution.EDGE:
        u = 0.5 * (1.0 + np.cos(2.0 * np.pi * u))
    points = lower + u * (upper - lower)
    return points[morton_order(points)]


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """Insert two zero bits between the low 21 bits of each value (for 3D Morton codes)."""
    v = v.astype(np.uint64) & np.uint64(0x1FFFFF)
    v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    v = (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)
    return v


def morton_order(points: np.ndarray) -> np.ndarray:
    """Permutation that sorts points [m], shape (n, 3), along a 3D Z-order curve (stable)."""
    points = np.asarray(points, dtype=np.float64)
    lo = points.min(axis=0)
    span = np.maximum(points.max(axis=0) - lo, np.finfo(np.float64).tiny)
    q = np.minimum(((points - lo) / span * (2**21 - 1)).astype(np.int64), 2**21 - 1)
    code = _spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << np.uint64(1)) | (
        _spread_bits(q[:, 2]) << np.uint64(2)
    )
    return np.argsort(code, kind="stable")
