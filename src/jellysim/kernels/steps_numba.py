"""Numba: the explicit step drivers (report order and symplectic Euler), fused passes."""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ._numba_opts import OPTS as _opts
from . import STATUS_OK
from .contact_numba import _ground_and_check, _status, contact, finish_step
from .forces_numba import _accelerations_provot_fused, accelerations, accelerations_ordered
from .provot_numba import _serial_max, provot
from .steps_fused_numba import paper_springs_steps


@njit(**_opts)
def _drift(x, v, a, dt, paper, x_pre, save):
    """Integrator position/velocity update; with ``save``, also x_pre = x afterwards."""
    for p in prange(x.shape[0]):
        for c in range(3):
            if paper:
                x[p, c] += v[p, c] * dt
                v[p, c] += a[p, c] * dt
            else:
                v[p, c] += a[p, c] * dt
                x[p, c] += v[p, c] * dt
            if save:
                x_pre[p, c] = x[p, c]


@njit(**_opts)
def _finish_fused(x, v, a, dx, apply_dx, x_pre, add_velocity, dt, g):
    """Per point, in one parallel region: (x += dx), (v += (x - x_pre) / dt), then exactly
    :func:`finish_step`'s ground rule and checks."""
    n = x.shape[0]
    inv = 1.0 / dt
    nonfinite = 0
    runaway = 0
    for p in prange(n):
        for c in range(3):
            if apply_dx:
                x[p, c] += dx[p, c]
            if add_velocity:
                v[p, c] += (x[p, c] - x_pre[p, c]) * inv
        bad, far = _ground_and_check(p, x, v, a, g.paper, g.height, g.mu, g.nu, g.center,
                                     g.bound2)
        nonfinite += bad
        runaway += far
    return _status(nonfinite, runaway)


@njit(**_opts)
def _add_velocity(v, x, x_pre, dt):
    inv = 1.0 / dt
    for p in prange(x.shape[0]):
        for c in range(3):
            v[p, c] += (x[p, c] - x_pre[p, c]) * inv


@njit(cache=True, inline="always")
def _forces(x, v, points, springs, scratch, ordered, a):
    """Accelerations into ``a``: with ``ordered`` (Gauss-Seidel Provot, the report's sequential
    step) in the report's summation order, else the vectorised per-point sums."""
    if ordered:
        accelerations_ordered(x, v, points, springs, scratch.spring_scalar, a)
    else:
        accelerations(x, v, points, springs, scratch.spring_scalar, a)


@njit(cache=True, nogil=True)
def run_steps(nsteps, dt, integrator, x, v, a, springs, points, provot_opts, ground,
              obstacles, scratch):
    """Same contract as :func:`jellysim.kernels.steps_numpy.run_steps` (the spec)."""
    loops, tau, tolerance = provot_opts.loops, provot_opts.tau, provot_opts.tolerance
    all_pairs, gauss_seidel = provot_opts.all_pairs, provot_opts.gauss_seidel
    dx, max_corr, x_pre = scratch.dx, scratch.max_corr, scratch.x_pre
    fuse = integrator == 0 and loops > 0 and not all_pairs and not gauss_seidel
    has_obstacles = obstacles.kind.shape[0] > 0
    save = loops > 0 and provot_opts.velocity_update
    g = ground
    if fuse and loops == 1 and not has_obstacles:
        # two parallel regions per step, bitwise the same results (steps_fused_numba)
        return paper_springs_steps(nsteps, dt, x, v, a, springs, points, tau, save, g, scratch)
    for step in range(nsteps):
        pending = False  # a Provot correction in dx still to be applied by the finishing pass
        if integrator == 0:
            _drift(x, v, a, dt, True, x_pre, save)
            if fuse:
                # the report's order evaluates forces and then corrects the same positions:
                # one pass serves both (identical results to the separate kernels)
                last = loops == 1 and not has_obstacles
                _accelerations_provot_fused(x, v, points, springs, tau, a, dx, max_corr,
                                            not last)
                pending = last
                if loops > 1 and _serial_max(max_corr) > tolerance:
                    provot(x, points, springs, tau, loops - 1, tolerance, all_pairs, gauss_seidel,
                           scratch)
            else:
                _forces(x, v, points, springs, scratch, gauss_seidel, a)
        else:
            _forces(x, v, points, springs, scratch, gauss_seidel, a)
            _drift(x, v, a, dt, False, x_pre, save)
        if loops > 0 and not fuse:
            provot(x, points, springs, tau, loops, tolerance, all_pairs, gauss_seidel, scratch)
        if has_obstacles:
            if save:
                _add_velocity(v, x, x_pre, dt)
            contact(x, v, obstacles.kind, obstacles.data, obstacles.rest_speed, dt, obstacles.slip)
            status = finish_step(x, v, a, g.paper, g.height, g.mu, g.nu, g.center, g.bound2)
        else:
            status = _finish_fused(x, v, a, dx, pending, x_pre, save, dt, g)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK
