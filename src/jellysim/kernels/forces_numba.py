"""Numba: report eq. 1 spring forces, each spring once, race-free gather (see
:mod:`.numba_backend` for the scheme)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from .provot_numba import _momentum_shift, _provot_c_inv


@njit(**_opts)
def accelerations(x, v, points, springs, spring_scalar, a_out):
    n = x.shape[0]
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    rest, stiff = springs.rest, springs.stiff
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, second_other = springs.second_slot, springs.second_other
    first_other = springs.first_other
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        px, py, pz = np.float64(x[p, 0]), np.float64(x[p, 1]), np.float64(x[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            dx = x[q, 0] - px
            dy = x[q, 1] - py
            dz = x[q, 2] - pz
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            c = 0.0
            if length > 0.0:
                c = stiff[s] * (length - rest[s]) / length
            spring_scalar[second_slot[s]] = c
            fx += c * dx
            fy += c * dy
            fz += c * dz
        a_out[p, 0] = fx
        a_out[p, 1] = fy
        a_out[p, 2] = fz
    for q in prange(n):
        fx = a_out[q, 0]
        fy = a_out[q, 1]
        fz = a_out[q, 2]
        qx, qy, qz = np.float64(x[q, 0]), np.float64(x[q, 1]), np.float64(x[q, 2])
        for t in range(second_ptr[q], second_ptr[q + 1]):
            c = spring_scalar[t]
            i = second_other[t]
            fx += c * (x[i, 0] - qx)
            fy += c * (x[i, 1] - qy)
            fz += c * (x[i, 2] - qz)
        w = inv_mass[q]
        a_out[q, 0] = (fx - damping * v[q, 0]) * w + gx
        a_out[q, 1] = (fy - damping * v[q, 1]) * w + gy
        a_out[q, 2] = (fz - damping * v[q, 2]) * w + gz


@njit(**_opts)
def _accelerations_provot_fused(x, v, points, springs, tau, spring_scalar, provot_scalar,
                                a_out, dx, max_corr, apply):
    """``accelerations`` and the first Jacobi Provot pass over the springs, sharing one
    length computation per spring: valid when Provot follows the force evaluation with no
    position change in between (the report's order).  ``dx`` receives the pass's moves (the
    mean requests less their mass-weighted mean, as the spec); with ``apply`` positions are
    corrected in place."""
    n = x.shape[0]
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    rest, stiff = springs.rest, springs.stiff
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, second_other = springs.second_slot, springs.second_other
    first_other = springs.first_other
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
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
            inv = 1.0 / length if length > 0.0 else 0.0
            r0 = rest[s]
            c = stiff[s] * (length - r0) * inv
            slot = second_slot[s]
            spring_scalar[slot] = c
            fx += c * ex
            fy += c * ey
            fz += c * ez
            cp = _provot_c_inv(length, inv, r0, tau)
            provot_scalar[slot] = cp
            sx += cp * ex
            sy += cp * ey
            sz += cp * ez
            cnt += cp != 0.0
        a_out[p, 0] = fx
        a_out[p, 1] = fy
        a_out[p, 2] = fz
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        max_corr[p] = cnt
    for q in prange(n):
        fx = a_out[q, 0]
        fy = a_out[q, 1]
        fz = a_out[q, 2]
        sx = dx[q, 0]
        sy = dx[q, 1]
        sz = dx[q, 2]
        cnt = int(max_corr[q])
        qx, qy, qz = np.float64(x[q, 0]), np.float64(x[q, 1]), np.float64(x[q, 2])
        for t in range(second_ptr[q], second_ptr[q + 1]):
            i = second_other[t]
            ex = x[i, 0] - qx
            ey = x[i, 1] - qy
            ez = x[i, 2] - qz
            c = spring_scalar[t]
            fx += c * ex
            fy += c * ey
            fz += c * ez
            cp = provot_scalar[t]
            sx += cp * ex
            sy += cp * ey
            sz += cp * ez
            cnt += cp != 0.0
        w = inv_mass[q]
        a_out[q, 0] = (fx - damping * v[q, 0]) * w + gravity[0]
        a_out[q, 1] = (fy - damping * v[q, 1]) * w + gravity[1]
        a_out[q, 2] = (fz - damping * v[q, 2]) * w + gravity[2]
        if cnt > 0:
            sx /= cnt
            sy /= cnt
            sz /= cnt
        dx[q, 0] = sx
        dx[q, 1] = sy
        dx[q, 2] = sz
        max_corr[q] = np.sqrt(sx * sx + sy * sy + sz * sz)
    # less the moves' mass-weighted mean (provot_numpy.momentum_shift: momentum conserved)
    mx, my, mz = _momentum_shift(points.mass, dx)
    for p in prange(n):
        dx[p, 0] -= mx
        dx[p, 1] -= my
        dx[p, 2] -= mz
        if apply:  # else the caller's finishing pass applies dx
            x[p, 0] += dx[p, 0]
            x[p, 1] += dx[p, 1]
            x[p, 2] += dx[p, 2]
