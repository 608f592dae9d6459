"""Numba: Provot (1995) strain limiting, Jacobi (averaged, parallel) and Gauss-Seidel."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from .provot_numpy import NOISE
from .spring_sums_numba import FAST_OPTS, point_provot


@njit(cache=True, inline="always")
def _provot_c(length, rest, tau):
    if length <= 0.0:
        return 0.0
    hi = (1.0 + tau) * rest
    lo = (1.0 - tau) * rest
    if length > hi:
        excess = length - hi
    elif length < lo:
        excess = length - lo
    else:
        return 0.0
    if abs(excess) <= NOISE * rest:  # rounding noise at the band edge: inside
        return 0.0
    return 0.5 * excess / length


@njit(cache=True, inline="always")
def _provot_c_inv(length, inv_length, rest, tau):
    """Branch-free :func:`_provot_c` given ``1 / length`` (0 for a zero length): clamping
    compiles to min/max instead of unpredictable branches."""
    target = min(max(length, (1.0 - tau) * rest), (1.0 + tau) * rest)
    excess = length - target
    excess = 0.0 if abs(excess) <= NOISE * rest else excess
    return 0.5 * excess * inv_length


@njit(cache=True, nogil=True)
def _momentum_shift(mass, dx):
    """The numpy spec's ``momentum_shift``: ``sum_q m_q dx_q / sum_q m_q`` (serially, in point
    order: the same result for any thread count, bitwise the spec's)."""
    sx = 0.0
    sy = 0.0
    sz = 0.0
    total = 0.0
    for p in range(dx.shape[0]):
        m = mass[p]
        sx += m * dx[p, 0]
        sy += m * dx[p, 1]
        sz += m * dx[p, 2]
        total += m
    return sx / total, sy / total, sz / total


@njit(**FAST_OPTS)
def _provot_requests(x, springs, tau, dx, max_corr):
    """Each point's mean Provot request over its springs [m] into ``dx`` (n, 3) and its length
    into ``max_corr`` (:mod:`.spring_sums_numba`)."""
    for p in prange(x.shape[0]):
        sx, sy, sz, cnt = point_provot(p, x, springs, tau)
        if cnt > 0:
            sx /= cnt
            sy /= cnt
            sz /= cnt
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        max_corr[p] = np.sqrt(sx * sx + sy * sy + sz * sz)


@njit(**_opts)
def shift_moves(x, dx, mass, apply):
    """Jacobi's moves ``dx`` (n, 3) [m] less their mass-weighted mean (momentum conserved,
    :func:`_momentum_shift`), in place; with ``apply`` also ``x += dx``.  Strict arithmetic
    (no fast-math), so every path that moves points this way rounds alike."""
    mx, my, mz = _momentum_shift(mass, dx)
    for p in prange(x.shape[0]):
        dx[p, 0] -= mx
        dx[p, 1] -= my
        dx[p, 2] -= mz
        if apply:
            x[p, 0] += dx[p, 0]
            x[p, 1] += dx[p, 1]
            x[p, 2] += dx[p, 2]


@njit(cache=True, nogil=True)
def _provot_jacobi_springs(x, mass, springs, tau, dx, max_corr):
    """One Jacobi pass over the springs: each point's mean request into ``dx`` and its length
    into ``max_corr`` [m], then every point moved by its request less the requests'
    mass-weighted mean."""
    _provot_requests(x, springs, tau, dx, max_corr)
    shift_moves(x, dx, mass, True)


@njit(**_opts)
def _provot_jacobi_all(x, x0, mass, tau, dx, max_corr):
    n = x.shape[0]
    for p in prange(n):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        cnt = 0
        for q in range(n):
            if q == p:
                continue
            ex = x[q, 0] - x[p, 0]
            ey = x[q, 1] - x[p, 1]
            ez = x[q, 2] - x[p, 2]
            rx = x0[q, 0] - x0[p, 0]
            ry = x0[q, 1] - x0[p, 1]
            rz = x0[q, 2] - x0[p, 2]
            c = _provot_c(np.sqrt(ex * ex + ey * ey + ez * ez),
                          np.sqrt(rx * rx + ry * ry + rz * rz), tau)
            if c != 0.0:
                sx += c * ex
                sy += c * ey
                sz += c * ez
                cnt += 1
        if cnt > 0:
            sx /= cnt
            sy /= cnt
            sz /= cnt
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        max_corr[p] = np.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = _momentum_shift(mass, dx)
    for p in prange(n):
        x[p, 0] += dx[p, 0] - sx
        x[p, 1] += dx[p, 1] - sy
        x[p, 2] += dx[p, 2] - sz


@njit(cache=True, nogil=True)
def _gs_pair(x, a, b, rest, tau):
    ex = np.float64(x[b, 0]) - x[a, 0]  # float64 arithmetic for a float32 state
    ey = np.float64(x[b, 1]) - x[a, 1]
    ez = np.float64(x[b, 2]) - x[a, 2]
    length = np.sqrt(ex * ex + ey * ey + ez * ez)
    c = _provot_c(length, rest, tau)
    if c != 0.0:
        x[a, 0] += c * ex
        x[a, 1] += c * ey
        x[a, 2] += c * ez
        x[b, 0] -= c * ex
        x[b, 1] -= c * ey
        x[b, 2] -= c * ez
    return abs(c) * length


@njit(cache=True, nogil=True)
def _provot_gs(x, x0, spring_ij, rest, tau, all_pairs):
    largest = 0.0
    if all_pairs:
        n = x.shape[0]
        for a in range(n):
            for b in range(a + 1, n):
                rx = x0[b, 0] - x0[a, 0]
                ry = x0[b, 1] - x0[a, 1]
                rz = x0[b, 2] - x0[a, 2]
                largest = max(largest, _gs_pair(x, a, b, np.sqrt(rx * rx + ry * ry + rz * rz),
                                                tau))
    else:
        for s in range(spring_ij.shape[0]):
            largest = max(largest, _gs_pair(x, spring_ij[s, 0], spring_ij[s, 1], rest[s], tau))
    return largest


@njit(cache=True, nogil=True)
def _serial_max(values):
    m = 0.0
    for i in range(values.shape[0]):
        if values[i] > m:
            m = values[i]
    return m


@njit(cache=True, nogil=True)
def provot(x, points, springs, tau, loops, tolerance, all_pairs, gauss_seidel, scratch):
    """Same contract as :func:`jellysim.kernels.provot_numpy.provot` (the spec)."""
    x0, mass = points.x0, points.mass
    dx, max_corr = scratch.dx, scratch.max_corr
    passes = 0
    largest = 0.0
    for _ in range(loops):
        passes += 1
        if gauss_seidel:
            largest = _provot_gs(x, x0, springs.ij, springs.rest, tau, all_pairs)
        elif all_pairs:
            _provot_jacobi_all(x, x0, mass, tau, dx, max_corr)
            largest = _serial_max(max_corr)
        else:
            _provot_jacobi_springs(x, mass, springs, tau, dx, max_corr)
            largest = _serial_max(max_corr)
        if largest <= tolerance:
            break
    return passes, largest
