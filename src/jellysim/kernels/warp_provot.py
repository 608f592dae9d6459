"""Warp kernels of Provot strain limiting (:mod:`.warp_backend`): Jacobi over the springs
(each spring's correction once, into its second-list slot, then a gather) or over all pairs,
and Gauss-Seidel (one serial thread).  Arithmetic mirrors :mod:`.provot_numba`.
"""
from __future__ import annotations

from typing import Any

import warp as wp

from .warp_common import A2 as _A2, AT as _AT, I32 as _I32
from .warp_common import precision_structs, register_overloads

wp.set_module_options({"enable_backward": False})

ProvotBuf = precision_structs("ProvotBuf", {"dx": ("array", 2), "cnt": _I32,
                                            "max_corr": ("array", 1),
                                            "largest": ("array", 1)}, __name__)
"""A Jacobi pass's buffers: the correction sum/average ``dx`` (n, 3), the count of acting
springs ``cnt`` (n,), each point's correction norm ``max_corr`` (n,), the largest ``[0]``."""


NOISE = 1e-12  # provot_numpy.NOISE: a pair this close (relative) to its band edge is inside


@wp.func
def _provot_c(length: Any, rest: Any, tau: Any):
    zero = type(length)(0.0)
    one = type(length)(1.0)
    half = type(length)(0.5)
    r = zero
    if length > zero:
        hi = (one + tau) * rest
        lo = (one - tau) * rest
        excess = zero
        if length > hi:
            excess = length - hi
        elif length < lo:
            excess = length - lo
        if wp.abs(excess) > type(length)(NOISE) * rest:
            r = half * excess / length
    return r


@wp.func
def _provot_c_inv(length: Any, inv_length: Any, rest: Any, tau: Any):
    one = type(length)(1.0)
    half = type(length)(0.5)
    target = wp.min(wp.max(length, (one - tau) * rest), (one + tau) * rest)
    excess = length - target
    if wp.abs(excess) <= type(length)(NOISE) * rest:
        excess = type(length)(0.0)
    return half * excess * inv_length


_F64_2 = wp.array2d(dtype=wp.float64)
_F64 = wp.array(dtype=wp.float64)


@wp.kernel
def k_mass_moves(mass: _AT, dx: _A2, part: _F64_2, gate: int, ctl: _I32):
    """Thread b of ``part.shape[0]`` fixed blocks of points: ``part[b] = (sum m dx, sum m)``
    over its block, serially in point order, in float64 for either precision (no float
    atomics: deterministic; one block on the CPU device is the numba/numpy order, bitwise)."""
    b = wp.tid()
    if ctl[0] != 0 or (gate != 0 and ctl[2] != 0):
        return
    n = dx.shape[0]
    nb = part.shape[0]
    sx = wp.float64(0.0)
    sy = wp.float64(0.0)
    sz = wp.float64(0.0)
    total = wp.float64(0.0)
    for p in range((n * b) // nb, (n * (b + 1)) // nb):
        m = wp.float64(mass[p])
        sx = sx + m * wp.float64(dx[p, 0])
        sy = sy + m * wp.float64(dx[p, 1])
        sz = sz + m * wp.float64(dx[p, 2])
        total = total + m
    part[b, 0] = sx
    part[b, 1] = sy
    part[b, 2] = sz
    part[b, 3] = total


@wp.kernel
def k_shift_total(part: _F64_2, shift: _F64, gate: int, ctl: _I32):
    """One thread: the blocks' sums in block order -> ``shift`` = sum m dx / sum m (3,)."""
    if ctl[0] != 0 or (gate != 0 and ctl[2] != 0):
        return
    sx = wp.float64(0.0)
    sy = wp.float64(0.0)
    sz = wp.float64(0.0)
    total = wp.float64(0.0)
    for b in range(part.shape[0]):
        sx = sx + part[b, 0]
        sy = sy + part[b, 1]
        sz = sz + part[b, 2]
        total = total + part[b, 3]
    shift[0] = sx / total
    shift[1] = sy / total
    shift[2] = sz / total


@wp.kernel
def k_remove_shift(dx: _A2, shift: _F64, gate: int, ctl: _I32):
    """``dx -= shift``: a Jacobi pass's moves less their mass-weighted mean (momentum kept)."""
    p = wp.tid()
    if ctl[0] != 0 or (gate != 0 and ctl[2] != 0):
        return
    for c in range(3):
        dx[p, c] = type(dx[p, c])(wp.float64(dx[p, c]) - shift[c])



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



register_overloads([k_provot_first, k_provot_second, k_provot_all, k_apply_dx,
                    k_provot_check, k_provot_gs, k_mass_moves, k_shift_total, k_remove_shift])
