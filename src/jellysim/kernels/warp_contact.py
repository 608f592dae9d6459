"""Warp kernels of contact, the report's ground and the checks (:mod:`.warp_backend`, and
:mod:`.warp_physical`): obstacles with restitution and Coulomb friction (the numba backend's
``contact``), the finishing sweep (ground, non-finite / runaway counts) and the one-thread
``k_step_end`` that turns the counts into the device status word ``ctl``.
"""
from __future__ import annotations

from typing import Any

import warp as wp

from .warp_common import A2 as _A2, AT as _AT, I32 as _I32
from .warp_common import FLOAT, precision_structs, register_overloads
from .contact_numpy import RESTING_GAP, RESTING_SHARE

_RESTING_SHARE = wp.constant(RESTING_SHARE)
_RESTING_GAP = wp.constant(RESTING_GAP)

wp.set_module_options({"enable_backward": False})

# ctl (int32, 4): [0] status, [1] steps done, [2] Provot converged this step, [3] the call's
# step count (physical path); counts (int32, 2): non-finite points, runaway points of the step

Guard = precision_structs("Guard", {"ground": wp.int32, "height": FLOAT, "mu": FLOAT,
                                    "nu": FLOAT, "cx": FLOAT, "cy": FLOAT, "cz": FLOAT,
                                    "bound2": FLOAT}, __name__)
"""The report's ground (``ground`` 0/1, plane ``y = height``, ``mu``, ``nu``) and the runaway
guard (centre ``cx, cy, cz`` [m], squared bound ``bound2`` [m^2])."""


@wp.func
def _coord(px: Any, py: Any, pz: Any, c: int):
    r = px
    if c == 1:
        r = py
    elif c == 2:
        r = pz
    return r


@wp.func
def _contact_point(kind: wp.int32, g: wp.array2d(dtype=Any), o: int, px: Any, py: Any,
                   pz: Any):
    """(phi, nx, ny, nz) of one point against obstacle o (see the numpy spec)."""
    zero = type(px)(0.0)
    one = type(px)(1.0)
    phi = one
    nx = zero
    ny = zero
    nz = zero
    if kind == 0:
        phi = (px - g[o, 0]) * g[o, 3] + (py - g[o, 1]) * g[o, 4] + (pz - g[o, 2]) * g[o, 5]
        nx = g[o, 3]
        ny = g[o, 4]
        nz = g[o, 5]
    elif kind == 1:
        dx = px - g[o, 0]
        dy = py - g[o, 1]
        dz = pz - g[o, 2]
        r = wp.sqrt(dx * dx + dy * dy + dz * dz)
        phi = r - g[o, 3]
        if r > zero:
            nx = dx / r
            ny = dy / r
            nz = dz / r
        else:
            ny = one
    else:
        best = px - g[o, 0]
        face = int(0)
        inside = int(1)
        for f in range(6):
            c = f % 3
            pc = _coord(px, py, pz, c)
            d = zero
            if f < 3:
                d = pc - g[o, c]
            else:
                d = g[o, 3 + c] - pc
            if not (d > zero):
                inside = 0
            if d < best:
                best = d
                face = f
        if inside != 0:
            s = one
            if face < 3:
                s = -one
            if face % 3 == 0:
                nx = s
            elif face % 3 == 1:
                ny = s
            else:
                nz = s
            phi = -best
    return phi, nx, ny, nz



@wp.kernel
def k_add_velocity(v: _A2, x: _A2, x_pre: _A2, dt: Any, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0:
        return
    inv = type(dt)(1.0) / dt
    for c in range(3):
        v[p, c] = v[p, c] + (x[p, c] - x_pre[p, c]) * inv


@wp.kernel
def k_contact(x: _A2, v: _A2, kind: _I32, g: _A2, rest_speed: Any, dt: Any, slip: _AT,
              ctl: _I32):
    """:func:`jellysim.kernels.contact_numpy.contact` (its slip-weakening included)."""
    p = wp.tid()
    if ctl[0] != 0:
        return
    zero = type(dt)(0.0)
    one = type(dt)(1.0)
    for o in range(kind.shape[0]):
        phi, nx, ny, nz = _contact_point(kind[o], g, o, x[p, 0], x[p, 1], x[p, 2])
        if not (phi < zero):
            continue
        x[p, 0] = x[p, 0] - phi * nx
        x[p, 1] = x[p, 1] - phi * ny
        x[p, 2] = x[p, 2] - phi * nz
        vn = v[p, 0] * nx + v[p, 1] * ny + v[p, 2] * nz
        tx = v[p, 0] - vn * nx
        ty = v[p, 1] - vn * ny
        tz = v[p, 2] - vn * nz
        vn_new = vn
        scale = one
        step = wp.sqrt(v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2]) * dt
        if vn < zero:
            vn_new = zero  # (resting: slow, or touching at the step's start: contact_numpy)
            far = type(dt)(_RESTING_SHARE) * step + type(dt)(_RESTING_GAP)
            if -vn > rest_speed and phi - vn * dt > far:
                vn_new = -g[o, 6] * vn
        if g[o, 7] > 1.0e30:  # no slip (contact_numpy.NO_SLIP): held along the surface
            scale = zero
            slip[p] = zero
        elif vn < zero:
            dvn = vn_new - vn
            speed = wp.sqrt(tx * tx + ty * ty + tz * tz)
            w = zero  # the static share 1 - min(s / D_c, 1) (D_c = 0: 1 at s = 0)
            if g[o, 9] > zero:
                w = wp.max(one - slip[p] / g[o, 9], zero)
            elif not (slip[p] > zero):
                w = one
            mu = g[o, 8] + w * (g[o, 7] - g[o, 8])
            if speed <= mu * dvn:
                scale = zero
                slip[p] = zero
            else:
                if speed > zero:
                    scale = wp.max(one - mu * dvn / speed, zero)
                slip[p] = slip[p] + scale * speed * dt
        x[p, 0] = x[p, 0] + (scale - one) * tx * dt
        x[p, 1] = x[p, 1] + (scale - one) * ty * dt
        x[p, 2] = x[p, 2] + (scale - one) * tz * dt
        v[p, 0] = scale * tx + vn_new * nx
        v[p, 1] = scale * ty + vn_new * ny
        v[p, 2] = scale * tz + vn_new * nz


@wp.kernel
def k_finish(x: _A2, v: _A2, a: _A2, dx: _A2, apply_dx: int, x_pre: _A2, add_velocity: int,
             dt: Any, gd: Any, counts: _I32, ctl: _I32):
    """(x += dx), (v += (x - x_pre) / dt), the report's ground, then the checks."""
    p = wp.tid()
    if ctl[0] != 0:
        return
    inv = type(dt)(1.0) / dt
    zero = type(dt)(0.0)
    for c in range(3):
        if apply_dx != 0:
            x[p, c] = x[p, c] + dx[p, c]
        if add_velocity != 0:
            v[p, c] = v[p, c] + (x[p, c] - x_pre[p, c]) * inv
    if gd.ground != 0 and x[p, 1] < gd.height:
        x[p, 1] = gd.height
        v[p, 1] = zero
        v[p, 0] = v[p, 0] * gd.mu
        v[p, 2] = v[p, 2] * gd.mu
        a[p, 1] = a[p, 1] - gd.nu * a[p, 1]
    s = zero
    for c in range(3):
        s = s + (x[p, c] + v[p, c] + a[p, c])
    rx = x[p, 0] - gd.cx
    ry = x[p, 1] - gd.cy
    rz = x[p, 2] - gd.cz
    if not wp.isfinite(s):
        wp.atomic_add(counts, 0, 1)
    if rx * rx + ry * ry + rz * rz > gd.bound2:
        wp.atomic_add(counts, 1, 1)


@wp.kernel
def k_step_end(counts: _I32, ctl: _I32):
    """One thread: count the step, turn this step's flags into the status (non-finite first)."""
    if ctl[0] != 0:
        return
    ctl[1] = ctl[1] + 1
    if counts[0] > 0:
        ctl[0] = 1
    elif counts[1] > 0:
        ctl[0] = 2
    counts[0] = 0
    counts[1] = 0
    ctl[2] = 0



register_overloads([k_add_velocity, k_contact, k_finish, k_step_end], {"gd": Guard})
