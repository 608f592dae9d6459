"""Numba: the report's step with one Jacobi Provot pass over the springs, in three regions.

The case ``benchmarks/bench_step.py`` times (integrator ``paper``, Provot ``pairs = "springs"``,
``order = "jacobi"``, one loop, no obstacles) as THREE parallel regions per step instead of
five (drift, two force/Provot sweeps, momentum shift, finish).  The first sweep (per point p,
its first list) computes each spring's length once, its force and Provot scalars, and writes
them into the spring's slot of its second point's list, as
:func:`.forces_numba._accelerations_provot_fused` does; the second (per point q) gathers its
slots: q's acceleration and mean Provot request.  Then, serially in point order, the requests'
mass-weighted mean (``provot_numpy.momentum_shift``: Jacobi conserves linear momentum), and
the third region finishes each point: Provot move less that mean, the report's ground rule, the
checks and the NEXT step's drift (elementwise, so it joins the region).  Same formulas, same
summation order: the results are bitwise those of the five-region path (tested), for any
thread count.  (The shift needs every point's request, so the finish cannot join the second
sweep as it did before 2026-11-30: BENCHMARKS.md has the cost.)

Positions and velocities are double-buffered (the second sweep reads the neighbours' positions
while it writes the finished ones): step ``s`` reads ``(xr, vr)`` (after its drift) and writes
``(xw, vw)``.  A failing step (non-finite, runaway) is retaken from the intact read buffers
without the drift, so the caller sees the state after the failing step, as before.

Tried and dropped (``benchmarks/bench_fused.py``, same process, 2026-11-29): computing every
spring from both ends in ONE region per step (nothing stored, but twice the square roots and
divisions: 0.76x on one thread at 600 points); a spring-once sweep over 64 fixed point chunks
adding each in-chunk spring to both ends at once (0.93x at 100k points); the scalars stored in
spring order (contiguous, so the compiler vectorises the first sweep with ``fastmath =
{"reassoc"}``: vsqrtpd, gathers) and read back through a slot -> spring index (0.87x at 600
points, 0.59x at 100k: the indexed reads of the second sweep cost more than the vector square
roots gain).  Alone, the first sweep's arithmetic vectorised runs 4.5 ns per spring against
5.2 scalar (600 points, one thread), so the step is bound by the per-spring arithmetic and the
scattered slot stores (8.1 ns per spring at 100k), not by memory bandwidth.

The state arrays may be float64 or float32 (``precision = "float32"``): every length, force and
sum is computed in float64 (the loads are widened), only the stored positions, velocities and
accelerations round to float32.  (Measured: no faster than float64 on this machine's CPU, where
the step is compute-bound; float32 arithmetic per spring and float32 rest lengths and
stiffnesses were slower still, 0.93x, from the conversions.)
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from . import STATUS_OK
from .contact_numba import _ground_and_check, _status
from .provot_numba import _momentum_shift, _provot_c_inv


@njit(cache=True, inline="always")
def _accel_and_move(p, vr, a, fsum, inv_mass, gravity, damping, dx, max_corr):
    """Point p's acceleration into ``a``, its mean Provot request [m] into ``dx[p]`` and its
    norm into ``max_corr[p]`` (before the momentum shift, as the other paths)."""
    fx, fy, fz, sx, sy, sz, cnt = fsum
    w = inv_mass[p]
    a[p, 0] = (fx - damping * vr[p, 0]) * w + gravity[0]
    a[p, 1] = (fy - damping * vr[p, 1]) * w + gravity[1]
    a[p, 2] = (fz - damping * vr[p, 2]) * w + gravity[2]
    if cnt > 0:
        sx /= cnt
        sy /= cnt
        sz /= cnt
    max_corr[p] = np.sqrt(sx * sx + sy * sy + sz * sz)
    dx[p, 0] = sx
    dx[p, 1] = sy
    dx[p, 2] = sz


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
def paper_region(xr, vr, xw, vw, a, springs, points, tau, g, ctl, scratch):
    """One step (see the module docstring): reads ``xr, vr``, writes ``xw, vw, a``; record
    fields are unpacked before the parallel loops (extracting arrays from a record inside one
    costs reference counting per point)."""
    n = xr.shape[0]
    rest, stiff = springs.rest, springs.stiff
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    second_slot, second_other = springs.second_slot, springs.second_other
    first_other = springs.first_other
    sscal, pscal, dx = scratch.spring_scalar, scratch.provot_scalar, scratch.dx
    count, force, max_corr = scratch.count, scratch.force, scratch.max_corr
    inv_mass, gravity, center = points.inv_mass, points.gravity, g.center
    mass = points.mass
    consts = _consts(points, g, ctl)
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        sx = 0.0
        sy = 0.0
        sz = 0.0
        cnt = 0
        px, py, pz = np.float64(xr[p, 0]), np.float64(xr[p, 1]), np.float64(xr[p, 2])
        for s in range(first_ptr[p], first_ptr[p + 1]):
            q = first_other[s]
            ex = np.float64(xr[q, 0]) - px
            ey = np.float64(xr[q, 1]) - py
            ez = np.float64(xr[q, 2]) - pz
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            inv = 1.0 / length if length > 0.0 else 0.0
            r0 = rest[s]
            c = stiff[s] * (length - r0) * inv
            slot = second_slot[s]
            sscal[slot] = c
            fx += c * ex
            fy += c * ey
            fz += c * ez
            cp = _provot_c_inv(length, inv, r0, tau)
            pscal[slot] = cp
            sx += cp * ex
            sy += cp * ey
            sz += cp * ez
            cnt += cp != 0.0
        force[p, 0] = fx
        force[p, 1] = fy
        force[p, 2] = fz
        dx[p, 0] = sx
        dx[p, 1] = sy
        dx[p, 2] = sz
        count[p] = cnt
    nonfinite = 0
    runaway = 0
    for q in prange(n):
        fx = force[q, 0]
        fy = force[q, 1]
        fz = force[q, 2]
        sx = dx[q, 0]
        sy = dx[q, 1]
        sz = dx[q, 2]
        cnt = count[q]
        qx, qy, qz = np.float64(xr[q, 0]), np.float64(xr[q, 1]), np.float64(xr[q, 2])
        for t in range(second_ptr[q], second_ptr[q + 1]):
            i = second_other[t]
            ex = np.float64(xr[i, 0]) - qx
            ey = np.float64(xr[i, 1]) - qy
            ez = np.float64(xr[i, 2]) - qz
            c = sscal[t]
            fx += c * ex
            fy += c * ey
            fz += c * ez
            cp = pscal[t]
            sx += cp * ex
            sy += cp * ey
            sz += cp * ez
            cnt += cp != 0.0
        _accel_and_move(q, vr, a, (fx, fy, fz, sx, sy, sz, cnt), inv_mass, gravity,
                        consts[0], dx, max_corr)
    shift = _momentum_shift(mass, dx)  # serial, in point order: any thread count, bitwise
    for p in prange(n):
        bad, far = _finish_point(p, xr, vr, xw, vw, a, dx, shift, center, consts)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


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


@njit(cache=True)
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
