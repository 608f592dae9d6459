"""Numba: report eq. 1 spring forces, per point, race-free (each point sums its own springs:
:mod:`.spring_sums_numba`)."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from .provot_numba import shift_moves
from .spring_sums_numba import FAST_OPTS, point_force, point_force_provot


@njit(**FAST_OPTS)
def accelerations(x, v, points, springs, spring_scalar, a_out):
    """Report eq. 1 accelerations [m/s^2] into ``a_out`` (n, 3); ``spring_scalar`` is unused
    here (the numba kernels store nothing per spring: :mod:`.spring_sums_numba`)."""
    n = x.shape[0]
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    for p in prange(n):
        fx, fy, fz = point_force(p, x, springs)
        w = inv_mass[p]
        a_out[p, 0] = (fx - damping * v[p, 0]) * w + gx
        a_out[p, 1] = (fy - damping * v[p, 1]) * w + gy
        a_out[p, 2] = (fz - damping * v[p, 2]) * w + gz


@njit(cache=True, inline="always")
def _accel_and_move(p, v, a, sums, inv_mass, gravity, damping, dx, max_corr):
    """Point p's acceleration into ``a`` from its spring force sum, its mean Provot request
    [m] into ``dx[p]`` and the request's length into ``max_corr[p]`` (before the momentum
    shift)."""
    fx, fy, fz, sx, sy, sz, cnt = sums
    w = inv_mass[p]
    a[p, 0] = (fx - damping * v[p, 0]) * w + gravity[0]
    a[p, 1] = (fy - damping * v[p, 1]) * w + gravity[1]
    a[p, 2] = (fz - damping * v[p, 2]) * w + gravity[2]
    if cnt > 0:
        sx /= cnt
        sy /= cnt
        sz /= cnt
    max_corr[p] = np.sqrt(sx * sx + sy * sy + sz * sz)
    dx[p, 0] = sx
    dx[p, 1] = sy
    dx[p, 2] = sz


@njit(**FAST_OPTS)
def accel_and_requests(x, v, points, springs, tau, a_out, dx, max_corr):
    """Report eq. 1 accelerations [m/s^2] into ``a_out`` and the first Jacobi Provot pass's
    mean requests [m] into ``dx`` (their lengths into ``max_corr``), from one visit of each
    spring end: valid when Provot follows the force evaluation with no position change in
    between (the report's order)."""
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    for p in prange(x.shape[0]):
        sums = point_force_provot(p, x, springs, tau)
        _accel_and_move(p, v, a_out, sums, inv_mass, gravity, damping, dx, max_corr)


@njit(cache=True, nogil=True)
def _accelerations_provot_fused(x, v, points, springs, tau, a_out, dx, max_corr, apply):
    """``accelerations`` and the first Jacobi Provot pass over the springs
    (:func:`accel_and_requests`); ``dx`` receives the pass's moves (the mean requests less
    their mass-weighted mean, as the spec), ``max_corr`` each point's mean request's length
    [m]; with ``apply`` positions are corrected in place."""
    accel_and_requests(x, v, points, springs, tau, a_out, dx, max_corr)
    shift_moves(x, dx, points.mass, apply)


@njit(**_opts)
def accelerations_ordered(x, v, points, springs, spring_scalar, a_out):
    """:func:`accelerations` with every point's sum taken in the report's sequential order:
    its springs to larger indices ascending, then to smaller ones ascending, strict IEEE
    arithmetic (each spring once, by its first point, its scalar written into its second
    point's slot and gathered by a second sweep).  The step of Gauss-Seidel Provot (the
    report's, ``order = "gauss-seidel"``) uses it, so that the ``paper-2010`` preset agrees with
    a sequential transcription of the report to 1e-12 m after 100 steps
    (``tests/test_paper_step.py``: at the landing a rounding difference grows ~100x a step);
    the Jacobi paths use the vectorised :func:`accelerations`."""
    n = x.shape[0]
    inv_mass, damping, gravity = points.inv_mass, points.damping, points.gravity
    rest, stiff = springs.rest, springs.stiff
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, second_other = springs.second_slot, springs.second_other
    first_other = springs.first_other
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        px, py, pz = np.float64(x[p, 0]), np.float64(x[p, 1]), np.float64(x[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            dx = x[q, 0] - px
            dy = x[q, 1] - py
            dz = x[q, 2] - pz
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            c = 0.0
            if length > 0.0:
                c = stiff[s] * (length - rest[s]) / length
            spring_scalar[second_slot[s]] = c
            fx += c * dx
            fy += c * dy
            fz += c * dz
        a_out[p, 0] = fx
        a_out[p, 1] = fy
        a_out[p, 2] = fz
    for q in prange(n):
        fx = a_out[q, 0]
        fy = a_out[q, 1]
        fz = a_out[q, 2]
        qx, qy, qz = np.float64(x[q, 0]), np.float64(x[q, 1]), np.float64(x[q, 2])
        for t in range(second_ptr[q], second_ptr[q + 1]):
            c = spring_scalar[t]
            i = second_other[t]
            fx += c * (x[i, 0] - qx)
            fy += c * (x[i, 1] - qy)
            fz += c * (x[i, 2] - qz)
        w = inv_mass[q]
        a_out[q, 0] = (fx - damping * v[q, 0]) * w + gx
        a_out[q, 1] = (fy - damping * v[q, 1]) * w + gy
        a_out[q, 2] = (fz - damping * v[q, 2]) * w + gz
