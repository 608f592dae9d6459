"""Numba: Provot (1995) strain limiting, Jacobi (averaged, parallel) and Gauss-Seidel."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts


@njit(cache=True, inline="always")
def _provot_c(length, rest, tau):
    if length <= 0.0:
        return 0.0
    hi = (1.0 + tau) * rest
    lo = (1.0 - tau) * rest
    if length > hi:
        return 0.5 * (length - hi) / length
    if length < lo:
        return 0.5 * (length - lo) / length
    return 0.0


@njit(cache=True, inline="always")
def _provot_c_inv(length, inv_length, rest, tau):
    """Branch-free :func:`_provot_c` given ``1 / length`` (0 for a zero length): clamping
    compiles to min/max instead of unpredictable branches."""
    target = min(max(length, (1.0 - tau) * rest), (1.0 + tau) * rest)
    return 0.5 * (length - target) * inv_length


@njit(**_opts)
def _provot_jacobi_springs(x, springs, tau, spring_scalar, dx, count, max_corr):
    n = x.shape[0]
    rest = springs.rest
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, second_other = springs.second_slot, springs.second_other
    first_other = springs.first_other
    for p in prange(n):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        cnt = 0
        px, py, pz = np.float64(x[p, 0]), np.float64(x[p, 1]), np.float64(x[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            ex = x[q, 0] - px
            ey = x[q, 1] - py
            ez = x[q, 2] - pz
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            c = _provot_c_inv(length, 1.0 / length if length > 0.0 else 0.0, rest[s], tau)
            spring_scalar[second_slot[s]] = c
            sx += c * ex
            sy += c * ey
            sz += c * ez
            cnt += c != 0.0
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        count[p] = cnt
    for q in prange(n):
        sx = dx[q, 0]
        sy = dx[q, 1]
        sz = dx[q, 2]
        cnt = count[q]
        qx, qy, qz = np.float64(x[q, 0]), np.float64(x[q, 1]), np.float64(x[q, 2])
        for t in range(second_ptr[q], second_ptr[q + 1]):
            c = spring_scalar[t]
            i = second_other[t]
            sx -= c * (qx - x[i, 0])
            sy -= c * (qy - x[i, 1])
            sz -= c * (qz - x[i, 2])
            cnt += c != 0.0
        if cnt > 0:
            sx /= cnt
            sy /= cnt
            sz /= cnt
        dx[q, 0] = sx
        dx[q, 1] = sy
        dx[q, 2] = sz
        max_corr[q] = np.sqrt(sx * sx + sy * sy + sz * sz)
    for p in prange(n):
        x[p, 0] += dx[p, 0]
        x[p, 1] += dx[p, 1]
        x[p, 2] += dx[p, 2]


@njit(**_opts)
def _provot_jacobi_all(x, x0, tau, dx, max_corr):
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
    for p in prange(n):
        x[p, 0] += dx[p, 0]
        x[p, 1] += dx[p, 1]
        x[p, 2] += dx[p, 2]


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _serial_max(values):
    m = 0.0
    for i in range(values.shape[0]):
        if values[i] > m:
            m = values[i]
    return m


@njit(cache=True)
def provot(x, x0, springs, tau, loops, tolerance, all_pairs, gauss_seidel, scratch):
    spring_scalar, dx, count, max_corr = (scratch.spring_scalar, scratch.dx, scratch.count,
                                          scratch.max_corr)
    passes = 0
    largest = 0.0
    for _ in range(loops):
        passes += 1
        if gauss_seidel:
            largest = _provot_gs(x, x0, springs.ij, springs.rest, tau, all_pairs)
        elif all_pairs:
            _provot_jacobi_all(x, x0, tau, dx, max_corr)
            largest = _serial_max(max_corr)
        else:
            _provot_jacobi_springs(x, springs, tau, spring_scalar, dx, count, max_corr)
            largest = _serial_max(max_corr)
        if largest <= tolerance:
            break
    return passes, largest
