"""Numba: the report's step with one Jacobi Provot pass over the springs, in two regions.

The case ``benchmarks/bench_step.py`` times (integrator ``paper``, Provot ``pairs = "springs"``,
``order = "jacobi"``, one loop, no obstacles) as TWO parallel regions per step.  The first (per
point p) sums p's spring forces and Provot requests over all its springs, each computed from
p's end (:func:`.spring_sums_numba.point_force_provot`, as
:func:`.forces_numba._accelerations_provot_fused` does): p's acceleration and mean Provot
request.  Then, serially in point order, the requests' mass-weighted mean
(``provot_numpy.momentum_shift``: Jacobi conserves linear momentum), and the second region
finishes each point: Provot move less that mean, the report's ground rule, the checks and the
NEXT step's drift (elementwise, so it joins the region).  The same per-point sums as the
general path: the results are bitwise those of the drift / fused-sweep / finish kernels of
:func:`.steps_numba.run_steps` (tested), for any thread count.

Positions and velocities are double-buffered (the first region reads the neighbours' positions
while the second writes the finished ones): step ``s`` reads ``(xr, vr)`` (after its drift) and
writes ``(xw, vw)``.  A failing step (non-finite, runaway) is retaken from the intact read
buffers without the drift, so the caller sees the state after the failing step, as before.

History (BENCHMARKS.md, "Time step" and "The gather step"): until 2026-12-07 each spring was
computed once, by its first point, its force and Provot scalars written into the spring's slot
of its second point's list and gathered by a second sweep (three regions per step).  On the
AVX-512 VMs of 2026-11 that was as fast as computing each spring from both ends (0.76x scalar,
1.07x vectorised); on the AVX2 VM of 2026-12 the both-ends form, vectorised and with the
second list's rest lengths and stiffnesses stored in slot order, runs 1.3-1.8x faster at 600
and 100k points, and stores nothing per spring.

The state arrays may be float64 or float32 (``precision = "float32"``): every length, force and
sum is computed in float64 (the loads are widened), only the stored positions, velocities and
accelerations round to float32.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from . import STATUS_OK
from .contact_numba import _ground_and_check, _status
from .provot_numba import _momentum_shift
from .forces_numba import accel_and_requests


@njit(cache=True, inline="always")
def _finish_point(p, xr, vr, xw, vw, a, dx, shift, center, consts):
    """Point p's Provot move ``dx[p] - shift`` (shift: the moves' mass-weighted mean), ground
    rule, checks and (``drift``) the next step's drift, written to ``xw``/``vw``; returns
    (non-finite, runaway) as 0/1.  ``consts`` = (damping, paper, height, mu, nu, bound2, dt,
    drift, velocity_update)."""
    damping, paper, height, mu, nu, bound2, dt, drift, velocity_update = consts
    for c in range(3):
        xw[p, c] = xr[p, c] + (dx[p, c] - shift[c])
        vw[p, c] = vr[p, c]
    if velocity_update:
        inv_dt = 1.0 / dt
        for c in range(3):
            vw[p, c] += (xw[p, c] - xr[p, c]) * inv_dt
    bad, far = _ground_and_check(p, xw, vw, a, paper, height, mu, nu, center, bound2)
    if drift:
        for c in range(3):
            xw[p, c] += vw[p, c] * dt
            vw[p, c] += a[p, c] * dt
    return bad, far


@njit(cache=True, inline="always")
def _consts(points, g, ctl):
    dt, drift, velocity_update = ctl
    return (points.damping, g.paper, g.height, g.mu, g.nu, g.bound2, dt, drift,
            velocity_update)


@njit(**_opts)
def _finish_points(xr, vr, xw, vw, a, dx, shift, center, consts):
    """Every point's :func:`_finish_point`; returns the run status."""
    nonfinite = 0
    runaway = 0
    for p in prange(xr.shape[0]):
        bad, far = _finish_point(p, xr, vr, xw, vw, a, dx, shift, center, consts)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


@njit(cache=True, nogil=True)
def paper_region(xr, vr, xw, vw, a, springs, points, tau, g, ctl, scratch):
    """One step (see the module docstring): reads ``xr, vr``, writes ``xw, vw, a``."""
    dx, max_corr = scratch.dx, scratch.max_corr
    accel_and_requests(xr, vr, points, springs, tau, a, dx, max_corr)
    shift = _momentum_shift(points.mass, dx)  # serial, in point order: any thread count
    return _finish_points(xr, vr, xw, vw, a, dx, shift, g.center, _consts(points, g, ctl))


@njit(**_opts)
def _drift_paper(x, v, a, dt):
    for p in prange(x.shape[0]):
        for c in range(3):
            x[p, c] += v[p, c] * dt
            v[p, c] += a[p, c] * dt


@njit(**_opts)
def _copy_state(dst_x, dst_v, src_x, src_v):
    for p in prange(dst_x.shape[0]):
        for c in range(3):
            dst_x[p, c] = src_x[p, c]
            dst_v[p, c] = src_v[p, c]


@njit(cache=True, nogil=True)
def paper_springs_steps(nsteps, dt, x, v, a, springs, points, tau, velocity_update, ground,
                        scratch):
    """``nsteps`` report steps with one Jacobi Provot pass; (steps done, status).  Scratch:
    ``x_pre`` and ``v_alt`` are the second buffers, ``max_corr`` receives each point's last
    Provot move [m]."""
    _drift_paper(x, v, a, dt)
    xr, vr, xw, vw = x, v, scratch.x_pre, scratch.v_alt
    status = STATUS_OK
    done = nsteps
    for step in range(nsteps):
        last = step == nsteps - 1
        status = paper_region(xr, vr, xw, vw, a, springs, points, tau, ground,
                              (dt, not last, velocity_update), scratch)
        if status != STATUS_OK:
            if not last:  # retake the failing step without the next step's drift
                paper_region(xr, vr, xw, vw, a, springs, points, tau, ground,
                             (dt, False, velocity_update), scratch)
            done = step + 1
            xr, xw = xw, xr
            vr, vw = vw, vr
            break
        xr, xw = xw, xr
        vr, vw = vw, vr
    if done % 2 == 1:  # the state ended in the scratch buffers
        _copy_state(x, v, xr, vr)
    return done, status
