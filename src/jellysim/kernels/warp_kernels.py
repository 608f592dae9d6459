"""Warp kernels of :mod:`.warp_backend` (one Warp module: float32 and float64 overloads of
every kernel, compiled once).

They take plain arrays and scalars (no Model, no numba-style argument list), so the host side
can be re-wired freely.  Arithmetic mirrors :mod:`.numba_backend` operation for operation; no
float atomics (spring scalars go to their second-list slots and are gathered in CSR order);
``ctl`` is the device status word: [0] status, [1] steps done, [2] Provot converged this step.
"""
from __future__ import annotations

from typing import Any

import warp as wp

if wp.config.log_level == wp.LOG_INFO:  # no banner / "module loaded" lines unless asked for
    wp.config.log_level = wp.LOG_WARNING
wp.set_module_options({"enable_backward": False})

_I32 = wp.array(dtype=wp.int32)
_AT = wp.array(dtype=Any)
_A2 = wp.array2d(dtype=Any)

# ctl (int32, 4): [0] status, [1] steps done, [2] Provot converged this step, [3] unused
# counts (int32, 2): non-finite points, runaway points of the current step


# -- helpers -------------------------------------------------------------------------------------
@wp.func
def _provot_c(length: Any, rest: Any, tau: Any):
    zero = type(length)(0.0)
    one = type(length)(1.0)
    half = type(length)(0.5)
    r = zero
    if length > zero:
        hi = (one + tau) * rest
        lo = (one - tau) * rest
        if length > hi:
            r = half * (length - hi) / length
        elif length < lo:
            r = half * (length - lo) / length
    return r


@wp.func
def _provot_c_inv(length: Any, inv_length: Any, rest: Any, tau: Any):
    one = type(length)(1.0)
    half = type(length)(0.5)
    target = wp.min(wp.max(length, (one - tau) * rest), (one + tau) * rest)
    return half * (length - target) * inv_length


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


# -- integrator ----------------------------------------------------------------------------------
@wp.kernel
def k_drift(x: _A2, v: _A2, a: _A2, dt: Any, paper: int, save: int, x_pre: _A2, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0:
        return
    for c in range(3):
        if paper != 0:
            x[p, c] = x[p, c] + v[p, c] * dt
            v[p, c] = v[p, c] + a[p, c] * dt
        else:
            v[p, c] = v[p, c] + a[p, c] * dt
            x[p, c] = x[p, c] + v[p, c] * dt
        if save != 0:
            x_pre[p, c] = x[p, c]


# -- spring forces: each spring once (first point's thread), then a gather -----------------------
@wp.kernel
def k_force_first(x: _A2, spring_j: _I32, rest: _AT, stiff: _AT, first_ptr: _I32,
                  second_slot: _I32, scal: _AT, f: _A2, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0:
        return
    px = x[p, 0]
    py = x[p, 1]
    pz = x[p, 2]
    zero = type(px)(0.0)
    fx = zero
    fy = zero
    fz = zero
    for s in range(first_ptr[p], first_ptr[p + 1]):
        q = spring_j[s]
        dx = x[q, 0] - px
        dy = x[q, 1] - py
        dz = x[q, 2] - pz
        length = wp.sqrt(dx * dx + dy * dy + dz * dz)
        c = zero
        if length > zero:
            c = stiff[s] * (length - rest[s]) / length
        scal[second_slot[s]] = c
        fx = fx + c * dx
        fy = fy + c * dy
        fz = fz + c * dz
    f[p, 0] = fx
    f[p, 1] = fy
    f[p, 2] = fz


@wp.kernel
def k_force_second(x: _A2, v: _A2, inv_mass: _AT, damping: Any, gx: Any, gy: Any, gz: Any,
                   second_ptr: _I32, second_other: _I32, scal: _AT, a: _A2, ctl: _I32):
    q = wp.tid()
    if ctl[0] != 0:
        return
    fx = a[q, 0]
    fy = a[q, 1]
    fz = a[q, 2]
    qx = x[q, 0]
    qy = x[q, 1]
    qz = x[q, 2]
    for t in range(second_ptr[q], second_ptr[q + 1]):
        c = scal[t]
        i = second_other[t]
        fx = fx + c * (x[i, 0] - qx)
        fy = fy + c * (x[i, 1] - qy)
        fz = fz + c * (x[i, 2] - qz)
    w = inv_mass[q]
    a[q, 0] = (fx - damping * v[q, 0]) * w + gx
    a[q, 1] = (fy - damping * v[q, 1]) * w + gy
    a[q, 2] = (fz - damping * v[q, 2]) * w + gz


@wp.kernel
def k_fused_first(x: _A2, spring_j: _I32, rest: _AT, stiff: _AT, first_ptr: _I32,
                  second_slot: _I32, tau: Any, scal: _AT, pscal: _AT, f: _A2, dx: _A2,
                  cnt: _I32, ctl: _I32):
    """Forces and the first Jacobi Provot pass, one length per spring (the report's order)."""
    p = wp.tid()
    if ctl[0] != 0:
        return
    px = x[p, 0]
    py = x[p, 1]
    pz = x[p, 2]
    zero = type(px)(0.0)
    one = type(px)(1.0)
    fx = zero
    fy = zero
    fz = zero
    sx = zero
    sy = zero
    sz = zero
    n = int(0)
    for s in range(first_ptr[p], first_ptr[p + 1]):
        q = spring_j[s]
        ex = x[q, 0] - px
        ey = x[q, 1] - py
        ez = x[q, 2] - pz
        length = wp.sqrt(ex * ex + ey * ey + ez * ez)
        inv = zero
        if length > zero:
            inv = one / length
        r0 = rest[s]
        c = stiff[s] * (length - r0) * inv
        slot = second_slot[s]
        scal[slot] = c
        fx = fx + c * ex
        fy = fy + c * ey
        fz = fz + c * ez
        cp = _provot_c_inv(length, inv, r0, tau)
        pscal[slot] = cp
        sx = sx + cp * ex
        sy = sy + cp * ey
        sz = sz + cp * ez
        if cp != zero:
            n = n + 1
    f[p, 0] = fx
    f[p, 1] = fy
    f[p, 2] = fz
    dx[p, 0] = sx
    dx[p, 1] = sy
    dx[p, 2] = sz
    cnt[p] = n


@wp.kernel
def k_fused_second(x: _A2, v: _A2, inv_mass: _AT, damping: Any, gx: Any, gy: Any, gz: Any,
                   second_ptr: _I32, second_other: _I32, scal: _AT, pscal: _AT, a: _A2,
                   dx: _A2, cnt: _I32, max_corr: _AT, reduce: int, largest: _AT, ctl: _I32):
    q = wp.tid()
    if ctl[0] != 0:
        return
    fx = a[q, 0]
    fy = a[q, 1]
    fz = a[q, 2]
    sx = dx[q, 0]
    sy = dx[q, 1]
    sz = dx[q, 2]
    n = cnt[q]
    qx = x[q, 0]
    qy = x[q, 1]
    qz = x[q, 2]
    zero = type(qx)(0.0)
    for t in range(second_ptr[q], second_ptr[q + 1]):
        i = second_other[t]
        ex = x[i, 0] - qx
        ey = x[i, 1] - qy
        ez = x[i, 2] - qz
        c = scal[t]
        fx = fx + c * ex
        fy = fy + c * ey
        fz = fz + c * ez
        cp = pscal[t]
        sx = sx + cp * ex
        sy = sy + cp * ey
        sz = sz + cp * ez
        if cp != zero:
            n = n + 1
    w = inv_mass[q]
    a[q, 0] = (fx - damping * v[q, 0]) * w + gx
    a[q, 1] = (fy - damping * v[q, 1]) * w + gy
    a[q, 2] = (fz - damping * v[q, 2]) * w + gz
    if n > 0:
        sx = sx / type(qx)(n)
        sy = sy / type(qx)(n)
        sz = sz / type(qx)(n)
    dx[q, 0] = sx
    dx[q, 1] = sy
    dx[q, 2] = sz
    m = wp.sqrt(sx * sx + sy * sy + sz * sz)
    max_corr[q] = m
    if reduce != 0:
        wp.atomic_max(largest, 0, m)


# -- Provot strain limiting ----------------------------------------------------------------------
@wp.kernel
def k_provot_first(x: _A2, spring_j: _I32, rest: _AT, first_ptr: _I32, second_slot: _I32,
                   tau: Any, pscal: _AT, dx: _A2, cnt: _I32, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0 or ctl[2] != 0:
        return
    px = x[p, 0]
    py = x[p, 1]
    pz = x[p, 2]
    zero = type(px)(0.0)
    one = type(px)(1.0)
    sx = zero
    sy = zero
    sz = zero
    n = int(0)
    for s in range(first_ptr[p], first_ptr[p + 1]):
        q = spring_j[s]
        ex = x[q, 0] - px
        ey = x[q, 1] - py
        ez = x[q, 2] - pz
        length = wp.sqrt(ex * ex + ey * ey + ez * ez)
        inv = zero
        if length > zero:
            inv = one / length
        c = _provot_c_inv(length, inv, rest[s], tau)
        pscal[second_slot[s]] = c
        sx = sx + c * ex
        sy = sy + c * ey
        sz = sz + c * ez
        if c != zero:
            n = n + 1
    dx[p, 0] = sx
    dx[p, 1] = sy
    dx[p, 2] = sz
    cnt[p] = n


@wp.kernel
def k_provot_second(x: _A2, second_ptr: _I32, second_other: _I32, pscal: _AT, dx: _A2,
                    cnt: _I32, max_corr: _AT, reduce: int, largest: _AT, ctl: _I32):
    q = wp.tid()
    if ctl[0] != 0 or ctl[2] != 0:
        return
    sx = dx[q, 0]
    sy = dx[q, 1]
    sz = dx[q, 2]
    n = cnt[q]
    qx = x[q, 0]
    qy = x[q, 1]
    qz = x[q, 2]
    zero = type(qx)(0.0)
    for t in range(second_ptr[q], second_ptr[q + 1]):
        c = pscal[t]
        i = second_other[t]
        sx = sx - c * (qx - x[i, 0])
        sy = sy - c * (qy - x[i, 1])
        sz = sz - c * (qz - x[i, 2])
        if c != zero:
            n = n + 1
    if n > 0:
        sx = sx / type(qx)(n)
        sy = sy / type(qx)(n)
        sz = sz / type(qx)(n)
    dx[q, 0] = sx
    dx[q, 1] = sy
    dx[q, 2] = sz
    m = wp.sqrt(sx * sx + sy * sy + sz * sz)
    max_corr[q] = m
    if reduce != 0:
        wp.atomic_max(largest, 0, m)


@wp.kernel
def k_provot_all(x: _A2, x0: _A2, tau: Any, dx: _A2, max_corr: _AT, reduce: int,
                 largest: _AT, ctl: _I32):
    """Jacobi (averaged) over all pairs, rest lengths from the rest positions (O(n^2))."""
    p = wp.tid()
    if ctl[0] != 0 or ctl[2] != 0:
        return
    n = x.shape[0]
    zero = type(tau)(0.0)
    sx = zero
    sy = zero
    sz = zero
    k = int(0)
    for q in range(n):
        if q != p:
            ex = x[q, 0] - x[p, 0]
            ey = x[q, 1] - x[p, 1]
            ez = x[q, 2] - x[p, 2]
            rx = x0[q, 0] - x0[p, 0]
            ry = x0[q, 1] - x0[p, 1]
            rz = x0[q, 2] - x0[p, 2]
            c = _provot_c(wp.sqrt(ex * ex + ey * ey + ez * ez),
                          wp.sqrt(rx * rx + ry * ry + rz * rz), tau)
            if c != zero:
                sx = sx + c * ex
                sy = sy + c * ey
                sz = sz + c * ez
                k = k + 1
    if k > 0:
        sx = sx / type(tau)(k)
        sy = sy / type(tau)(k)
        sz = sz / type(tau)(k)
    dx[p, 0] = sx
    dx[p, 1] = sy
    dx[p, 2] = sz
    m = wp.sqrt(sx * sx + sy * sy + sz * sz)
    max_corr[p] = m
    if reduce != 0:
        wp.atomic_max(largest, 0, m)


@wp.kernel
def k_apply_dx(x: _A2, dx: _A2, provot_gate: int, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0:
        return
    if provot_gate != 0 and ctl[2] != 0:
        return
    for c in range(3):
        x[p, c] = x[p, c] + dx[p, c]


@wp.kernel
def k_provot_check(largest: _AT, tolerance: Any, ctl: _I32):
    """One thread: after a pass whose largest correction is <= tolerance, the rest of this
    step's passes are skipped (numba's ``break``)."""
    if ctl[0] != 0 or ctl[2] != 0:
        return
    if largest[0] <= tolerance:
        ctl[2] = 1
    largest[0] = type(tolerance)(0.0)


@wp.func
def _gs_pair(x: wp.array2d(dtype=Any), a: int, b: int, rest: Any, tau: Any):
    ex = x[b, 0] - x[a, 0]
    ey = x[b, 1] - x[a, 1]
    ez = x[b, 2] - x[a, 2]
    length = wp.sqrt(ex * ex + ey * ey + ez * ez)
    c = _provot_c(length, rest, tau)
    if c != type(tau)(0.0):
        x[a, 0] = x[a, 0] + c * ex
        x[a, 1] = x[a, 1] + c * ey
        x[a, 2] = x[a, 2] + c * ez
        x[b, 0] = x[b, 0] - c * ex
        x[b, 1] = x[b, 1] - c * ey
        x[b, 2] = x[b, 2] - c * ez
    return wp.abs(c) * length


@wp.kernel
def k_provot_gs(x: _A2, x0: _A2, spring_i: _I32, spring_j: _I32, rest: _AT, tau: Any,
                loops: int, tolerance: Any, all_pairs: int, ctl: _I32):
    """Gauss-Seidel: sequential by nature; one thread (as slow as it sounds on a GPU)."""
    if ctl[0] != 0:
        return
    n = x.shape[0]
    for _ in range(loops):
        largest = type(tau)(0.0)
        if all_pairs != 0:
            for a in range(n):
                for b in range(a + 1, n):
                    rx = x0[b, 0] - x0[a, 0]
                    ry = x0[b, 1] - x0[a, 1]
                    rz = x0[b, 2] - x0[a, 2]
                    largest = wp.max(largest, _gs_pair(x, a, b,
                                                       wp.sqrt(rx * rx + ry * ry + rz * rz),
                                                       tau))
        else:
            for s in range(spring_i.shape[0]):
                largest = wp.max(largest, _gs_pair(x, spring_i[s], spring_j[s], rest[s], tau))
        if largest <= tolerance:
            break


# -- contact, ground, checks ---------------------------------------------------------------------
@wp.kernel
def k_add_velocity(v: _A2, x: _A2, x_pre: _A2, dt: Any, ctl: _I32):
    p = wp.tid()
    if ctl[0] != 0:
        return
    inv = type(dt)(1.0) / dt
    for c in range(3):
        v[p, c] = v[p, c] + (x[p, c] - x_pre[p, c]) * inv


@wp.kernel
def k_contact(x: _A2, v: _A2, kind: _I32, g: _A2, rest_speed: Any, dt: Any, ctl: _I32):
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
        if vn < zero:
            vn_new = zero
            if -vn > rest_speed:
                vn_new = -g[o, 6] * vn
            dvn = vn_new - vn
            speed = wp.sqrt(tx * tx + ty * ty + tz * tz)
            if speed <= g[o, 7] * dvn:
                scale = zero
            elif speed > zero:
                scale = wp.max(one - g[o, 8] * dvn / speed, zero)
        x[p, 0] = x[p, 0] + (scale - one) * tx * dt
        x[p, 1] = x[p, 1] + (scale - one) * ty * dt
        x[p, 2] = x[p, 2] + (scale - one) * tz * dt
        v[p, 0] = scale * tx + vn_new * nx
        v[p, 1] = scale * ty + vn_new * ny
        v[p, 2] = scale * tz + vn_new * nz


@wp.kernel
def k_finish(x: _A2, v: _A2, a: _A2, dx: _A2, apply_dx: int, x_pre: _A2, add_velocity: int,
             dt: Any, ground: int, height: Any, mu: Any, nu: Any, cx: Any, cy: Any, cz: Any,
             bound2: Any, counts: _I32, ctl: _I32):
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
    if ground != 0 and x[p, 1] < height:
        x[p, 1] = height
        v[p, 1] = zero
        v[p, 0] = v[p, 0] * mu
        v[p, 2] = v[p, 2] * mu
        a[p, 1] = a[p, 1] - nu * a[p, 1]
    s = zero
    for c in range(3):
        s = s + (x[p, c] + v[p, c] + a[p, c])
    rx = x[p, 0] - cx
    ry = x[p, 1] - cy
    rz = x[p, 2] - cz
    if not wp.isfinite(s):
        wp.atomic_add(counts, 0, 1)
    if rx * rx + ry * ry + rz * rz > bound2:
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


@wp.kernel
def k_triad(a: _AT, b: _AT, c: _AT, s: Any):
    """STREAM triad ``a = b + s c`` (the benchmark's bandwidth probe)."""
    i = wp.tid()
    a[i] = b[i] + s * c[i]


_KERNELS = [k_drift, k_force_first, k_force_second, k_fused_first, k_fused_second,
            k_provot_first, k_provot_second, k_provot_all, k_apply_dx, k_provot_check,
            k_provot_gs, k_add_velocity, k_contact, k_finish, k_step_end, k_triad]


def _overloads():
    """Register the float32 and float64 overloads of every generic kernel up front, so the
    module compiles once for both."""
    for kern in _KERNELS:
        for T in (wp.float32, wp.float64):
            sig = {}
            for name, t in kern.adj.arg_types.items():
                if t is Any:
                    sig[name] = T
                elif wp.types.is_array(t) and t.dtype is Any:
                    sig[name] = wp.array(dtype=T, ndim=t.ndim)
            if sig:
                wp.overload(kern, sig)


_overloads()
