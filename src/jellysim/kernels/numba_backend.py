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


@njit(cache=True, inline="always")
def _provot_c_inv(length, inv_length, rest, tau):
    """Branch-free :func:`_provot_c` given ``1 / length`` (0 for a zero length): clamping
    compiles to min/max instead of unpredictable branches."""
    target = min(max(length, (1.0 - tau) * rest), (1.0 + tau) * rest)
    return 0.5 * (length - target) * inv_length


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
        qx, qy, qz = x[q, 0], x[q, 1], x[q, 2]
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
def _accelerations_provot_fused(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff,
                                first_ptr, second_ptr, second_slot, second_other, tau,
                                spring_scalar, provot_scalar, a_out, dx, max_corr, apply):
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
    if apply:  # else the caller's finishing pass applies dx (one parallel region less)
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


@njit(cache=True, inline="always")
def _ground_and_check(p, x, v, a, ground, height, mu, nu, center, bound2):
    """The report's ground rule on point p, then (non-finite?, runaway?) as 0/1 ints."""
    if ground and x[p, 1] < height:
        x[p, 1] = height
        v[p, 1] = 0.0
        v[p, 0] *= mu
        v[p, 2] *= mu
        a[p, 1] -= nu * a[p, 1]
    s = 0.0
    for c in range(3):
        s += x[p, c] + v[p, c] + a[p, c]
    rx = x[p, 0] - center[0]
    ry = x[p, 1] - center[1]
    rz = x[p, 2] - center[2]
    return (0 if np.isfinite(s) else 1), (1 if rx * rx + ry * ry + rz * rz > bound2 else 0)


@njit(cache=True, inline="always")
def _status(nonfinite, runaway):
    if nonfinite > 0:
        return STATUS_NONFINITE
    if runaway > 0:
        return STATUS_RUNAWAY
    return STATUS_OK


@njit(**_opts)
def finish_step(x, v, a, ground, height, mu, nu, center, bound2):
    n = x.shape[0]
    nonfinite = 0
    runaway = 0
    for p in prange(n):
        bad, far = _ground_and_check(p, x, v, a, ground, height, mu, nu, center, bound2)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


@njit(**_opts)
def _drift(x, v, a, dt, paper, x_pre, save):
    """Integrator position/velocity update; with ``save``, also x_pre = x afterwards."""
    for p in prange(x.shape[0]):
        for c in range(3):
            if paper:
                x[p, c] += v[p, c] * dt
                v[p, c] += a[p, c] * dt
            else:
                v[p, c] += a[p, c] * dt
                x[p, c] += v[p, c] * dt
            if save:
                x_pre[p, c] = x[p, c]


@njit(**_opts)
def _finish_fused(x, v, a, dx, apply_dx, x_pre, add_velocity, dt, ground, height, mu, nu,
                  center, bound2):
    """Per point, in one parallel region: (x += dx), (v += (x - x_pre) / dt), then exactly
    :func:`finish_step`'s ground rule and checks."""
    n = x.shape[0]
    inv = 1.0 / dt
    nonfinite = 0
    runaway = 0
    for p in prange(n):
        for c in range(3):
            if apply_dx:
                x[p, c] += dx[p, c]
            if add_velocity:
                v[p, c] += (x[p, c] - x_pre[p, c]) * inv
        bad, far = _ground_and_check(p, x, v, a, ground, height, mu, nu, center, bound2)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


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
              ground, height, mu, nu, obstacle_kind, obstacle_data, rest_speed, center, bound2,
              spring_scalar, dx, count, max_corr, x_pre, provot_scalar):
    fuse = integrator == 0 and provot_loops > 0 and not all_pairs and not gauss_seidel
    obstacles = obstacle_kind.shape[0] > 0
    save = provot_loops > 0 and velocity_update
    for step in range(nsteps):
        pending = False  # a Provot correction in dx still to be applied by the finishing pass
        if integrator == 0:
            _drift(x, v, a, dt, True, x_pre, save)
            if fuse:
                # the report's order evaluates forces and then corrects the same positions:
                # one pass serves both (identical results to the separate kernels)
                last = provot_loops == 1 and not obstacles
                _accelerations_provot_fused(x, v, inv_mass, damping, gravity, spring_ij, rest,
                                            stiff, first_ptr, second_ptr, second_slot,
                                            second_other, tau, spring_scalar, provot_scalar,
                                            a, dx, max_corr, not last)
                pending = last
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
            _drift(x, v, a, dt, False, x_pre, save)
        if provot_loops > 0 and not fuse:
            provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot,
                   second_other, tau, provot_loops, tolerance, all_pairs, gauss_seidel,
                   spring_scalar, dx, count, max_corr)
        if obstacles:
            if save:
                _add_velocity(v, x, x_pre, dt)
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt)
            status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        else:
            status = _finish_fused(x, v, a, dx, pending, x_pre, save, dt, ground, height, mu,
                                   nu, center, bound2)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK


# -- physical contact (planes, spheres, boxes) ----------------------------------------------
@njit(cache=True, inline="always")
def _contact_point(kind, g, px, py, pz):
    """(phi, nx, ny, nz) of one point against one obstacle (see the numpy spec)."""
    if kind == 0:
        return ((px - g[0]) * g[3] + (py - g[1]) * g[4] + (pz - g[2]) * g[5], g[3], g[4], g[5])
    if kind == 1:
        dx = px - g[0]
        dy = py - g[1]
        dz = pz - g[2]
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        if r > 0.0:
            return r - g[3], dx / r, dy / r, dz / r
        return r - g[3], 0.0, 1.0, 0.0
    best = px - g[0]
    face = 0
    p = (px, py, pz)
    inside = True
    for f in range(6):
        c = f % 3
        d = p[c] - g[c] if f < 3 else g[3 + c] - p[c]
        if not d > 0.0:
            inside = False
        if d < best:
            best = d
            face = f
    if not inside:
        return 1.0, 0.0, 0.0, 0.0
    nx = 0.0
    ny = 0.0
    nz = 0.0
    s = -1.0 if face < 3 else 1.0
    if face % 3 == 0:
        nx = s
    elif face % 3 == 1:
        ny = s
    else:
        nz = s
    return -best, nx, ny, nz


@njit(**_opts)
def contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt):
    n = x.shape[0]
    m = obstacle_kind.shape[0]
    for p in prange(n):
        for o in range(m):
            g = obstacle_data[o]
            phi, nx, ny, nz = _contact_point(obstacle_kind[o], g, x[p, 0], x[p, 1], x[p, 2])
            if not phi < 0.0:
                continue
            x[p, 0] -= phi * nx
            x[p, 1] -= phi * ny
            x[p, 2] -= phi * nz
            vn = v[p, 0] * nx + v[p, 1] * ny + v[p, 2] * nz
            tx = v[p, 0] - vn * nx
            ty = v[p, 1] - vn * ny
            tz = v[p, 2] - vn * nz
            vn_new = vn
            scale = 1.0
            if vn < 0.0:
                vn_new = -g[6] * vn if -vn > rest_speed else 0.0
                dvn = vn_new - vn
                speed = np.sqrt(tx * tx + ty * ty + tz * tz)
                if speed <= g[7] * dvn:
                    scale = 0.0
                elif speed > 0.0:
                    scale = max(1.0 - g[8] * dvn / speed, 0.0)
            x[p, 0] += (scale - 1.0) * tx * dt
            x[p, 1] += (scale - 1.0) * ty * dt
            x[p, 2] += (scale - 1.0) * tz * dt
            v[p, 0] = scale * tx + vn_new * nx
            v[p, 1] = scale * ty + vn_new * ny
            v[p, 2] = scale * tz + vn_new * nz


# -- linearly implicit theta-method (stiff-stable integrator) --------------------------------
@njit(**_opts)
def spring_frames(x, spring_ij, rest, stiff, frame, clip):
    for s in prange(spring_ij.shape[0]):
        i = spring_ij[s, 0]
        j = spring_ij[s, 1]
        dx = x[j, 0] - x[i, 0]
        dy = x[j, 1] - x[i, 1]
        dz = x[j, 2] - x[i, 2]
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        frame[s, 3] = stiff[s]
        if length > 0.0:
            frame[s, 0] = dx / length
            frame[s, 1] = dy / length
            frame[s, 2] = dz / length
            geo = stiff[s] * (1.0 - rest[s] / length)
            frame[s, 4] = max(geo, 0.0) if clip else geo
        else:
            frame[s, 0] = 0.0
            frame[s, 1] = 0.0
            frame[s, 2] = 0.0
            frame[s, 4] = 0.0


@njit(**_opts)
def system_matvec(u, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr, second_slot,
                  second_other, spring_vec, out):
    n = u.shape[0]
    for p in prange(n):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = spring_ij[s, 1]
            dx = u[q, 0] - u[p, 0]
            dy = u[q, 1] - u[p, 1]
            dz = u[q, 2] - u[p, 2]
            nx = frame[s, 0]
            ny = frame[s, 1]
            nz = frame[s, 2]
            g = frame[s, 4]
            c = (frame[s, 3] - g) * (nx * dx + ny * dy + nz * dz)
            vx = c * nx + g * dx
            vy = c * ny + g * dy
            vz = c * nz + g * dz
            slot = second_slot[s]
            spring_vec[slot, 0] = vx
            spring_vec[slot, 1] = vy
            spring_vec[slot, 2] = vz
            sx -= vx
            sy -= vy
            sz -= vz
        out[p, 0] = sx
        out[p, 1] = sy
        out[p, 2] = sz
    for q in prange(n):
        sx = out[q, 0]
        sy = out[q, 1]
        sz = out[q, 2]
        for t in range(second_ptr[q], second_ptr[q + 1]):
            sx += spring_vec[t, 0]
            sy += spring_vec[t, 1]
            sz += spring_vec[t, 2]
        w = mass[q] + shift[q]
        out[q, 0] = w * u[q, 0] + h2 * sx
        out[q, 1] = w * u[q, 1] + h2 * sy
        out[q, 2] = w * u[q, 2] + h2 * sz


@njit(cache=True)
def system_diagonal(mass, shift, h2, spring_ij, frame, diag):
    # a serial pass in spring order (O(k), once per step): same sum order as numpy's bincount
    for p in range(mass.shape[0]):
        for c in range(3):
            diag[p, c] = 0.0
    _diag_gather(mass, shift, h2, spring_ij, frame, diag)


@njit(cache=True)
def _diag_gather(mass, shift, h2, spring_ij, frame, diag):
    # serial: O(k), once per step; keeps the sum order fixed (spring index order)
    for s in range(spring_ij.shape[0]):
        g = frame[s, 4]
        kk = frame[s, 3] - g
        for c in range(3):
            d = kk * frame[s, c] * frame[s, c] + g
            diag[spring_ij[s, 0], c] += d
            diag[spring_ij[s, 1], c] += d
    for p in range(mass.shape[0]):
        for c in range(3):
            diag[p, c] = mass[p] + shift[p] + h2 * diag[p, c]


_FREE = 0
_RELEASED = 1
_STUCK = 2


@njit(**_opts)
def contact_normals(x, v, obstacle_kind, obstacle_data, margin, contact_state, dt, rest_speed,
                    first_ptr, second_ptr, cnrm, cobs, offset):
    for q in prange(x.shape[0]):
        for c in range(6):
            cnrm[q, c] = 0.0
        cobs[q] = -1
        if contact_state[q] == _RELEASED:
            continue
        for o in range(obstacle_kind.shape[0]):
            phi, nx, ny, nz = _contact_point(obstacle_kind[o], obstacle_data[o], x[q, 0],
                                             x[q, 1], x[q, 2])
            vn = v[q, 0] * nx + v[q, 1] * ny + v[q, 2] * nz
            gap = phi + offset[q, 0] * nx + offset[q, 1] * ny + offset[q, 2] * nz
            if vn <= 0.0 and gap + dt * min(vn, 0.0) <= margin:
                cnrm[q, 0] = nx
                cnrm[q, 1] = ny
                cnrm[q, 2] = nz
                impact = -vn if -vn > rest_speed else 0.0
                free = (first_ptr[q + 1] - first_ptr[q] + second_ptr[q + 1]
                        - second_ptr[q]) == 0
                if impact > 0.0 and free:
                    cnrm[q, 3] = obstacle_data[o, 6] * impact
                else:
                    cnrm[q, 3] = -(max(phi, 0.0) + gap - phi) / dt
                cnrm[q, 4] = impact
                cnrm[q, 5] = 1.0 if contact_state[q] == _STUCK else 0.0
                cobs[q] = o
                break


@njit(**_opts)
def filter_constrained(u, cnrm):
    for q in prange(u.shape[0]):
        d = u[q, 0] * cnrm[q, 0] + u[q, 1] * cnrm[q, 1] + u[q, 2] * cnrm[q, 2]
        keep = 1.0 - cnrm[q, 5]
        u[q, 0] = (u[q, 0] - d * cnrm[q, 0]) * keep
        u[q, 1] = (u[q, 1] - d * cnrm[q, 1]) * keep
        u[q, 2] = (u[q, 2] - d * cnrm[q, 2]) * keep


@njit(**_opts)
def constrain_start(dv, v, cnrm):
    for q in prange(dv.shape[0]):
        nx = cnrm[q, 0]
        ny = cnrm[q, 1]
        nz = cnrm[q, 2]
        stick = cnrm[q, 5]
        d = dv[q, 0] * nx + dv[q, 1] * ny + dv[q, 2] * nz
        keep = 1.0 - stick
        vn = v[q, 0] * nx + v[q, 1] * ny + v[q, 2] * nz
        t = cnrm[q, 3] - vn
        dv[q, 0] = (dv[q, 0] - d * nx) * keep + t * nx - stick * (v[q, 0] - vn * nx)
        dv[q, 1] = (dv[q, 1] - d * ny) * keep + t * ny - stick * (v[q, 1] - vn * ny)
        dv[q, 2] = (dv[q, 2] - d * nz) * keep + t * nz - stick * (v[q, 2] - vn * nz)


@njit(**_opts)
def constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data, dt, contact_state):
    for q in prange(x.shape[0]):
        contact_state[q] = _FREE
        o = cobs[q]
        if o < 0:
            continue
        nx = cnrm[q, 0]
        ny = cnrm[q, 1]
        nz = cnrm[q, 2]
        jx = ap[q, 0] - b[q, 0]
        jy = ap[q, 1] - b[q, 1]
        jz = ap[q, 2] - b[q, 2]
        jn = jx * nx + jy * ny + jz * nz
        was_stuck = cnrm[q, 5] > 0.0
        jtx = jx - jn * nx
        jty = jy - jn * ny
        jtz = jz - jn * nz
        jt_norm = np.sqrt(jtx * jtx + jty * jty + jtz * jtz)
        budget = max(jn, 0.0) / mass[q]
        vn = v[q, 0] * nx + v[q, 1] * ny + v[q, 2] * nz
        tx = v[q, 0] - vn * nx
        ty = v[q, 1] - vn * ny
        tz = v[q, 2] - vn * nz
        speed = np.sqrt(tx * tx + ty * ty + tz * tz)
        stick = speed <= obstacle_data[o, 7] * budget
        if stick or was_stuck:
            scale = 0.0
        elif speed > 0.0:
            scale = max(1.0 - obstacle_data[o, 8] * budget / speed, 0.0)
        else:
            scale = 1.0
        x[q, 0] += (scale - 1.0) * tx * dt
        x[q, 1] += (scale - 1.0) * ty * dt
        x[q, 2] += (scale - 1.0) * tz * dt
        v[q, 0] = scale * tx + vn * nx
        v[q, 1] = scale * ty + vn * ny
        v[q, 2] = scale * tz + vn * nz
        if was_stuck:
            holds = jt_norm <= obstacle_data[o, 7] * max(jn, 0.0)
        else:
            holds = stick
        if jn < 0.0:
            contact_state[q] = _RELEASED
        elif holds:
            contact_state[q] = _STUCK


@njit(cache=True)
def _serial_max_int(values):
    m = -1
    for i in range(values.shape[0]):
        if values[i] > m:
            m = values[i]
    return m


@njit(cache=True)
def _project_net_residual(dv, b, ap, mass, shift):
    """dv += sum(b - A dv) / sum(m + shift): serial sums, fixed order."""
    w = 0.0
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for q in range(dv.shape[0]):
        w += mass[q] + shift[q]
        s0 += b[q, 0] - ap[q, 0]
        s1 += b[q, 1] - ap[q, 1]
        s2 += b[q, 2] - ap[q, 2]
    for q in range(dv.shape[0]):
        dv[q, 0] += s0 / w
        dv[q, 1] += s1 / w
        dv[q, 2] += s2 / w


@njit(cache=True)
def _dot(a, b):
    s = 0.0
    for p in range(a.shape[0]):
        for c in range(3):
            s += a[p, c] * b[p, c]
    return s


@njit(**_opts)
def _axpy_pair(dv, r, p, ap, alpha):
    for q in prange(dv.shape[0]):
        for c in range(3):
            dv[q, c] += alpha * p[q, c]
            r[q, c] -= alpha * ap[q, c]


@njit(**_opts)
def _precondition(z, r, diag):
    for q in prange(z.shape[0]):
        for c in range(3):
            z[q, c] = r[q, c] / diag[q, c]


@njit(**_opts)
def _update_direction(p, z, beta):
    for q in prange(p.shape[0]):
        for c in range(3):
            p[q, c] = z[q, c] + beta * p[q, c]


@njit(**_opts)
def _implicit_rhs(b, ap, mass, a, v, dt, h):
    # ap holds (m v + K v) on entry
    for q in prange(b.shape[0]):
        for c in range(3):
            kv = ap[q, c] - mass[q] * v[q, c]
            b[q, c] = dt * (mass[q] * a[q, c] - h * kv)


@njit(**_opts)
def _residual(r, b, ap):
    for q in prange(r.shape[0]):
        for c in range(3):
            r[q, c] = b[q, c] - ap[q, c]


@njit(**_opts)
def _implicit_update(x, v, a, dv, dt, theta):
    for q in prange(x.shape[0]):
        for c in range(3):
            x[q, c] += dt * (v[q, c] + theta * dv[q, c])
            v[q, c] += dv[q, c]
            a[q, c] = dv[q, c] / dt


@njit(**_opts)
def _bdf2_start(x, v, a, x_prev, v_prev, fresh, w, dt, beta):
    # restart the history where marked (as if the point had come with its present
    # acceleration: the step is then a backward-Euler-like one), then
    # w = (x - x_prev) / 3 + beta v
    for q in prange(x.shape[0]):
        if fresh[q]:
            for c in range(3):
                x_prev[q, c] = x[q, c] - dt * v[q, c]
                v_prev[q, c] = v[q, c] - dt * a[q, c]
        for c in range(3):
            w[q, c] = (x[q, c] - x_prev[q, c]) / 3.0 + beta * v[q, c]


@njit(**_opts)
def _bdf2_offset(offset, x, x_prev):
    for q in prange(x.shape[0]):
        for c in range(3):
            offset[q, c] = (x[q, c] - x_prev[q, c]) / 3.0


@njit(**_opts)
def _bdf2_rhs(b, ap, mass, a, v, v_prev, w, beta):
    # ap holds (m w + K w) on entry
    for q in prange(b.shape[0]):
        for c in range(3):
            kw = ap[q, c] - mass[q] * w[q, c]
            b[q, c] = beta * (mass[q] * a[q, c] - kw) + mass[q] * (v[q, c] - v_prev[q, c]) / 3.0


@njit(**_opts)
def _bdf2_update(x, v, a, dv, x_prev, v_prev, x_int, dt, beta):
    for q in prange(x.shape[0]):
        for c in range(3):
            xn = x[q, c] + (x[q, c] - x_prev[q, c]) / 3.0 + beta * (v[q, c] + dv[q, c])
            x_prev[q, c] = x[q, c]
            v_prev[q, c] = v[q, c]
            x[q, c] = xn
            v[q, c] += dv[q, c]
            a[q, c] = dv[q, c] / dt
            x_int[q, c] = x[q, c]


@njit(**_opts)
def _bdf2_contact_velocity(v, x, x_old, cnrm, cobs, dt, first_ptr, second_ptr):
    # a constrained body point's normal velocity is the one its step took: the BDF2 velocity
    # that lands it on the surface also cancels its history, and would launch it at the next
    # step (a free particle keeps its prescribed bounce)
    for q in prange(x.shape[0]):
        free = (first_ptr[q + 1] - first_ptr[q] + second_ptr[q + 1] - second_ptr[q]) == 0
        if cobs[q] < 0 or free:
            continue
        nx = cnrm[q, 0]
        ny = cnrm[q, 1]
        nz = cnrm[q, 2]
        moved = ((x[q, 0] - x_old[q, 0]) * nx + (x[q, 1] - x_old[q, 1]) * ny
                 + (x[q, 2] - x_old[q, 2]) * nz) / dt
        d = moved - (v[q, 0] * nx + v[q, 1] * ny + v[q, 2] * nz)
        v[q, 0] += d * nx
        v[q, 1] += d * ny
        v[q, 2] += d * nz


@njit(**_opts)
def _bdf2_mark(fresh, cobs, x, v, x_int, v_int):
    for q in prange(x.shape[0]):
        moved = cobs[q] >= 0
        for c in range(3):
            if x[q, c] != x_int[q, c] or v[q, c] != v_int[q, c]:
                moved = True
        fresh[q] = 1 if moved else 0


@njit(cache=True)
def implicit_steps(nsteps, dt, theta, tol, max_iter, x, v, a, inv_mass, damping, gravity,
                   spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other,
                   ground, height, mu, nu, obstacle_kind, obstacle_data, rest_speed,
                   center, bound2, spring_scalar, frame, spring_vec, dv, r, z, p, ap, diag,
                   b, cnrm, mass, cobs, contact_state, bdf2, hist, fresh):
    h = 2.0 * dt / 3.0 if bdf2 else theta * dt
    h2 = h * h
    n = mass.shape[0]
    shift = np.full(n, h * damping)
    zero = np.zeros(n)
    iters = 0
    worst = 0.0
    for step in range(nsteps):
        accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff, first_ptr,
                      second_ptr, second_slot, second_other, spring_scalar, a)
        bnorm = 0.0
        res = 0.0
        for attempt in range(2):
            clip = attempt == 1
            spring_frames(x, spring_ij, rest, stiff, frame, clip)
            system_diagonal(mass, shift, h2, spring_ij, frame, diag)
            if not clip and diag.min() <= 0.0:
                continue
            if bdf2:
                _bdf2_start(x, v, a, hist[0], hist[1], fresh, hist[2], dt, h)
                system_matvec(hist[2], mass, zero, 1.0, spring_ij, frame, first_ptr,
                              second_ptr, second_slot, second_other, spring_vec, ap)
                _bdf2_rhs(b, ap, mass, a, v, hist[1], hist[2], h)
            else:
                system_matvec(v, mass, zero, 1.0, spring_ij, frame, first_ptr, second_ptr,
                              second_slot, second_other, spring_vec, ap)
                _implicit_rhs(b, ap, mass, a, v, dt, h)
            if bdf2:
                _bdf2_offset(hist[3], x, hist[0])
            contact_normals(x, v, obstacle_kind, obstacle_data, 1e-9, contact_state,
                            h if bdf2 else dt, rest_speed, first_ptr, second_ptr, cnrm, cobs,
                            hist[3])
            if clip:
                dv[:] = 0.0
            constrain_start(dv, v, cnrm)
            bnorm = np.sqrt(_dot(b, b))
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
            _residual(r, b, ap)
            filter_constrained(r, cnrm)
            _precondition(z, r, diag)
            filter_constrained(z, cnrm)
            _copy(p, z)
            rz = _dot(r, z)
            res = np.sqrt(_dot(r, r))
            it = 0
            broke = False
            while it < max_iter and res > tol * bnorm:
                system_matvec(p, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                              second_slot, second_other, spring_vec, ap)
                filter_constrained(ap, cnrm)
                pap = _dot(p, ap)
                if pap <= 0.0:
                    broke = True
                    break
                alpha = rz / pap
                _axpy_pair(dv, r, p, ap, alpha)
                _precondition(z, r, diag)
                filter_constrained(z, cnrm)
                rz_new = _dot(r, z)
                _update_direction(p, z, rz_new / rz)
                rz = rz_new
                res = np.sqrt(_dot(r, r))
                it += 1
            iters += it
            if not broke:
                break
        if bnorm > 0.0:
            worst = max(worst, res / bnorm)
        if _serial_max_int(cobs) < 0:
            # free flight: project the solve's net residual out (see the numpy spec)
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
            _project_net_residual(dv, b, ap, mass, shift)
        if bdf2:
            _bdf2_update(x, v, a, dv, hist[0], hist[1], hist[2], dt, h)
            _bdf2_contact_velocity(v, x, hist[0], cnrm, cobs, dt, first_ptr, second_ptr)
            _copy(hist[3], v)  # the velocity the obstacles and the ground will be judged from
        else:
            _implicit_update(x, v, a, dv, dt, theta)
        if obstacle_kind.shape[0] > 0:
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
            constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data,
                                h if bdf2 else dt, contact_state)
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt)
        status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        if bdf2:
            _bdf2_mark(fresh, cobs, x, v, hist[2], hist[3])
        if status != STATUS_OK:
            return step + 1, status, iters, worst
    return nsteps, STATUS_OK, iters, worst


@njit(**_opts)
def csr_matmat(indptr, indices, data, x, out):
    """``out = A x`` for a CSR matrix ``A`` (indptr, indices, data) and a dense block ``x``
    (n, m): rows in parallel, each row's sum in a fixed order (the same result for any thread
    count)."""
    m = x.shape[1]
    for i in prange(out.shape[0]):
        for c in range(m):
            out[i, c] = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            a = data[p]
            for c in range(m):
                out[i, c] += a * x[j, c]
