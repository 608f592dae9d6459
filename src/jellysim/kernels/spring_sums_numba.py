"""Numba: one point's sums over its springs, each spring computed from the point's own end.

Every numba kernel of the springs path (forces, the Jacobi Provot passes, the fused report
step) is one parallel loop over points that calls one of these: point ``p`` visits all its
springs in one list, ``visit_ptr[p]:visit_ptr[p+1]`` of :class:`.records.SpringArrays` (the
ones it is the first point of, then the ones it is the second point of, each with the other
end's index, the rest length and the stiffness stored in the list), and sums, in float64:

* the spring force of report eq. 1, ``k (|e| - L0) e / |e|`` with ``e = x_other - x_p``;
* Provot's request ``1/2 (|e| - clamp(|e|, (1 - tau) L0, (1 + tau) L0)) e / |e|`` (rounding
  noise below ``NOISE L0`` at the band's edge counts as inside, as in the spec) and the number of
  springs that make one.

So each spring's length is computed twice per pass (once from each end) and nothing is stored
per spring: no slot writes, no second sweep.  The loops are compiled with ``fastmath =
{"reassoc", "nsz", "contract"}`` so that LLVM vectorises them (AVX2/AVX-512 square roots and
divisions, partial sums in vector lanes, fused multiply-adds).  That fixes each point's
summation order by the compiled code alone, the same whichever thread runs the point: results
are bitwise identical for any thread count, and agree with the numpy spec (sums in another
order) to rounding, ~1e-16 m a step.

Measured (BENCHMARKS.md, "The gather step"): the report's step 1.3-1.8x faster than the
previous layout (each spring once, its scalars written into its second point's slot and
gathered by a second sweep) on this project's 2-core AVX2 VM, at 600 and 100k points.  These
functions are inlined into their callers (``inline="always"``), which are compiled with
:data:`FAST_OPTS`; what the callers call without inlining (the momentum shift's serial sum)
keeps its strict arithmetic (LLVM keeps fast-math flags per instruction).  A non-inlined
fast-math helper called once per point was measured 1.4x slower (the sums did not vectorise
as well).

One list, not two (BENCHMARKS.md, "One list per point"): the loop is vectorised 8 springs at
a time with a scalar remainder; the paper scene's points have 17 springs as first point and 17
as second point on average, and two loops (the form until session 30) spent a larger share in
their two remainders.  One loop ran the sweep 1.28x faster at 600 points, 1.1x at 100k.

Indices: the list is sliced first (``visit_other[lo:hi]``, ``visit_rest[lo:hi]``, ...) and
walked from 0.  Walked as ``range(first_ptr[p], first_ptr[p + 1])``, the index could be negative for
all LLVM knew, and numba's wraparound of negative indices made every load of the rest length,
stiffness and neighbour index a scalar load through a corrected address; from 0 they are
vector loads.  Against the loops walked from ``first_ptr[p]`` under the former default
target (LLVM's ``prefer-no-gather`` on Zen 4), the report's step runs 1.16-1.37x faster at 600
points and 1.2x at 100k on one thread (BENCHMARKS.md, "Indices walked from zero").  The
sums' lanes are LLVM's choice (fast-math), so the target must compile alike when numba
compiles and when it loads from its cache: ``tests/test_cache_bits.py``, :mod:`jellysim._cpu`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ._numba_opts import OPTS
from .provot_numpy import NOISE

FASTMATH = {"reassoc", "nsz", "contract"}
"""LLVM fast-math flags of the per-point sums (reassociation lets the loops vectorise)."""

FAST_OPTS = dict(OPTS, fastmath=FASTMATH)
"""Compile options of the kernels that call these sums: numba inlines the sums into them
(``inline="always"``) and compiles them with the caller's flags.  The flags exclude ``nnan``
and ``ninf``, so the callers' ``isfinite`` checks stay valid."""

_opts = dict(cache=True, error_model="numpy", inline="always")


@njit(**_opts)
def _scalars(ex, ey, ez, r0, k, tau):
    """(force scalar ``k (l - L0) / l`` [N/m], Provot scalar [-]) of one spring seen from one
    end, ``e`` the vector to the other end [m]; both 0 for a zero length."""
    length = np.sqrt(ex * ex + ey * ey + ez * ez)
    inv = 1.0 / length if length > 0.0 else 0.0
    target = min(max(length, (1.0 - tau) * r0), (1.0 + tau) * r0)
    excess = length - target
    excess = 0.0 if abs(excess) <= NOISE * r0 else excess
    return k * (length - r0) * inv, 0.5 * excess * inv


@njit(**_opts)
def point_force_provot(p, x, springs, tau):
    """Point p's spring force [N] and Provot request sum [m] with its count:
    ``(fx, fy, fz, sx, sy, sz, count)`` (count a float), over p's visit list (its springs as
    first point, then as second point: :func:`.records.visit_lists`)."""
    lo, hi = springs.visit_ptr[p], springs.visit_ptr[p + 1]
    others = springs.visit_other[lo:hi]
    rests, stiffs = springs.visit_rest[lo:hi], springs.visit_stiff[lo:hi]
    px, py, pz = np.float64(x[p, 0]), np.float64(x[p, 1]), np.float64(x[p, 2])
    fx = fy = fz = sx = sy = sz = cnt = 0.0
    for s in range(hi - lo):  # (from 0: see the module docstring, "Indices")
        q = others[s]
        ex = np.float64(x[q, 0]) - px
        ey = np.float64(x[q, 1]) - py
        ez = np.float64(x[q, 2]) - pz
        c, cp = _scalars(ex, ey, ez, rests[s], stiffs[s], tau)
        fx += c * ex
        fy += c * ey
        fz += c * ez
        sx += cp * ex
        sy += cp * ey
        sz += cp * ez
        cnt += 1.0 if cp != 0.0 else 0.0
    return fx, fy, fz, sx, sy, sz, cnt


@njit(**_opts)
def point_force(p, x, springs):
    """Point p's spring force [N] ``(fx, fy, fz)`` (report eq. 1, no damping or gravity): the
    force part of :func:`point_force_provot` (the Provot part is compiled away)."""
    fx, fy, fz, _, _, _, _ = point_force_provot(p, x, springs, 0.5)
    return fx, fy, fz


@njit(**_opts)
def point_provot(p, x, springs, tau):
    """Point p's Provot request sum [m] and count ``(sx, sy, sz, count)``: the Provot part of
    :func:`point_force_provot` (the force part is compiled away)."""
    _, _, _, sx, sy, sz, cnt = point_force_provot(p, x, springs, tau)
    return sx, sy, sz, cnt
