"""Numpy (the spec): Provot (1995) strain limiting."""
from __future__ import annotations

import numpy as np

from .forces_numpy import _scatter


NOISE = 1e-12
"""A pair within ``NOISE * rest`` of its band edge is inside the band (no request): a length
that a previous pass put exactly on the edge comes back off it by rounding only (c ~ 1e-16),
and such a request must not count, identically in every backend."""


def _provot_scalar(length, rest, tau):
    """Half the relative excess of a pair over its band (0 inside the band, within
    ``NOISE * rest`` of it, or at length 0)."""
    hi = (1.0 + tau) * rest
    lo = (1.0 - tau) * rest
    excess = length - np.clip(length, lo, hi)
    excess = np.where(np.abs(excess) <= NOISE * rest, 0.0, excess)
    safe = np.where(length > 0.0, length, 1.0)
    return np.where(length > 0.0, 0.5 * excess / safe, 0.0)


def momentum_shift(mass, step):
    """``sum_q m_q step_q / sum_q m_q`` [m] (3,): the mass-weighted mean of a Jacobi pass's
    moves ``step`` (n, 3), summed serially in point order (``cumsum`` is sequential: the
    numba and Warp twins add in the same order, so the backends agree bitwise)."""
    total = np.cumsum(mass[:, None] * step, axis=0)[-1]
    return total / np.cumsum(mass)[-1]


def provot(x, points, springs, tau, loops, tolerance, all_pairs, gauss_seidel, scratch):
    """Provot (1995) strain limiting, in place on ``x`` [m] (n, 3).

    A pair (i, j) with ``d = x_j - x_i`` whose length leaves ``[(1-tau) L0, (1+tau) L0]`` asks
    for i to move by ``+c d`` and j by ``-c d`` with ``c = (|d| - bound) / (2 |d|)``: both ends
    move equally to the nearest bound.  Pairs are the springs (rest length ``rest``) or, with
    ``all_pairs``, every pair (rest length from ``x0``).

    A pair within ``NOISE * L0`` of its band makes no request.

    Jacobi order: all requests of a pass are computed from the same positions and each point
    moves by the mean of its requests, less the mass-weighted mean of those moves
    (:func:`momentum_shift`): the mean alone moves the two ends of a pair unequally (each
    end's mean is over a different number of requests), so the centre of mass would move and
    the velocity update would turn that into momentum; less the shift, a pass conserves the
    centre of mass (a rigid translation changes no pair length).  Gauss-Seidel order (the
    report's): pairs in index order (i, then j), each request applied at once, both ends
    moving equally whatever their masses.  Stops after ``loops`` passes or when a pass's
    largest point correction (Jacobi: the largest mean request, before the shift) is <=
    ``tolerance`` [m].  Returns ``(passes, largest correction of the last pass)``.
    ``points``: :class:`~.records.PointArrays` (``x0``, ``mass``); ``springs``:
    :class:`~.records.SpringArrays`; ``scratch``: :class:`~.records.ExplicitScratch` (unused
    here; the numba twin needs it).
    """
    n = x.shape[0]
    x0, mass = points.x0, points.mass
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
            largest = float(np.sqrt(np.einsum("ij,ij->i", step, step)).max(initial=0.0))
            x += step - momentum_shift(mass, step)
        if largest <= tolerance:
            break
    return passes, largest
