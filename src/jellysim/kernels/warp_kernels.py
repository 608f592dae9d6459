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

from .warp_common import A2 as _A2, AT as _AT, I32 as _I32
from .warp_common import FLOAT, precision_structs, register_overloads
from .warp_provot import ProvotBuf, _provot_c_inv

wp.set_module_options({"enable_backward": False})

Accel = precision_structs("Accel", {"inv_mass": ("array", 1), "damping": FLOAT, "gx": FLOAT,
                                    "gy": FLOAT, "gz": FLOAT}, __name__)
"""What turns a force into an acceleration: ``1 / m`` [1/kg] (n,), the damping delta [kg/s],
gravity [m/s^2]."""


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
def k_force_second(x: _A2, v: _A2, acc: Any, second_ptr: _I32, second_other: _I32, scal: _AT,
                   a: _A2, ctl: _I32):
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
    w = acc.inv_mass[q]
    damping = acc.damping
    a[q, 0] = (fx - damping * v[q, 0]) * w + acc.gx
    a[q, 1] = (fy - damping * v[q, 1]) * w + acc.gy
    a[q, 2] = (fz - damping * v[q, 2]) * w + acc.gz


@wp.kernel
def k_fused_first(x: _A2, spring_j: _I32, rest: _AT, stiff: _AT, first_ptr: _I32,
                  second_slot: _I32, tau: Any, scal: _AT, pscal: _AT, f: _A2, pb: Any,
                  ctl: _I32):
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
    pb.dx[p, 0] = sx
    pb.dx[p, 1] = sy
    pb.dx[p, 2] = sz
    pb.cnt[p] = n


@wp.kernel
def k_fused_second(x: _A2, v: _A2, acc: Any, second_ptr: _I32, second_other: _I32,
                   scal: _AT, pscal: _AT, a: _A2, pb: Any, reduce: int, ctl: _I32):
    q = wp.tid()
    if ctl[0] != 0:
        return
    dx = pb.dx
    fx = a[q, 0]
    fy = a[q, 1]
    fz = a[q, 2]
    sx = dx[q, 0]
    sy = dx[q, 1]
    sz = dx[q, 2]
    n = pb.cnt[q]
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
    w = acc.inv_mass[q]
    damping = acc.damping
    a[q, 0] = (fx - damping * v[q, 0]) * w + acc.gx
    a[q, 1] = (fy - damping * v[q, 1]) * w + acc.gy
    a[q, 2] = (fz - damping * v[q, 2]) * w + acc.gz
    if n > 0:
        sx = sx / type(qx)(n)
        sy = sy / type(qx)(n)
        sz = sz / type(qx)(n)
    dx[q, 0] = sx
    dx[q, 1] = sy
    dx[q, 2] = sz
    m = wp.sqrt(sx * sx + sy * sy + sz * sz)
    pb.max_corr[q] = m
    if reduce != 0:
        wp.atomic_max(pb.largest, 0, m)



@wp.kernel
def k_triad(a: _AT, b: _AT, c: _AT, s: Any):
    """STREAM triad ``a = b + s c`` (the benchmark's bandwidth probe)."""
    i = wp.tid()
    a[i] = b[i] + s * c[i]


register_overloads([k_drift, k_force_first, k_force_second, k_fused_first, k_fused_second,
                    k_triad], {"acc": Accel, "pb": ProvotBuf})
