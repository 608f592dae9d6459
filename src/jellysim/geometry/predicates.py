"""Exact geometric predicates for the inside test (:mod:`jellysim.geometry.inside`).

``orient2d`` / ``orient3d`` with Shewchuk's floating-point filter and an exact fallback
(Dekker TwoProduct + TwoSum expansions), and the symbolic-perturbation tie-break of an edge
(:func:`_sos_edge`).  See :mod:`jellysim.geometry.inside` for why and how they are exact.
All are numba ``njit`` functions on float64 scalars.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from jellysim._numba_cache import check as _check_cache

_check_cache()

_EPS = 2.0**-53
_SPLITTER = 134217729.0  # 2^27 + 1
_CCW_ERR = (3.0 + 16.0 * _EPS) * _EPS
_O3D_ERR = (7.0 + 56.0 * _EPS) * _EPS


@njit(cache=True, inline="always")
def _two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@njit(cache=True, inline="always")
def _split(a):
    c = _SPLITTER * a
    big = c - a
    hi = c - big
    return hi, a - hi


@njit(cache=True, inline="always")
def _two_product(a, b):
    x = a * b
    ahi, alo = _split(a)
    bhi, blo = _split(b)
    err = x - ahi * bhi
    err -= alo * bhi
    err -= ahi * blo
    return x, alo * blo - err


@njit(cache=True)
def _grow(e, n, b):
    """Add the double b to the expansion e[:n] in place (Shewchuk's Grow-Expansion with zero
    elimination: components stay non-overlapping and in increasing magnitude); returns the new
    length."""
    if b == 0.0:
        return n
    q = b
    m = 0
    for i in range(n):
        q, h = _two_sum(q, e[i])
        if h != 0.0:
            e[m] = h
            m += 1
    if q != 0.0:
        e[m] = q
        m += 1
    return m


@njit(cache=True)
def _expansion_sign(e, n):
    for i in range(n - 1, -1, -1):
        if e[i] > 0.0:
            return 1
        if e[i] < 0.0:
            return -1
    return 0


@njit(cache=True)
def _add_product2(e, n, x, y, sgn):
    hi, lo = _two_product(x, y)
    n = _grow(e, n, sgn * hi)
    return _grow(e, n, sgn * lo)


@njit(cache=True)
def _orient2d_exact(ax, ay, bx, by, cx, cy):
    # (bx-ax)(cy-ay) - (by-ay)(cx-ax) expanded into products of input coordinates
    e = np.empty(12)
    n = 0
    n = _add_product2(e, n, bx, cy, 1.0)
    n = _add_product2(e, n, bx, ay, -1.0)
    n = _add_product2(e, n, ax, cy, -1.0)
    n = _add_product2(e, n, by, cx, -1.0)
    n = _add_product2(e, n, by, ax, 1.0)
    n = _add_product2(e, n, ay, cx, 1.0)
    return _expansion_sign(e, n)


@njit(cache=True, inline="always")
def _orient2d(ax, ay, bx, by, cx, cy):
    """Exact sign of (b - a) x (c - a) (positive: a, b, c counter-clockwise)."""
    detleft = (ax - cx) * (by - cy)
    detright = (ay - cy) * (bx - cx)
    det = detleft - detright
    bound = _CCW_ERR * (abs(detleft) + abs(detright))
    if det > bound:
        return 1
    if -det > bound:
        return -1
    if bound == 0.0:  # both products are exactly zero (no underflow assumed)
        return 0
    return _orient2d_exact(ax, ay, bx, by, cx, cy)


@njit(cache=True)
def _add_product3(e, n, x, y, z, sgn):
    p1, p0 = _two_product(x, y)
    q1, q0 = _two_product(p1, z)
    r1, r0 = _two_product(p0, z)
    n = _grow(e, n, sgn * q1)
    n = _grow(e, n, sgn * q0)
    n = _grow(e, n, sgn * r1)
    return _grow(e, n, sgn * r0)


@njit(cache=True)
def _add_det3(e, n, a0, a1, a2, b0, b1, b2, c0, c1, c2, sgn):
    n = _add_product3(e, n, a0, b1, c2, sgn)
    n = _add_product3(e, n, a0, b2, c1, -sgn)
    n = _add_product3(e, n, a1, b0, c2, -sgn)
    n = _add_product3(e, n, a1, b2, c0, sgn)
    n = _add_product3(e, n, a2, b0, c1, sgn)
    n = _add_product3(e, n, a2, b1, c0, -sgn)
    return n


@njit(cache=True)
def _orient3d_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):
    # det3(a-d, b-d, c-d) = det3(a,b,c) - det3(a,b,d) + det3(a,c,d) - det3(b,c,d)
    e = np.empty(96)
    n = 0
    n = _add_det3(e, n, ax, ay, az, bx, by, bz, cx, cy, cz, 1.0)
    n = _add_det3(e, n, ax, ay, az, bx, by, bz, dx, dy, dz, -1.0)
    n = _add_det3(e, n, ax, ay, az, cx, cy, cz, dx, dy, dz, 1.0)
    n = _add_det3(e, n, bx, by, bz, cx, cy, cz, dx, dy, dz, -1.0)
    return _expansion_sign(e, n)


@njit(cache=True, inline="always")
def _orient3d(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):
    """Exact sign of det3(a - d, b - d, c - d) = (a - d) . ((b - a) x (c - a))."""
    adx = ax - dx
    ady = ay - dy
    adz = az - dz
    bdx = bx - dx
    bdy = by - dy
    bdz = bz - dz
    cdx = cx - dx
    cdy = cy - dy
    cdz = cz - dz
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    cdxady = cdx * ady
    adxcdy = adx * cdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    perm = (
        (abs(bdxcdy) + abs(cdxbdy)) * abs(adz)
        + (abs(cdxady) + abs(adxcdy)) * abs(bdz)
        + (abs(adxbdy) + abs(bdxady)) * abs(cdz)
    )
    bound = _O3D_ERR * perm
    if det > bound:
        return 1
    if -det > bound:
        return -1
    return _orient3d_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz)


@njit(cache=True, inline="always")
def _sos_edge(ay, az, by, bz, qy, qz):
    """Sign of orient2d(a, b, q + (e, e^2)) in the (y, z) plane, never 0 for a != b."""
    o = _orient2d(ay, az, by, bz, qy, qz)
    if o != 0:
        return o, o
    if az != bz:
        return (1 if az > bz else -1), 0
    if by != ay:
        return (1 if by > ay else -1), 0
    return 0, 0


