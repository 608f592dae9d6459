"""Numba kernels: same names, signatures and results as :mod:`.numpy_backend` (the spec).

Parallel loops run over *points*, never over springs with a scatter-add (that would race):
a spring's scalar is computed once, by the thread that owns its first point, while that thread
sums the spring's force on the first point, and written into the spring's slot of its second
point's list (``second_slot``: each slot has exactly one writer); a second pass gathers each
point's forces from its own contiguous slots.  Reading the scalars sequentially instead of
through an index halves the time of large bodies (BENCHMARKS.md).  Each point's sum is taken in
a fixed order, so the result is bitwise identical for any number of threads.  Floating-point
reductions across threads (like the largest Provot correction) are taken from per-point arrays
in a serial loop, also order-fixed.  ``cache=True``: a second process loads the compiled code.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY

_opts = dict(parallel=True, cache=True, nogil=True, error_model="numpy")


@njit(**_opts)
def accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff,
                  first_ptr, second_ptr, second_slot, second_other, spring_scalar, a_out):
    n = x.shape[0]
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        px, py, pz = x[p, 0], x[p, 1], x[p, 2]
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = spring_ij[s, 1]
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
        qx, qy, qz = x[q, 0], x[q, 1], x[q, 2]
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


@njit(**_opts)
def _provot_jacobi_springs(x, spring_ij, rest, first_ptr, second_ptr, second_slot,
                           second_other, tau, spring_scalar, dx, count, max_corr):
    n = x.shape[0]
    for p in prange(n):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        cnt = 0
        px, py, pz = x[p, 0], x[p, 1], x[p, 2]
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = spring_ij[s, 1]
            ex = x[q, 0] - px
            ey = x[q, 1] - py
            ez = x[q, 2] - pz
            c = _provot_c(np.sqrt(ex * ex + ey * ey + ez * ez), rest[s], tau)
            spring_scalar[second_slot[s]] = c
            if c != 0.0:
                sx += c * ex
                sy += c * ey
                sz += c * ez
                cnt += 1
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        count[p] = cnt
    for q in prange(n):
        sx = dx[q, 0]
        sy = dx[q, 1]
        sz = dx[q, 2]
        cnt = count[q]
        qx, qy, qz = x[q, 0], x[q, 1], x[q, 2]
        for t in range(second_ptr[q], second_ptr[q + 1]):
            c = spring_scalar[t]
            if c != 0.0:
                i = second_other[t]
                sx -= c * (qx - x[i, 0])
                sy -= c * (qy - x[i, 1])
                sz -= c * (qz - x[i, 2])
                cnt += 1
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
def _accelerations_provot_fused(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff,
                                first_ptr, second_ptr, second_slot, second_other, tau,
                                spring_scalar, provot_scalar, a_out, dx, max_corr):
    """``accelerations`` and the first Jacobi Provot pass over the springs, sharing one
    length computation per spring: valid when Provot follows the force evaluation with no
    position change in between (the report's order).  Positions are corrected in place."""
    n = x.shape[0]
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        sx = 0.0
        sy = 0.0
        sz = 0.0
        cnt = 0
        px, py, pz = x[p, 0], x[p, 1], x[p, 2]
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = spring_ij[s, 1]
            ex = x[q, 0] - px
            ey = x[q, 1] - py
            ez = x[q, 2] - pz
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            c = 0.0
            if length > 0.0:
                c = stiff[s] * (length - rest[s]) / length
            slot = second_slot[s]
            spring_scalar[slot] = c
            fx += c * ex
            fy += c * ey
            fz += c * ez
            cp = _provot_c(length, rest[s], tau)
            provot_scalar[slot] = cp
            if cp != 0.0:
                sx += cp * ex
                sy += cp * ey
                sz += cp * ez
                cnt += 1
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
        qx, qy, qz = x[q, 0], x[q, 1], x[q, 2]
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
            if cp != 0.0:
                sx += cp * ex
                sy += cp * ey
                sz += cp * ez
                cnt += 1
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
    ex = x[b, 0] - x[a, 0]
    ey = x[b, 1] - x[a, 1]
    ez = x[b, 2] - x[a, 2]
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
def provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot, second_other,
           tau, loops, tolerance, all_pairs, gauss_seidel, spring_scalar, dx, count, max_corr):
    passes = 0
    largest = 0.0
    for _ in range(loops):
        passes += 1
        if gauss_seidel:
            largest = _provot_gs(x, x0, spring_ij, rest, tau, all_pairs)
        elif all_pairs:
            _provot_jacobi_all(x, x0, tau, dx, max_corr)
            largest = _serial_max(max_corr)
        else:
            _provot_jacobi_springs(x, spring_ij, rest, first_ptr, second_ptr, second_slot,
                                   second_other, tau, spring_scalar, dx, count, max_corr)
            largest = _serial_max(max_corr)
        if largest <= tolerance:
            break
    return passes, largest


@njit(**_opts)
def finish_step(x, v, a, ground, height, mu, nu, center, bound2):
    n = x.shape[0]
    nonfinite = 0
    runaway = 0
    for p in prange(n):
        if ground and x[p, 1] < height:
            x[p, 1] = height
            v[p, 1] = 0.0
            v[p, 0] *= mu
            v[p, 2] *= mu
            a[p, 1] -= nu * a[p, 1]
        s = 0.0
        for c in range(3):
            s += x[p, c] + v[p, c] + a[p, c]
        if not np.isfinite(s):
            nonfinite += 1
        rx = x[p, 0] - center[0]
        ry = x[p, 1] - center[1]
        rz = x[p, 2] - center[2]
        if rx * rx + ry * ry + rz * rz > bound2:
            runaway += 1
    if nonfinite > 0:
        return STATUS_NONFINITE
    if runaway > 0:
        return STATUS_RUNAWAY
    return STATUS_OK


@njit(**_opts)
def _drift(x, v, a, dt, paper):
    for p in prange(x.shape[0]):
        for c in range(3):
            if paper:
                x[p, c] += v[p, c] * dt
                v[p, c] += a[p, c] * dt
            else:
                v[p, c] += a[p, c] * dt
                x[p, c] += v[p, c] * dt


@njit(**_opts)
def _copy(dst, src):
    for p in prange(src.shape[0]):
        for c in range(3):
            dst[p, c] = src[p, c]


@njit(**_opts)
def _add_velocity(v, x, x_pre, dt):
    inv = 1.0 / dt
    for p in prange(x.shape[0]):
        for c in range(3):
            v[p, c] += (x[p, c] - x_pre[p, c]) * inv


@njit(cache=True)
def run_steps(nsteps, dt, integrator, x, v, a, x0, inv_mass, damping, gravity,
              spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other,
              provot_loops, tau, tolerance, all_pairs, gauss_seidel, velocity_update,
              ground, height, mu, nu, center, bound2,
              spring_scalar, dx, count, max_corr, x_pre, provot_scalar):
    fuse = integrator == 0 and provot_loops > 0 and not all_pairs and not gauss_seidel
    for step in range(nsteps):
        if integrator == 0:
            _drift(x, v, a, dt, True)
            if provot_loops > 0 and velocity_update:
                _copy(x_pre, x)
            if fuse:
                # the report's order evaluates forces and then corrects the same positions:
                # one pass serves both (identical results to the separate kernels)
                _accelerations_provot_fused(x, v, inv_mass, damping, gravity, spring_ij, rest,
                                            stiff, first_ptr, second_ptr, second_slot,
                                            second_other, tau, spring_scalar, provot_scalar,
                                            a, dx, max_corr)
                if provot_loops > 1 and _serial_max(max_corr) > tolerance:
                    provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot,
                           second_other, tau, provot_loops - 1, tolerance, all_pairs,
                           gauss_seidel, spring_scalar, dx, count, max_corr)
            else:
                accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff,
                              first_ptr, second_ptr, second_slot, second_other, spring_scalar,
                              a)
        else:
            accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff, first_ptr,
                          second_ptr, second_slot, second_other, spring_scalar, a)
            _drift(x, v, a, dt, False)
            if provot_loops > 0 and velocity_update:
                _copy(x_pre, x)
        if provot_loops > 0:
            if not fuse:
                provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot,
                       second_other, tau, provot_loops, tolerance, all_pairs, gauss_seidel,
                       spring_scalar, dx, count, max_corr)
            if velocity_update:
                _add_velocity(v, x, x_pre, dt)
        status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK
