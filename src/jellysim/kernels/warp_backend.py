"""Warp kernels: the explicit step on an NVIDIA GPU (CUDA) or on Warp's CPU device.

Same physics, same arithmetic order and the same ``run_steps`` signature as
:mod:`.numba_backend` (so ``get_backend("warp")`` drops into the Simulator); Warp is imported
only when this module is (``pip install 'jellysim[gpu]'``).  What it runs:

* the integrators ``paper`` (the report's order: ``x += v dt; v += a dt; a = F(x, v) / m``, eq. 1
  spring forces, ``-delta v`` damping, gravity) and ``symplectic``;
* Provot strain limiting: Jacobi (averaged) over the springs or over all pairs, Gauss-Seidel
  (one serial thread, as the numba backend's), with the pass-count tolerance;
* the report's ground (``mu``/``nu``) and the physical contact of planes, spheres and boxes
  (restitution, static/kinetic Coulomb friction: the numba backend's ``contact``);
* the non-finite / runaway check, which stops the batch at the failing step.

**Determinism.**  No float atomics: each spring's scalar is computed once, by the thread of its
first point, and written into its slot of the second point's list (``spring_second_slot``: one
writer per slot); a second pass gathers each point's slots in CSR order.  The only atomics are
integer counters and ``atomic_max`` of non-negative norms (exact, order-free), so a run is
bitwise repeatable on every device, and in float64 on the CPU device bitwise equal to the numba
backend (the tests allow 1e-12 m).

**No host round trip per step.**  Per call the state is uploaded once; one step is a fixed list
of launches recorded once (captured as a CUDA graph on a GPU, replayed ``n`` times; on the CPU
device the recorded launches are replayed); a device status word makes every kernel of the
steps after a failure return at once, so the state is left as after the failing step, as with
numba.  The state (and ``max_corr``) is copied back when the call returns.  Device copies of a
Model's arrays are cached per Model (uploaded once).

All kernels live in this one Warp module with float32 and float64 overloads: one compilation
(about 20 s cold on one CPU core, then Warp's kernel cache, ``WARP_CACHE_PATH``).
"""
from __future__ import annotations

import weakref
from typing import Any

import numpy as np
import warp as wp

from . import STATUS_OK

__all__ = ["WarpBackend", "run_steps", "PRECISIONS", "resolve_device", "device_info"]

PRECISIONS = ("float64", "float32")

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


# -- host side -----------------------------------------------------------------------------------
def resolve_device(device: str | None = None) -> str:
    """``"cuda"`` (the default GPU) when one is present, else ``"cpu"``; a named device
    (``"cpu"``, ``"cuda"``, ``"cuda:1"``) is checked to exist."""
    from ..errors import SceneError

    wp.init()
    if device in (None, "", "auto"):
        return "cuda:0" if wp.is_cuda_available() else "cpu"
    try:
        return str(wp.get_device(device))
    except (RuntimeError, ValueError) as exc:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise SceneError(f"warp device '{device}' is not available ({exc}); devices here: "
                         f"{names}") from None


def device_info(device: str) -> dict:
    """Name, memory and (CUDA) peak memory bandwidth [bytes/s] of a Warp device."""
    d = wp.get_device(device)
    info = {"device": str(d), "name": d.name, "is_cuda": bool(d.is_cuda)}
    if d.is_cuda:
        info["memory_bytes"] = int(d.total_memory)
        info["sm_count"] = int(getattr(d, "sm_count", 0))
        info["arch"] = int(getattr(d, "arch", 0))
        peak = _cuda_peak_bandwidth(d.ordinal)
        if peak:
            info["peak_bandwidth_Bps"] = peak
    return info


def _cuda_peak_bandwidth(ordinal: int) -> float | None:
    """2 x memory clock x bus width [bytes/s]: the CUDA driver's device attributes (memory
    clock rate 36, bus width 37); the clock from ``nvidia-smi`` where the driver no longer
    reports it."""
    import ctypes
    import subprocess

    try:
        cu = ctypes.CDLL("libcuda.so.1")
        dev = ctypes.c_int()
        if cu.cuInit(0) or cu.cuDeviceGet(ctypes.byref(dev), ordinal):
            return None
        clock = ctypes.c_int()  # kHz
        width = ctypes.c_int()  # bits
        if cu.cuDeviceGetAttribute(ctypes.byref(width), 37, dev) or width.value <= 0:
            return None
        khz = clock.value if not cu.cuDeviceGetAttribute(ctypes.byref(clock), 36, dev) else 0
        if khz <= 0:
            out = subprocess.run(["nvidia-smi", f"--id={ordinal}",
                                  "--query-gpu=clocks.max.memory",
                                  "--format=csv,noheader,nounits"], capture_output=True,
                                 text=True, timeout=20)
            khz = 1000.0 * float(out.stdout.strip().splitlines()[0])
        return 2.0 * khz * 1e3 * width.value / 8.0
    except (OSError, ValueError, IndexError, subprocess.SubprocessError):
        return None


def bytes_per_spring_update(springs: int, points: int, precision: str = "float32") -> dict:
    """The least memory traffic of one paper step with one Provot pass over the springs (the
    fused force + Provot sweep), per spring: streamed spring arrays plus the per-point arrays
    shared out over the springs (every array read or written once per kernel; neighbour
    positions assumed cached)."""
    t = 4 if precision == "float32" else 8
    # pass 1: spring_j 4, rest t, stiff t, second_slot 4, writes scal t, pscal t
    # pass 2: second_other 4, reads scal t, pscal t
    per_spring = 12 + 6 * t
    # drift: r x v a, w x v x_pre (18t); fused 1: r x, ptr, w f dx cnt (9t + 12);
    # fused 2: r x a dx v inv_mass ptr cnt, w a dx max_corr (22t + 12);
    # finish: r x dx v x_pre a, w x v a (24t)
    per_point = 73 * t + 24
    return {"per_spring": per_spring, "per_point": per_point,
            "per_spring_update": per_spring + per_point * points / max(springs, 1)}


_MODEL_ARRAYS = ("x0", "inv_mass", "spring_ij", "rest", "stiff", "first_ptr", "second_ptr",
                 "second_slot", "second_other")


class _DeviceModel:
    """A Model's arrays and the scratch on one device, in one precision; recorded steps."""

    def __init__(self, wb: WarpBackend, x0, inv_mass, spring_ij, rest, stiff, first_ptr,
                 second_ptr, second_slot, second_other):
        dev, T, F = wb.device, wb.wp_dtype, wb.np_dtype
        n = x0.shape[0]
        k = spring_ij.shape[0]
        if k >= 2**31 - 1:
            raise ValueError(f"the warp backend indexes springs with int32; {k} springs is "
                             "too many")

        def up(a, dtype):
            return wp.array(np.ascontiguousarray(a, dtype=dtype), device=dev)

        self.n, self.k = n, k
        self.x0 = up(x0, F)
        self.inv_mass = up(inv_mass, F)
        ij = np.asarray(spring_ij).reshape(k, 2)
        self.spring_i = up(ij[:, 0], np.int32)
        self.spring_j = up(ij[:, 1], np.int32)
        self.rest = up(rest, F)
        self.stiff = up(stiff, F)
        self.first_ptr = up(first_ptr, np.int32)
        self.second_ptr = up(second_ptr, np.int32)
        self.second_slot = up(second_slot, np.int32)
        self.second_other = up(second_other, np.int32)
        z2 = lambda: wp.zeros((n, 3), dtype=T, device=dev)  # noqa: E731
        self.x, self.v, self.a, self.dx, self.x_pre = z2(), z2(), z2(), z2(), z2()
        self.scal = wp.zeros(max(k, 1), dtype=T, device=dev)
        self.pscal = wp.zeros(max(k, 1), dtype=T, device=dev)
        self.cnt = wp.zeros(n, dtype=wp.int32, device=dev)
        self.max_corr = wp.zeros(n, dtype=T, device=dev)
        self.largest = wp.zeros(1, dtype=T, device=dev)
        self.ctl = wp.zeros(4, dtype=wp.int32, device=dev)
        self.counts = wp.zeros(2, dtype=wp.int32, device=dev)
        self.programs: dict = {}
        self.last = None
        # CPU device: numpy views of the device arrays (copies in and out without Warp calls)
        self.views = None
        if not wp.get_device(dev).is_cuda:
            self.views = {name: getattr(self, name).numpy() for name in
                          ("x", "v", "a", "max_corr", "ctl", "counts", "largest")}


class WarpBackend:
    """The Warp kernels on one device in one precision.  ``run_steps`` has the numba backend's
    signature (numpy arrays in and out); device copies are cached per Model.

    device: ``None``/``"auto"`` (a GPU when present, else Warp's CPU device), ``"cpu"``,
        ``"cuda"``, ``"cuda:N"``.
    precision: ``"float64"`` (default; bitwise the numba arithmetic on the CPU device) or
        ``"float32"`` (the state is rounded to float32 on upload and widened on the way back).
    """

    name = "warp"
    _instances: dict = {}

    def __init__(self, device: str | None = None, precision: str = "float64"):
        from ..errors import SceneError

        if precision not in PRECISIONS:
            raise SceneError(f"warp precision must be one of {', '.join(PRECISIONS)}, got "
                             f"'{precision}'")
        self.device = resolve_device(device)
        self.precision = precision
        self.wp_dtype = wp.float64 if precision == "float64" else wp.float32
        self.np_dtype = np.float64 if precision == "float64" else np.float32
        self._models: dict = {}
        wp.load_module(module=__name__, device=self.device)

    @classmethod
    def get(cls, device: str | None = None, precision: str = "float64") -> WarpBackend:
        """A shared instance per (device, precision)."""
        key = (resolve_device(device), precision)
        inst = cls._instances.get(key)
        if inst is None:
            inst = cls._instances[key] = cls(key[0], precision)
        return inst

    @property
    def is_cuda(self) -> bool:
        return wp.get_device(self.device).is_cuda

    # -- model cache ---------------------------------------------------------------------------
    def _model(self, arrays) -> _DeviceModel:
        key = tuple(id(a) for a in arrays)
        dm = self._models.get(key)
        if dm is None:
            dm = _DeviceModel(self, *arrays)
            self._models[key] = dm
            owner = weakref.ref(self)

            def drop(key=key, owner=owner):
                wb = owner()
                if wb is not None:
                    wb._models.pop(key, None)

            for a in arrays:  # an array freed -> its Model is gone: free the device copies
                weakref.finalize(a, drop)
        return dm

    # -- one step as recorded launches ---------------------------------------------------------
    def _program(self, dm: _DeviceModel, key, p):
        prog = dm.programs.get(key)
        if prog is not None:
            return prog
        dev, T = self.device, self.wp_dtype
        n = dm.n
        cmds = []

        def L(kernel, dim, inputs):
            cmds.append(wp.launch(kernel, dim=dim, inputs=inputs, device=dev, record_cmd=True))

        dt = T(p["dt"])
        loops = p["loops"]
        all_pairs, gs = p["all_pairs"], p["gauss_seidel"]
        obstacles = p["obstacle_kind"].shape[0] > 0
        save = int(loops > 0 and p["velocity_update"])
        paper = p["integrator"] == 0
        fuse = paper and loops > 0 and not all_pairs and not gs
        tau, tol = T(p["tau"]), T(p["tolerance"])
        g = p["gravity"]
        force_args = (T(p["damping"]), T(g[0]), T(g[1]), T(g[2]))
        kind = wp.array(p["obstacle_kind"].astype(np.int32), device=dev)
        odata = wp.array(p["obstacle_data"].astype(self.np_dtype).reshape(-1, 9), dtype=T,
                         device=dev)
        ctl = dm.ctl

        def forces():
            L(k_force_first, n, [dm.x, dm.spring_j, dm.rest, dm.stiff, dm.first_ptr,
                                 dm.second_slot, dm.scal, dm.a, ctl])
            L(k_force_second, n, [dm.x, dm.v, dm.inv_mass, *force_args, dm.second_ptr,
                                  dm.second_other, dm.scal, dm.a, ctl])

        def provot_pass(reduce):
            if all_pairs:
                L(k_provot_all, n, [dm.x, dm.x0, tau, dm.dx, dm.max_corr, reduce, dm.largest,
                                    ctl])
            else:
                L(k_provot_first, n, [dm.x, dm.spring_j, dm.rest, dm.first_ptr,
                                      dm.second_slot, tau, dm.pscal, dm.dx, dm.cnt, ctl])
                L(k_provot_second, n, [dm.x, dm.second_ptr, dm.second_other, dm.pscal, dm.dx,
                                       dm.cnt, dm.max_corr, reduce, dm.largest, ctl])
            L(k_apply_dx, n, [dm.x, dm.dx, 1, ctl])
            if reduce:
                L(k_provot_check, 1, [dm.largest, tol, ctl])

        pending = 0
        if paper:
            L(k_drift, n, [dm.x, dm.v, dm.a, dt, 1, save, dm.x_pre, ctl])
            if fuse:
                last = loops == 1 and not obstacles
                reduce = int(loops > 1)
                L(k_fused_first, n, [dm.x, dm.spring_j, dm.rest, dm.stiff, dm.first_ptr,
                                     dm.second_slot, tau, dm.scal, dm.pscal, dm.a, dm.dx,
                                     dm.cnt, ctl])
                L(k_fused_second, n, [dm.x, dm.v, dm.inv_mass, *force_args, dm.second_ptr,
                                      dm.second_other, dm.scal, dm.pscal, dm.a, dm.dx, dm.cnt,
                                      dm.max_corr, reduce, dm.largest, ctl])
                if not last:
                    L(k_apply_dx, n, [dm.x, dm.dx, 0, ctl])
                pending = int(last)
                if reduce:
                    L(k_provot_check, 1, [dm.largest, tol, ctl])
                    for i in range(loops - 1):
                        provot_pass(int(i < loops - 2))
            else:
                forces()
        else:
            forces()
            L(k_drift, n, [dm.x, dm.v, dm.a, dt, 0, save, dm.x_pre, ctl])
        if loops > 0 and not fuse:
            if gs:
                L(k_provot_gs, 1, [dm.x, dm.x0, dm.spring_i, dm.spring_j, dm.rest, tau, loops,
                                   tol, int(all_pairs), ctl])
            else:
                for i in range(loops):
                    provot_pass(int(i < loops - 1))
        finish = [dt, int(p["ground"]), T(p["height"]), T(p["mu"]), T(p["nu"]),
                  *(T(c) for c in p["center"]), T(p["bound2"]), dm.counts, ctl]
        if obstacles:
            if save:
                L(k_add_velocity, n, [dm.v, dm.x, dm.x_pre, dt, ctl])
            L(k_contact, n, [dm.x, dm.v, kind, odata, T(p["rest_speed"]), dt, ctl])
            L(k_finish, n, [dm.x, dm.v, dm.a, dm.dx, 0, dm.x_pre, 0, *finish])
        else:
            L(k_finish, n, [dm.x, dm.v, dm.a, dm.dx, pending, dm.x_pre, save, *finish])
        L(k_step_end, 1, [dm.counts, ctl])

        graph = None
        if self.is_cuda:
            with wp.ScopedCapture(device=dev) as cap:
                for c in cmds:
                    c.launch()
            graph = cap.graph
        prog = {"cmds": cmds, "graph": graph, "keep": (kind, odata)}
        if len(dm.programs) >= 8:
            dm.programs.pop(next(iter(dm.programs)))
        dm.programs[key] = prog
        return prog

    def _replay(self, prog, nsteps: int) -> None:
        if prog["graph"] is not None:
            for _ in range(nsteps):
                wp.capture_launch(prog["graph"])
        else:
            cmds = prog["cmds"]
            for _ in range(nsteps):
                for c in cmds:
                    c.launch()

    def run_steps(self, nsteps, dt, integrator, x, v, a, x0, inv_mass, damping, gravity,
                  spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other,
                  provot_loops, tau, tolerance, all_pairs, gauss_seidel, velocity_update,
                  ground, height, mu, nu, obstacle_kind, obstacle_data, rest_speed, center,
                  bound2, spring_scalar, dx, count, max_corr, x_pre, provot_scalar):
        """:func:`jellysim.kernels.numba_backend.run_steps` on the device: same arguments
        (numpy arrays), same in-place results on x, v, a (and ``max_corr``); the other scratch
        arrays stay on the device.  Returns ``(steps_done, status)``."""
        dm = self._model((x0, inv_mass, spring_ij, rest, stiff, first_ptr, second_ptr,
                          second_slot, second_other))
        ok = np.asarray(obstacle_kind)
        od = np.asarray(obstacle_data, dtype=np.float64)
        p = dict(dt=float(dt), integrator=int(integrator), damping=float(damping),
                 gravity=tuple(float(g) for g in gravity), loops=int(provot_loops),
                 tau=float(tau), tolerance=float(tolerance), all_pairs=bool(all_pairs),
                 gauss_seidel=bool(gauss_seidel), velocity_update=bool(velocity_update),
                 ground=bool(ground), height=float(height), mu=float(mu), nu=float(nu),
                 rest_speed=float(rest_speed), center=tuple(float(c) for c in center),
                 bound2=float(bound2))
        key = (tuple(p.items()), ok.tobytes(), od.tobytes())
        p["obstacle_kind"], p["obstacle_data"] = ok, od
        prog = self._program(dm, key, p)
        F = self.np_dtype
        hv = dm.views
        if hv is not None:  # CPU device: plain numpy copies into the device memory
            hv["x"][...] = x
            hv["v"][...] = v
            hv["a"][...] = a
            for name in ("ctl", "counts", "largest"):
                hv[name][...] = 0
        else:
            dm.x.assign(np.ascontiguousarray(x, dtype=F))
            dm.v.assign(np.ascontiguousarray(v, dtype=F))
            dm.a.assign(np.ascontiguousarray(a, dtype=F))
            dm.ctl.zero_()
            dm.counts.zero_()
            dm.largest.zero_()
        dm.last = prog
        self._replay(prog, int(nsteps))
        if hv is not None:
            ctl = hv["ctl"].copy()
            x[...] = hv["x"]
            v[...] = hv["v"]
            a[...] = hv["a"]
            max_corr[...] = hv["max_corr"]
        else:
            ctl = dm.ctl.numpy()
            x[...] = dm.x.numpy()
            v[...] = dm.v.numpy()
            a[...] = dm.a.numpy()
            max_corr[...] = dm.max_corr.numpy()
        status = int(ctl[0])
        done = int(ctl[1]) if status != STATUS_OK else int(nsteps)
        return done, status

    def replay_resident(self, x0, nsteps: int) -> int:
        """Benchmarks: run ``nsteps`` more steps of the last ``run_steps`` call of the model
        whose rest positions are ``x0`` on the device-resident state (no copies); returns the
        status.  The host state is not updated."""
        for dm in self._models.values():
            if dm.last is not None and dm.n == x0.shape[0]:
                self._replay(dm.last, int(nsteps))
                wp.synchronize_device(self.device)
                return int(dm.ctl.numpy()[0])  # noqa: the status word, not the state
        raise RuntimeError("no run_steps call to replay")


def run_steps(*args):
    """:meth:`WarpBackend.run_steps` on the default device (a GPU if present, else the CPU
    device) in float64: a drop-in for the numba backend's ``run_steps``."""
    return WarpBackend.get().run_steps(*args)
