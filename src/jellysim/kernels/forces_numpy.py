"""Numpy (the spec): report eq. 1, the spring forces and accelerations."""
from __future__ import annotations

import numpy as np


def _scatter(n: int, idx: np.ndarray, values: np.ndarray) -> np.ndarray:
    out = np.empty((n, 3))
    for c in range(3):
        out[:, c] = np.bincount(idx, weights=values[:, c], minlength=n)
    return out


def accelerations(x, v, points, springs, spring_scalar, a_out):
    """Report eq. 1: ``a = (sum_s k_s (|d| - L0_s) d / |d| - delta v) / m + g``.

    For spring s = (i, j), ``d = x_j - x_i``; the force ``k (|d| - L0) d / |d|`` acts on i and
    its opposite on j.  A spring of zero current length exerts no force (direction undefined).
    The per-spring scalar ``k (|d| - L0) / |d|`` is left in ``spring_scalar`` [N/m], shape (k,)
    (scratch: the numba twin leaves it untouched).
    Writes ``a_out`` [m/s^2], shape (n, 3).  ``points``: :class:`~.records.PointArrays`,
    ``springs``: :class:`~.records.SpringArrays`.
    """
    n = x.shape[0]
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    spring_ij, rest, stiff = springs.ij, springs.rest, springs.stiff
    i, j = spring_ij[:, 0], spring_ij[:, 1]
    d = x[j] - x[i]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    safe = np.where(length > 0.0, length, 1.0)
    spring_scalar[:] = np.where(length > 0.0, stiff * (length - rest) / safe, 0.0)
    f = spring_scalar[:, None] * d
    force = _scatter(n, i, f) - _scatter(n, j, f)
    a_out[:] = (force - damping * v) * inv_mass[:, None] + gravity
