"""Numba: the linearly implicit theta-method and BDF2 with matrix-free, Jacobi-preconditioned
conjugate gradients (contact constraints inside the solve); a CSR block product."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from . import STATUS_OK
from .contact_numba import (constrain_start, constraint_friction, contact, contact_normals,
                            filter_constrained, finish_step, update_active_set)
from .contact_numpy import MAX_CONE_PASSES
from .forces_numba import accelerations


@njit(**_opts)
def spring_frames(x, springs, frame, clip):
    spring_ij, rest, stiff = springs.ij, springs.rest, springs.stiff
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
def system_matvec(u, mass, shift, h2, springs, frame, spring_vec, out):
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, first_other = springs.second_slot, springs.first_other
    n = u.shape[0]
    for p in prange(n):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
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


@njit(cache=True, nogil=True)
def system_diagonal(mass, shift, h2, springs, frame, diag):
    # a serial pass in spring order (O(k), once per step): same sum order as numpy's bincount
    for p in range(mass.shape[0]):
        for c in range(3):
            diag[p, c] = 0.0
    _diag_gather(mass, shift, h2, springs.ij, frame, diag)


@njit(cache=True, nogil=True)
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


@njit(**_opts)
def _copy(dst, src):
    for p in prange(src.shape[0]):
        for c in range(3):
            dst[p, c] = src[p, c]


@njit(cache=True, nogil=True)
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
def _bdf2_contact_velocity(v, x, x_old, cnrm, cobs, dt, springs):
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
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


@njit(cache=True, nogil=True)
def _serial_max_int(values):
    m = -1
    for i in range(values.shape[0]):
        if values[i] > m:
            m = values[i]
    return m


@njit(cache=True, nogil=True)
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


@njit(**_opts)
def _add(out, u):
    for q in prange(out.shape[0]):
        for c in range(3):
            out[q, c] += u[q, c]


@njit(cache=True, nogil=True)
def implicit_steps(nsteps, dt, x, v, a, springs, points, ground, obstacles, options, scratch):
    """Same contract as :func:`jellysim.kernels.implicit_numpy.implicit_steps` (the spec)."""
    theta, tol, max_iter, bdf2 = (options.theta, options.tolerance, options.max_iterations,
                                  options.bdf2)
    mass, damping = points.mass, points.damping
    obstacle_kind, obstacle_data, rest_speed = obstacles.kind, obstacles.data, obstacles.rest_speed
    sc = scratch
    frame, spring_vec, dv, r, z, p, ap, diag, b = (sc.frame, sc.spring_vec, sc.dv, sc.r, sc.z,
                                                   sc.p, sc.ap, sc.diag, sc.b)
    cnrm, cobs, contact_state, hist, fresh = (sc.cnrm, sc.cobs, sc.contact_state, sc.hist,
                                              sc.fresh)
    g = ground
    h = 2.0 * dt / 3.0 if bdf2 else theta * dt
    h2 = h * h
    n = mass.shape[0]
    shift = np.full(n, h * damping)
    zero = np.zeros(n)
    iters = 0
    worst = 0.0
    for step in range(nsteps):
        accelerations(x, v, points, springs, sc.spring_scalar, a)
        bnorm = 0.0
        res = 0.0
        # Coulomb inside the step: the active-set iteration of the numpy spec
        sc.friction[:] = 0.0
        for cone_pass in range(MAX_CONE_PASSES):
            for attempt in range(2):
                clip = attempt == 1
                spring_frames(x, springs, frame, clip)
                system_diagonal(mass, shift, h2, springs, frame, diag)
                if not clip and diag.min() <= 0.0:
                    continue
                if bdf2:
                    _bdf2_start(x, v, a, hist[0], hist[1], fresh, hist[2], dt, h)
                    system_matvec(hist[2], mass, zero, 1.0, springs, frame, spring_vec, ap)
                    _bdf2_rhs(b, ap, mass, a, v, hist[1], hist[2], h)
                else:
                    system_matvec(v, mass, zero, 1.0, springs, frame, spring_vec, ap)
                    _implicit_rhs(b, ap, mass, a, v, dt, h)
                _add(b, sc.friction)
                if bdf2:
                    _bdf2_offset(hist[3], x, hist[0])
                contact_normals(x, v, obstacle_kind, obstacle_data, 1e-9, contact_state,
                                h if bdf2 else dt, rest_speed, springs, cnrm, cobs, hist[3])
                if clip:
                    dv[:] = 0.0
                constrain_start(dv, v, cnrm)
                bnorm = np.sqrt(_dot(b, b))
                system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
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
                    system_matvec(p, mass, shift, h2, springs, frame, spring_vec, ap)
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
            if obstacle_kind.shape[0] == 0 or cone_pass == MAX_CONE_PASSES - 1:
                break
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            if update_active_set(v, dv, b, ap, mass, cnrm, cobs, obstacle_data, contact_state,
                                 sc.friction) == 0:
                break
        if bnorm > 0.0:
            worst = max(worst, res / bnorm)
        if _serial_max_int(cobs) < 0:
            # free flight: project the solve's net residual out (see the numpy spec)
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            _project_net_residual(dv, b, ap, mass, shift)
        if bdf2:
            _bdf2_update(x, v, a, dv, hist[0], hist[1], hist[2], dt, h)
            _bdf2_contact_velocity(v, x, hist[0], cnrm, cobs, dt, springs)
            _copy(hist[3], v)  # the velocity the obstacles and the ground will be judged from
        else:
            _implicit_update(x, v, a, dv, dt, theta)
        if obstacle_kind.shape[0] > 0:
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data,
                                h if bdf2 else dt, contact_state, sc.friction)
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt, obstacles.slip)
        status = finish_step(x, v, a, g.paper, g.height, g.mu, g.nu, g.center, g.bound2)
        if bdf2:
            _bdf2_mark(fresh, cobs, x, v, hist[2], hist[3])
        if status != STATUS_OK:
            return step + 1, status, iters, worst
    return nsteps, STATUS_OK, iters, worst
