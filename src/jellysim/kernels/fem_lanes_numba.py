"""Numba: the tet forces of :func:`.fem_numpy.tet_forces` computed ``LANES`` tets at a time.

Why blocks: per tet the Stable Neo-Hookean force is ~250 floating-point operations on values
gathered from four points, and written scalar-per-tet the compiler cannot vectorise it (the
loads and stores of many arrays might alias).  Here each block of ``LANES`` tets is first
gathered into one small local buffer (rows of a compile-time stride: row ``r`` is
``buf[r * LANES : (r + 1) * LANES]``), the arithmetic then runs as one loop over the lanes
that touches only that buffer (so LLVM proves there is no aliasing and emits AVX2/AVX-512
code), and the results are scattered back.  Same formulas in the same order as the
scalar version it replaced, no fused multiply-add: the forces are bitwise those of the
per-tet loop (``tests/test_fem.py``), for any thread count (every tet is computed alone).

Measured (``benchmarks/bench_tet_kernel.py``, BENCHMARKS.md "Session 6"): 63,888 tets, one
thread, 28.0 -> 17.4 ns per tet without the damping branch, 39.1 -> 28.3 with it; what is left
is mostly memory traffic (the inverse rest shapes, the branch strain, the corner forces: ~430
bytes per tet per substep).  Buffer rows::

    0-8    Ds (row-major: d_ab = x_{b+1}[a] - x_0[a])
    9-17   Dm^-1 (row-major)
    18-22  mu, lam, alpha, rest volume, mu_L
    23-28  the damping branch's strain q (xx yy zz xy yz xz), read and updated
    29-37  H = -V P Dm^-T (columns h1, h2, h3, each x y z)
    38     J
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts

__all__ = ["LANES", "tet_forces", "tet_forces_summed"]

LANES = 32
"""Tets per block (32 measured fastest of 16/32/64/128: the buffer, 39 rows, stays in L1)."""
_ROWS = 39
_CHUNKS = 256
"""Blocks are dealt to threads in this many contiguous chunks (one buffer per chunk)."""


def _make_lanes(damped):
    """The lane loop, with or without the damping branch (a compile-time constant: a branch
    inside the loop would stop the vectoriser)."""

    @njit(cache=True, inline="always", error_model="numpy")
    def lanes(s, g, decay):
        B = LANES
        for l in range(B):
            d00 = s[0 * B + l]
            d01 = s[1 * B + l]
            d02 = s[2 * B + l]
            d10 = s[3 * B + l]
            d11 = s[4 * B + l]
            d12 = s[5 * B + l]
            d20 = s[6 * B + l]
            d21 = s[7 * B + l]
            d22 = s[8 * B + l]
            m00 = s[9 * B + l]
            m01 = s[10 * B + l]
            m02 = s[11 * B + l]
            m10 = s[12 * B + l]
            m11 = s[13 * B + l]
            m12 = s[14 * B + l]
            m20 = s[15 * B + l]
            m21 = s[16 * B + l]
            m22 = s[17 * B + l]
            f00 = d00 * m00 + d01 * m10 + d02 * m20
            f01 = d00 * m01 + d01 * m11 + d02 * m21
            f02 = d00 * m02 + d01 * m12 + d02 * m22
            f10 = d10 * m00 + d11 * m10 + d12 * m20
            f11 = d10 * m01 + d11 * m11 + d12 * m21
            f12 = d10 * m02 + d11 * m12 + d12 * m22
            f20 = d20 * m00 + d21 * m10 + d22 * m20
            f21 = d20 * m01 + d21 * m11 + d22 * m21
            f22 = d20 * m02 + d21 * m12 + d22 * m22
            ic = (f00 * f00 + f01 * f01 + f02 * f02 + f10 * f10 + f11 * f11 + f12 * f12
                  + f20 * f20 + f21 * f21 + f22 * f22)
            # cofactor columns: c0 = F1 x F2, c1 = F2 x F0, c2 = F0 x F1 (Fk = column k)
            c00 = f11 * f22 - f21 * f12
            c10 = f21 * f02 - f01 * f22
            c20 = f01 * f12 - f11 * f02
            c01 = f12 * f20 - f22 * f10
            c11 = f22 * f00 - f02 * f20
            c21 = f02 * f10 - f12 * f00
            c02 = f10 * f21 - f20 * f11
            c12 = f20 * f01 - f00 * f21
            c22 = f00 * f11 - f10 * f01
            J = f00 * c00 + f10 * c10 + f20 * c20
            a = s[18 * B + l] * (1.0 - 1.0 / (ic + 1.0))
            b = s[19 * B + l] * (J - s[20 * B + l])
            p00 = a * f00 + b * c00
            p01 = a * f01 + b * c01
            p02 = a * f02 + b * c02
            p10 = a * f10 + b * c10
            p11 = a * f11 + b * c11
            p12 = a * f12 + b * c12
            p20 = a * f20 + b * c20
            p21 = a * f21 + b * c21
            p22 = a * f22 + b * c22
            if damped:
                exx = 0.5 * (f00 * f00 + f10 * f10 + f20 * f20 - 1.0)
                eyy = 0.5 * (f01 * f01 + f11 * f11 + f21 * f21 - 1.0)
                ezz = 0.5 * (f02 * f02 + f12 * f12 + f22 * f22 - 1.0)
                exy = 0.5 * (f00 * f01 + f10 * f11 + f20 * f21)
                eyz = 0.5 * (f01 * f02 + f11 * f12 + f21 * f22)
                exz = 0.5 * (f00 * f02 + f10 * f12 + f20 * f22)
                q0 = exx + (s[23 * B + l] - exx) * decay
                q1 = eyy + (s[24 * B + l] - eyy) * decay
                q2 = ezz + (s[25 * B + l] - ezz) * decay
                q3 = exy + (s[26 * B + l] - exy) * decay
                q4 = eyz + (s[27 * B + l] - eyz) * decay
                q5 = exz + (s[28 * B + l] - exz) * decay
                s[23 * B + l] = q0
                s[24 * B + l] = q1
                s[25 * B + l] = q2
                s[26 * B + l] = q3
                s[27 * B + l] = q4
                s[28 * B + l] = q5
                dxx = exx - q0
                dyy = eyy - q1
                dzz = ezz - q2
                mul = s[22 * B + l]
                tr = -2.0 * mul * (dxx + dyy + dzz) / 3.0  # deviatoric branch
                two = 2.0 * mul
                sxx = g * (two * dxx + tr)
                syy = g * (two * dyy + tr)
                szz = g * (two * dzz + tr)
                sxy = g * two * (exy - q3)
                syz = g * two * (eyz - q4)
                sxz = g * two * (exz - q5)
                p00 += f00 * sxx + f01 * sxy + f02 * sxz
                p01 += f00 * sxy + f01 * syy + f02 * syz
                p02 += f00 * sxz + f01 * syz + f02 * szz
                p10 += f10 * sxx + f11 * sxy + f12 * sxz
                p11 += f10 * sxy + f11 * syy + f12 * syz
                p12 += f10 * sxz + f11 * syz + f12 * szz
                p20 += f20 * sxx + f21 * sxy + f22 * sxz
                p21 += f20 * sxy + f21 * syy + f22 * syz
                p22 += f20 * sxz + f21 * syz + f22 * szz
            # H = -V P Dm^-T: H[:, k] = -V sum_l P[:, l] m[k, l]
            w = -s[21 * B + l]
            s[29 * B + l] = w * (p00 * m00 + p01 * m01 + p02 * m02)
            s[30 * B + l] = w * (p10 * m00 + p11 * m01 + p12 * m02)
            s[31 * B + l] = w * (p20 * m00 + p21 * m01 + p22 * m02)
            s[32 * B + l] = w * (p00 * m10 + p01 * m11 + p02 * m12)
            s[33 * B + l] = w * (p10 * m10 + p11 * m11 + p12 * m12)
            s[34 * B + l] = w * (p20 * m10 + p21 * m11 + p22 * m12)
            s[35 * B + l] = w * (p00 * m20 + p01 * m21 + p02 * m22)
            s[36 * B + l] = w * (p10 * m20 + p11 * m21 + p12 * m22)
            s[37 * B + l] = w * (p20 * m20 + p21 * m21 + p22 * m22)
            s[38 * B + l] = J

    return lanes


_lanes_elastic = _make_lanes(False)
_lanes_damped = _make_lanes(True)


@njit(cache=True, inline="always", error_model="numpy")
def _gather_block(s, t0, m, x, fem, q, damped):
    """Block ``[t0, t0 + m)`` into the buffer; lanes past ``m`` repeat tet ``t0``."""
    B = LANES
    tets, dm, vol, mu, lam, alpha, mu_l = fem[0], fem[1], fem[2], fem[3], fem[4], fem[5], fem[6]
    for l in range(B):
        t = t0 + l if l < m else t0
        i0, i1, i2, i3 = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
        x0, y0, z0 = x[i0, 0], x[i0, 1], x[i0, 2]
        s[0 * B + l] = x[i1, 0] - x0
        s[3 * B + l] = x[i1, 1] - y0
        s[6 * B + l] = x[i1, 2] - z0
        s[1 * B + l] = x[i2, 0] - x0
        s[4 * B + l] = x[i2, 1] - y0
        s[7 * B + l] = x[i2, 2] - z0
        s[2 * B + l] = x[i3, 0] - x0
        s[5 * B + l] = x[i3, 1] - y0
        s[8 * B + l] = x[i3, 2] - z0
        for a in range(3):
            for b in range(3):
                s[(9 + 3 * a + b) * B + l] = dm[t, a, b]
        s[18 * B + l] = mu[t]
        s[19 * B + l] = lam[t]
        s[20 * B + l] = alpha[t]
        s[21 * B + l] = vol[t]
        if damped:
            s[22 * B + l] = mu_l[t]
            for k in range(6):
                s[(23 + k) * B + l] = q[t, k]


@njit(cache=True, inline="always", error_model="numpy")
def _corner_forces(s, l):
    """Lane ``l``'s four corner forces [N] as 12 numbers (corner 0 x y z, corner 1 ...):
    corners 1-3 are the columns of H, corner 0 minus their sum (in this order: the gather
    and the summed pass must add the same bits)."""
    B = LANES
    h1x = s[29 * B + l]
    h1y = s[30 * B + l]
    h1z = s[31 * B + l]
    h2x = s[32 * B + l]
    h2y = s[33 * B + l]
    h2z = s[34 * B + l]
    h3x = s[35 * B + l]
    h3y = s[36 * B + l]
    h3z = s[37 * B + l]
    return (-((0.0 + h1x) + h2x + h3x), -((0.0 + h1y) + h2y + h3y), -((0.0 + h1z) + h2z + h3z),
            h1x, h1y, h1z, h2x, h2y, h2z, h3x, h3y, h3z)


@njit(cache=True, inline="always", error_model="numpy")
def _store_j_q(s, l, t, q, tet_j, damped):
    """Lane ``l``'s J into ``tet_j[t]`` and (``damped``) its updated strain into ``q[t]``;
    returns J."""
    B = LANES
    J = s[38 * B + l]
    tet_j[t] = J
    if damped:
        for k in range(6):
            q[t, k] = s[(23 + k) * B + l]
    return J


@njit(cache=True, inline="always", error_model="numpy")
def _scatter_block(s, t0, m, q, tet_force, tet_j, damped):
    """The block's corner forces [N] to rows ``4 t .. 4 t + 3``, J, and the updated q."""
    for l in range(m):
        t = t0 + l
        f = _corner_forces(s, l)  # constant indices below: a loop over f ran 20 % slower
        r = 4 * t
        tet_force[r, 0], tet_force[r, 1], tet_force[r, 2] = f[0], f[1], f[2]
        tet_force[r + 1, 0], tet_force[r + 1, 1], tet_force[r + 1, 2] = f[3], f[4], f[5]
        tet_force[r + 2, 0], tet_force[r + 2, 1], tet_force[r + 2, 2] = f[6], f[7], f[8]
        tet_force[r + 3, 0], tet_force[r + 3, 1], tet_force[r + 3, 2] = f[9], f[10], f[11]
        _store_j_q(s, l, t, q, tet_j, damped)


@njit(cache=True, inline="always", error_model="numpy")
def _block(s, t0, m, x, fem, q, damped, g, decay):
    """Tets ``t0 .. t0 + m - 1`` gathered into ``s`` and their forces computed there (the
    lane loop with or without the damping branch: two loops, so each vectorises)."""
    _gather_block(s, t0, m, x, fem, q, damped)
    if damped:
        _lanes_damped(s, g, decay)
    else:
        _lanes_elastic(s, g, decay)


@njit(**_opts)
def tet_forces(x, fem, g, decay, q, tet_force, tet_j):
    """See :func:`.fem_numpy.tet_forces` (same arguments and results)."""
    tets = fem[0]
    n = tets.shape[0]
    nb = (n + LANES - 1) // LANES
    damped = g > 0.0
    nch = min(nb, _CHUNKS)
    for ch in prange(nch):
        s = np.empty(_ROWS * LANES)
        for blk in range(ch * nb // nch, (ch + 1) * nb // nch):
            t0 = blk * LANES
            m = min(LANES, n - t0)
            _block(s, t0, m, x, fem, q, damped, g, decay)
            _scatter_block(s, t0, m, q, tet_force, tet_j, damped)


@njit(cache=True, nogil=True, error_model="numpy")
def tet_forces_summed(x, fem, g, decay, q, fsum, tet_j, min_j):
    """One thread: :func:`tet_forces` followed by :func:`.fem_numba.gather_tet_forces` and the
    smallest J, in one pass with no corner-force array: the tets are taken in order and each
    corner force is added to its point at once, so every point sums its tets' forces in tet
    order starting from 0.0, exactly as the gather does (bitwise the same ``fsum`` [N], shape
    (n, 3)); ``min_j[0]`` is lowered to the smallest J, NaNs skipped as in the gather path."""
    tets = fem[0]
    n = tets.shape[0]
    damped = g > 0.0
    B = LANES
    s = np.empty(_ROWS * LANES)
    fsum[:] = 0.0
    m_j = min_j[0]
    for t0 in range(0, n, B):
        m = min(B, n - t0)
        _block(s, t0, m, x, fem, q, damped, g, decay)
        for l in range(m):
            t = t0 + l
            f = _corner_forces(s, l)
            i0, i1, i2, i3 = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
            fsum[i0, 0], fsum[i0, 1], fsum[i0, 2] = fsum[i0, 0] + f[0], fsum[i0, 1] + f[1], \
                fsum[i0, 2] + f[2]
            fsum[i1, 0], fsum[i1, 1], fsum[i1, 2] = fsum[i1, 0] + f[3], fsum[i1, 1] + f[4], \
                fsum[i1, 2] + f[5]
            fsum[i2, 0], fsum[i2, 1], fsum[i2, 2] = fsum[i2, 0] + f[6], fsum[i2, 1] + f[7], \
                fsum[i2, 2] + f[8]
            fsum[i3, 0], fsum[i3, 1], fsum[i3, 2] = fsum[i3, 0] + f[9], fsum[i3, 1] + f[10], \
                fsum[i3, 2] + f[11]
            J = _store_j_q(s, l, t, q, tet_j, damped)
            if J < m_j:
                m_j = J
    min_j[0] = m_j
