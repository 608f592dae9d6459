"""Numba twins of :mod:`.fem_numpy` (same names, arguments and results; see that spec).

Parallel over tets for the corner forces (each tet writes its own four rows; computed in
blocks of tets so that the compiler vectorises them: :mod:`.fem_lanes_numba`), then parallel
over points for the gather (each point reads its own rows in tet order) and the integration:
no scatter-add, no race, bitwise identical for any thread count.  Arguments are grouped in
tuples (numba compiles tuples of arrays like plain arguments):

* ``fem``: ``(tets, rest_inverse, rest_volume, mu, lam, alpha, mu_l, lam_l, g, decay, q,
  point_tet_ptr, point_tet_slot)``
* ``model_arrays``: ``(inv_mass, damping, gravity, springs)`` with ``springs`` =
  ``(spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other, use_springs)``
* ``handles``: ``(gravity_scale, point_force, pinned, pin_from, pin_to, drag, drag_weight,
  drag_offset)``; ``drag = [point, tx, ty, tz, k, c]`` (point < 0: none): each point of weight
  w > 0 is pulled by ``k w (target + offset - x) - c w v`` (the damper implicit per point)
* ``contact_arrays``: ``(obstacle_kind, obstacle_data, rest_speed, center, bound2, slip)``
* ``scratch``: ``(tet_force, tet_j, fsum, spring_scalar, min_j)``; a ``tet_force`` with no
  rows (what the Simulator passes when it runs one thread) selects
  :func:`.fem_lanes_numba.tet_forces_summed`: one serial pass adding each corner force to
  its point at once, no corner-force array, no gather (1.3x faster at 64k tets, bitwise the
  same sums)
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import STATUS_OK
from .numba_backend import _status, contact
from .fem_lanes_numba import tet_forces, tet_forces_summed

__all__ = ["tet_forces", "gather_tet_forces", "physical_steps"]

_opts = dict(parallel=True, cache=True, nogil=True, error_model="numpy")


@njit(**_opts)
def gather_tet_forces(tet_force, ptr, slot, out):
    for p in prange(out.shape[0]):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for e in range(ptr[p], ptr[p + 1]):
            r = slot[e]
            fx += tet_force[r, 0]
            fy += tet_force[r, 1]
            fz += tet_force[r, 2]
        out[p, 0] = fx
        out[p, 1] = fy
        out[p, 2] = fz


@njit(**_opts)
def _spring_forces(x, springs, scalar, out):
    """Adds the springs' eq. 1 forces [N] to ``out`` (each spring once, then a gather)."""
    spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other = (
        springs[0], springs[1], springs[2], springs[3], springs[4], springs[5], springs[6])
    n = x.shape[0]
    for p in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for s in range(first_ptr[p], first_ptr[p + 1]):
            j = spring_ij[s, 1]
            dx = x[j, 0] - x[p, 0]
            dy = x[j, 1] - x[p, 1]
            dz = x[j, 2] - x[p, 2]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            c = 0.0
            if length > 0.0:
                c = stiff[s] * (length - rest[s]) / length
            scalar[second_slot[s]] = c
            fx += c * dx
            fy += c * dy
            fz += c * dz
        out[p, 0] += fx
        out[p, 1] += fy
        out[p, 2] += fz
    for q in prange(n):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for t in range(second_ptr[q], second_ptr[q + 1]):
            c = scalar[t]
            i = second_other[t]
            fx += c * (x[i, 0] - x[q, 0])
            fy += c * (x[i, 1] - x[q, 1])
            fz += c * (x[i, 2] - x[q, 2])
        out[q, 0] += fx
        out[q, 1] += fy
        out[q, 2] += fz


@njit(**_opts)
def _integrate(x, v, a, fsum, model_arrays, handles, dt, frac, center, bound2):
    """Symplectic Euler per point (v += dt a; x += dt v), pins and the checks; returns the
    count of non-finite and runaway points."""
    inv_mass, damping, gravity = model_arrays[0], model_arrays[1], model_arrays[2]
    gscale, fext, pinned, pin_from, pin_to, drag = (handles[0], handles[1], handles[2],
                                                    handles[3], handles[4], handles[5])
    dw, doff = handles[6], handles[7]
    dragging = drag[0] >= 0.0
    nonfinite = 0
    runaway = 0
    for p in prange(x.shape[0]):
        fx = fsum[p, 0] + fext[p, 0]
        fy = fsum[p, 1] + fext[p, 1]
        fz = fsum[p, 2] + fext[p, 2]
        if dragging and dw[p] > 0.0:
            kd = drag[4] * dw[p]
            fx += kd * (drag[1] + doff[p, 0] - x[p, 0])
            fy += kd * (drag[2] + doff[p, 1] - x[p, 1])
            fz += kd * (drag[3] + doff[p, 2] - x[p, 2])
        w = inv_mass[p]
        gs = gscale[p]
        a[p, 0] = (fx - damping * v[p, 0]) * w + gs * gravity[0]
        a[p, 1] = (fy - damping * v[p, 1]) * w + gs * gravity[1]
        a[p, 2] = (fz - damping * v[p, 2]) * w + gs * gravity[2]
        if dragging and dw[p] > 0.0 and drag[5] > 0.0:  # the drag's damper, implicit
            r = 1.0 + dt * drag[5] * dw[p] * w
            for c in range(3):
                a[p, c] = ((v[p, c] + dt * a[p, c]) / r - v[p, c]) / dt
        if pinned[p] != 0:
            for c in range(3):
                target = pin_from[p, c] + frac * (pin_to[p, c] - pin_from[p, c])
                v[p, c] = (target - x[p, c]) / dt
                x[p, c] = target
                a[p, c] = 0.0
        else:
            for c in range(3):
                v[p, c] += dt * a[p, c]
                x[p, c] += dt * v[p, c]
        s = x[p, 0] + x[p, 1] + x[p, 2] + v[p, 0] + v[p, 1] + v[p, 2]
        if not np.isfinite(s):
            nonfinite += 1
        rx = x[p, 0] - center[0]
        ry = x[p, 1] - center[1]
        rz = x[p, 2] - center[2]
        if rx * rx + ry * ry + rz * rz > bound2:
            runaway += 1
    return nonfinite, runaway


@njit(cache=True, nogil=True)
def _serial_min(values, start):
    m = start
    for i in range(values.shape[0]):
        if values[i] < m:
            m = values[i]
    return m


@njit(cache=True, inline="always")
def _substep_tail(s, nsteps, dt, x, v, a, fsum, model_arrays, handles, contact_arrays, scratch):
    """The rest of substep ``s`` once the tet forces are in ``fsum``: springs (if k != 0),
    handles and integration, contact; returns the status."""
    springs = model_arrays[3]
    if springs[7]:  # use_springs
        _spring_forces(x, springs, scratch[3], fsum)
    # pins move along the line from pin_from to pin_to over the nsteps steps
    nonfinite, runaway = _integrate(x, v, a, fsum, model_arrays, handles, dt,
                                    (s + 1.0) / nsteps, contact_arrays[3], contact_arrays[4])
    if contact_arrays[0].shape[0] > 0:
        contact(x, v, contact_arrays[0], contact_arrays[1], contact_arrays[2], dt,
                contact_arrays[5])
    return _status(nonfinite, runaway)


@njit(cache=True, nogil=True)
def _steps_summed(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch):
    """One thread: each corner force added to its point at once (no corner-force array, no
    gather pass: bitwise the same sums)."""
    g, decay, q = fem[8], fem[9], fem[10]
    tet_j, fsum, min_j = scratch[1], scratch[2], scratch[4]
    for s in range(nsteps):
        tet_forces_summed(x, fem, g, decay, q, fsum, tet_j, min_j)
        status = _substep_tail(s, nsteps, dt, x, v, a, fsum, model_arrays, handles,
                               contact_arrays, scratch)
        if status != STATUS_OK:
            return s + 1, status
    return nsteps, STATUS_OK


@njit(cache=True, nogil=True)
def _steps_gathered(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch):
    """Threads: corner forces into rows (parallel over tets), then a gather per point."""
    g, decay, q, ptr, slot = fem[8], fem[9], fem[10], fem[11], fem[12]
    tet_force, tet_j, fsum, min_j = scratch[0], scratch[1], scratch[2], scratch[4]
    for s in range(nsteps):
        tet_forces(x, fem, g, decay, q, tet_force, tet_j)
        min_j[0] = _serial_min(tet_j, min_j[0])
        gather_tet_forces(tet_force, ptr, slot, fsum)
        status = _substep_tail(s, nsteps, dt, x, v, a, fsum, model_arrays, handles,
                               contact_arrays, scratch)
        if status != STATUS_OK:
            return s + 1, status
    return nsteps, STATUS_OK


def physical_steps(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch):
    """``nsteps`` symplectic Euler steps of ``dt`` [s]: tet forces (+ springs), handles,
    integration, contact, checks.  Returns ``(steps done, status)``.  A ``tet_force`` scratch
    with no rows (one thread) runs the summed tet pass, else the parallel rows and gather: two
    compiled drivers, chosen here, so that a run compiles only the one it uses (the other's
    tet kernel is about 9 s of a first run's compiling)."""
    driver = _steps_summed if scratch[0].shape[0] == 0 else _steps_gathered
    return driver(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch)
