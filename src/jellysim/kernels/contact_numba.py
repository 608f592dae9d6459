"""Numba: the report's ground and the guard (:func:`finish_step`), obstacle contact with
restitution and Coulomb friction, and the implicit solve's contact constraints."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from .records import OBSTACLE_E, OBSTACLE_MU_K, OBSTACLE_MU_S, OBSTACLE_SLIP
from . import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY
from .contact_numpy import FRICTION_REL_TOL, NO_SLIP, RESTING_GAP, RESTING_SHARE


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
def contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt, slip):
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
            step = np.sqrt(v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2]) * dt
            bounce = -vn > rest_speed and phi - vn * dt > RESTING_SHARE * step + RESTING_GAP
            if g[OBSTACLE_MU_S] > NO_SLIP:  # no slip: held along the surface while touching
                scale = 0.0
                slip[p] = 0.0
                if vn < 0.0:
                    vn_new = -g[OBSTACLE_E] * vn if bounce else 0.0
            elif vn < 0.0:
                vn_new = -g[OBSTACLE_E] * vn if bounce else 0.0
                dvn = vn_new - vn
                speed = np.sqrt(tx * tx + ty * ty + tz * tz)
                mu = g[OBSTACLE_MU_K] + _weakening(slip[p], g[OBSTACLE_SLIP]) * (
                    g[OBSTACLE_MU_S] - g[OBSTACLE_MU_K])
                if speed <= mu * dvn:
                    scale = 0.0
                    slip[p] = 0.0
                else:
                    if speed > 0.0:
                        scale = max(1.0 - mu * dvn / speed, 0.0)
                    slip[p] += scale * speed * dt
            x[p, 0] += (scale - 1.0) * tx * dt
            x[p, 1] += (scale - 1.0) * ty * dt
            x[p, 2] += (scale - 1.0) * tz * dt
            v[p, 0] = scale * tx + vn_new * nx
            v[p, 1] = scale * ty + vn_new * ny
            v[p, 2] = scale * tz + vn_new * nz


@njit(cache=True, inline="always")
def _weakening(s, dc):
    """The static share of the friction coefficient after a slip ``s`` (see the numpy spec)."""
    if dc > 0.0:
        return max(1.0 - s / dc, 0.0)
    return 0.0 if s > 0.0 else 1.0


_FREE = 0
_RELEASED = 1
_STUCK = 2


@njit(**_opts)
def contact_normals(x, v, obstacle_kind, obstacle_data, margin, contact_state, dt, rest_speed,
                    springs, cnrm, cobs, offset):
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
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
            # a stuck point stays a candidate whatever the sign of vn (round-off would free
            # it); the active set releases it in the step if its constraint pulls
            if (vn <= 0.0 or contact_state[q] == _STUCK) and gap + dt * min(vn, 0.0) <= margin:
                cnrm[q, 0] = nx
                cnrm[q, 1] = ny
                cnrm[q, 2] = nz
                impact = -vn if -vn > rest_speed else 0.0
                free = (first_ptr[q + 1] - first_ptr[q] + second_ptr[q + 1]
                        - second_ptr[q]) == 0
                if impact > 0.0 and free:
                    cnrm[q, 3] = obstacle_data[o, OBSTACLE_E] * impact
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


@njit(cache=True, nogil=True)
def update_active_set(v, dv, b, ap, mass, cnrm, cobs, obstacle_data, contact_state, friction):
    """Same contract as :func:`jellysim.kernels.contact_numpy.update_active_set`."""
    changed = 0
    for q in range(cnrm.shape[0]):
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
        tx = jx - jn * nx
        ty = jy - jn * ny
        tz = jz - jn * nz
        jt = np.sqrt(tx * tx + ty * ty + tz * tz)
        ux = v[q, 0] + dv[q, 0]
        uy = v[q, 1] + dv[q, 1]
        uz = v[q, 2] + dv[q, 2]
        un = ux * nx + uy * ny + uz * nz
        ux -= un * nx
        uy -= un * ny
        uz -= un * nz
        speed = np.sqrt(ux * ux + uy * uy + uz * uz)
        ox = friction[q, 0]
        oy = friction[q, 1]
        oz = friction[q, 2]
        bound = obstacle_data[o, OBSTACLE_MU_K] * max(jn, 0.0)
        state = contact_state[q]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        if jn < 0.0:
            state = _RELEASED
        elif cnrm[q, 5] > 0.0:
            if jt > obstacle_data[o, OBSTACLE_MU_S] * jn:
                state = _FREE
                fx = bound * tx / jt
                fy = bound * ty / jt
                fz = bound * tz / jt
        elif ox * ux + oy * uy + oz * uz > 0.0:
            state = _STUCK
        elif speed > 0.0:
            fx = -bound * ux / speed
            fy = -bound * uy / speed
            fz = -bound * uz / speed
        moved = np.sqrt((fx - ox) ** 2 + (fy - oy) ** 2 + (fz - oz) ** 2)
        if state != contact_state[q] or moved > FRICTION_REL_TOL * bound + 1e-300:
            changed += 1
        contact_state[q] = state
        friction[q, 0] = fx
        friction[q, 1] = fy
        friction[q, 2] = fz
    return changed


@njit(**_opts)
def constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data, dt, contact_state,
                        friction):
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
        used = np.sqrt(friction[q, 0] ** 2 + friction[q, 1] ** 2 + friction[q, 2] ** 2) / mass[q]
        vn = v[q, 0] * nx + v[q, 1] * ny + v[q, 2] * nz
        tx = v[q, 0] - vn * nx
        ty = v[q, 1] - vn * ny
        tz = v[q, 2] - vn * nz
        speed = np.sqrt(tx * tx + ty * ty + tz * tz)
        stick = speed <= max(obstacle_data[o, OBSTACLE_MU_S] * budget - used, 0.0)
        if stick or was_stuck:
            scale = 0.0
        elif speed > 0.0:
            scale = max(1.0 - max(obstacle_data[o, OBSTACLE_MU_K] * budget - used, 0.0) / speed, 0.0)
        else:
            scale = 1.0
        x[q, 0] += (scale - 1.0) * tx * dt
        x[q, 1] += (scale - 1.0) * ty * dt
        x[q, 2] += (scale - 1.0) * tz * dt
        v[q, 0] = scale * tx + vn * nx
        v[q, 1] = scale * ty + vn * ny
        v[q, 2] = scale * tz + vn * nz
        if was_stuck:
            holds = jt_norm <= obstacle_data[o, OBSTACLE_MU_S] * max(jn, 0.0)
        else:
            holds = stick
        if jn < 0.0:
            contact_state[q] = _RELEASED
        elif holds:
            contact_state[q] = _STUCK
