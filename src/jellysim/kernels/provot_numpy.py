"""Numpy (the spec): Provot (1995) strain limiting."""
from __future__ import annotations

import numpy as np

from .forces_numpy import _scatter


def _provot_scalar(length, rest, tau):
    """Half the relative excess of a pair over its band (0 inside the band or at length 0)."""
    hi = (1.0 + tau) * rest
    lo = (1.0 - tau) * rest
    target = np.clip(length, lo, hi)
    safe = np.where(length > 0.0, length, 1.0)
    return np.where(length > 0.0, 0.5 * (length - target) / safe, 0.0)


def provot(x, x0, springs, tau, loops, tolerance, all_pairs, gauss_seidel, scratch):
    """Provot (1995) strain limiting, in place on ``x`` [m] (n, 3).

    A pair (i, j) with ``d = x_j - x_i`` whose length leaves ``[(1-tau) L0, (1+tau) L0]`` asks
    for i to move by ``+c d`` and j by ``-c d`` with ``c = (|d| - bound) / (2 |d|)``: both ends
    move equally to the nearest bound.  Pairs are the springs (rest length ``rest``) or, with
    ``all_pairs``, every pair (rest length from ``x0``).

    Jacobi order: all requests of a pass are computed from the same positions and each point
    moves by the mean of its requests.  Gauss-Seidel order: pairs in index order (i, then j),
    each request applied at once.  Stops after ``loops`` passes or when a pass's largest point
    correction is <= ``tolerance`` [m].  Returns ``(passes, largest correction of the last
    pass)``.  ``springs``: :class:`~.records.SpringArrays`; ``scratch``:
    :class:`~.records.ExplicitScratch` (unused here; the numba twin needs it).
    """
    n = x.shape[0]
    spring_ij, rest = springs.ij, springs.rest
    passes, largest = 0, 0.0
    if all_pairs:
        iu, ju = np.triu_indices(n, 1)
        pairs = np.stack([iu, ju], axis=1)
        pair_rest = np.linalg.norm(x0[ju] - x0[iu], axis=1)
    else:
        pairs, pair_rest = spring_ij, rest
    i, j = pairs[:, 0], pairs[:, 1]
    for _ in range(loops):
        passes += 1
        if gauss_seidel:
            largest = 0.0
            for s in range(pairs.shape[0]):
                a, b = i[s], j[s]
                d = x[b] - x[a]
                length = np.sqrt(d @ d)
                c = _provot_scalar(length, pair_rest[s], tau)
                if c != 0.0:
                    x[a] += c * d
                    x[b] -= c * d
                    largest = max(largest, abs(c) * length)
        else:
            d = x[j] - x[i]
            length = np.sqrt(np.einsum("ij,ij->i", d, d))
            c = _provot_scalar(length, pair_rest, tau)
            req = c[:, None] * d
            active = (c != 0.0).astype(np.float64)
            total = _scatter(n, i, req) - _scatter(n, j, req)
            cnt = np.bincount(i, weights=active, minlength=n) + np.bincount(
                j, weights=active, minlength=n)
            step = np.where(cnt[:, None] > 0, total / np.maximum(cnt, 1.0)[:, None], 0.0)
            x += step
            largest = float(np.sqrt(np.einsum("ij,ij->i", step, step)).max(initial=0.0))
        if largest <= tolerance:
            break
    return passes, largest
