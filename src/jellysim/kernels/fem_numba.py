"""Numba twins of :mod:`.fem_numpy` (same names, arguments and results; see that spec).

Parallel over tets for the corner forces (each tet writes its own four rows), then parallel
over points for the gather (each point reads its own rows in tet order) and the integration:
no scatter-add, no race, bitwise identical for any thread count.  Arguments are grouped in
tuples (numba compiles tuples of arrays like plain arguments):

* ``fem``: ``(tets, rest_inverse, rest_volume, mu, lam, alpha, mu_l, lam_l, g, decay, q,
  point_tet_ptr, point_tet_slot)``
* ``model_arrays``: ``(inv_mass, damping, gravity, springs)`` with ``springs`` =
  ``(spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other, use_springs)``
* ``handles``: ``(gravity_scale, point_force, pinned, pin_from, pin_to, drag)``;
  ``drag = [point, tx, ty, tz, k]`` (point < 0: none)
* ``contact_arrays``: ``(obstacle_kind, obstacle_data, rest_speed, center, bound2)``
* ``scratch``: ``(tet_force, tet_j, fsum, spring_scalar, min_j)``
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import STATUS_OK
from .numba_backend import _status, contact

__all__ = ["tet_forces", "gather_tet_forces", "physical_steps"]

_opts = dict(parallel=True, cache=True, nogil=True, error_model="numpy")


@njit(cache=True, inline="always")
def _one_tet(t, x, tets, dm, vol, mu, lam, alpha, mu_l, g, decay, q, tet_force):
    i0, i1, i2, i3 = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
    # Ds columns
    d00 = x[i1, 0] - x[i0, 0]
    d10 = x[i1, 1] - x[i0, 1]
    d20 = x[i1, 2] - x[i0, 2]
    d01 = x[i2, 0] - x[i0, 0]
    d11 = x[i2, 1] - x[i0, 1]
    d21 = x[i2, 2] - x[i0, 2]
    d02 = x[i3, 0] - x[i0, 0]
    d12 = x[i3, 1] - x[i0, 1]
    d22 = x[i3, 2] - x[i0, 2]
    # Dm^-1 entries read one by one (no row view per tet)
    m00 = dm[t, 0, 0]
    m01 = dm[t, 0, 1]
    m02 = dm[t, 0, 2]
    m10 = dm[t, 1, 0]
    m11 = dm[t, 1, 1]
    m12 = dm[t, 1, 2]
    m20 = dm[t, 2, 0]
    m21 = dm[t, 2, 1]
    m22 = dm[t, 2, 2]
    # F = Ds Dm^-1
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
    a = mu[t] * (1.0 - 1.0 / (ic + 1.0))
    b = lam[t] * (J - alpha[t])
    p00 = a * f00 + b * c00
    p01 = a * f01 + b * c01
    p02 = a * f02 + b * c02
    p10 = a * f10 + b * c10
    p11 = a * f11 + b * c11
    p12 = a * f12 + b * c12
    p20 = a * f20 + b * c20
    p21 = a * f21 + b * c21
    p22 = a * f22 + b * c22
    if g > 0.0:
        exx = 0.5 * (f00 * f00 + f10 * f10 + f20 * f20 - 1.0)
        eyy = 0.5 * (f01 * f01 + f11 * f11 + f21 * f21 - 1.0)
        ezz = 0.5 * (f02 * f02 + f12 * f12 + f22 * f22 - 1.0)
        exy = 0.5 * (f00 * f01 + f10 * f11 + f20 * f21)
        eyz = 0.5 * (f01 * f02 + f11 * f12 + f21 * f22)
        exz = 0.5 * (f00 * f02 + f10 * f12 + f20 * f22)
        q0 = exx + (q[t, 0] - exx) * decay
        q1 = eyy + (q[t, 1] - eyy) * decay
        q2 = ezz + (q[t, 2] - ezz) * decay
        q3 = exy + (q[t, 3] - exy) * decay
        q4 = eyz + (q[t, 4] - eyz) * decay
        q5 = exz + (q[t, 5] - exz) * decay
        q[t, 0] = q0
        q[t, 1] = q1
        q[t, 2] = q2
        q[t, 3] = q3
        q[t, 4] = q4
        q[t, 5] = q5
        dxx = exx - q0
        dyy = eyy - q1
        dzz = ezz - q2
        tr = -2.0 * mu_l[t] * (dxx + dyy + dzz) / 3.0  # deviatoric branch
        two = 2.0 * mu_l[t]
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
    # H = -V P Dm^-T: H[:, k] = -V sum_l P[:, l] m[k, l]; corner 0 gets minus their sum
    w = -vol[t]
    h1x = w * (p00 * m00 + p01 * m01 + p02 * m02)
    h1y = w * (p10 * m00 + p11 * m01 + p12 * m02)
    h1z = w * (p20 * m00 + p21 * m01 + p22 * m02)
    h2x = w * (p00 * m10 + p01 * m11 + p02 * m12)
    h2y = w * (p10 * m10 + p11 * m11 + p12 * m12)
    h2z = w * (p20 * m10 + p21 * m11 + p22 * m12)
    h3x = w * (p00 * m20 + p01 * m21 + p02 * m22)
    h3y = w * (p10 * m20 + p11 * m21 + p12 * m22)
    h3z = w * (p20 * m20 + p21 * m21 + p22 * m22)
    r = 4 * t
    tet_force[r + 1, 0] = h1x
    tet_force[r + 1, 1] = h1y
    tet_force[r + 1, 2] = h1z
    tet_force[r + 2, 0] = h2x
    tet_force[r + 2, 1] = h2y
    tet_force[r + 2, 2] = h2z
    tet_force[r + 3, 0] = h3x
    tet_force[r + 3, 1] = h3y
    tet_force[r + 3, 2] = h3z
    tet_force[r, 0] = -((0.0 + h1x) + h2x + h3x)
    tet_force[r, 1] = -((0.0 + h1y) + h2y + h3y)
    tet_force[r, 2] = -((0.0 + h1z) + h2z + h3z)
    return J


@njit(**_opts)
def tet_forces(x, fem, g, decay, q, tet_force, tet_j):
    # the arrays are taken out of the tuple once, not per tet (12 % faster)
    tets, dm, vol, mu, lam, alpha, mu_l = fem[0], fem[1], fem[2], fem[3], fem[4], fem[5], fem[6]
    for t in prange(tets.shape[0]):
        tet_j[t] = _one_tet(t, x, tets, dm, vol, mu, lam, alpha, mu_l, g, decay, q, tet_force)


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
    dp = int(drag[0])
    nonfinite = 0
    runaway = 0
    for p in prange(x.shape[0]):
        fx = fsum[p, 0] + fext[p, 0]
        fy = fsum[p, 1] + fext[p, 1]
        fz = fsum[p, 2] + fext[p, 2]
        if p == dp:
            fx += drag[4] * (drag[1] - x[p, 0])
            fy += drag[4] * (drag[2] - x[p, 1])
            fz += drag[4] * (drag[3] - x[p, 2])
        w = inv_mass[p]
        gs = gscale[p]
        a[p, 0] = (fx - damping * v[p, 0]) * w + gs * gravity[0]
        a[p, 1] = (fy - damping * v[p, 1]) * w + gs * gravity[1]
        a[p, 2] = (fz - damping * v[p, 2]) * w + gs * gravity[2]
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


@njit(cache=True)
def _serial_min(values, start):
    m = start
    for i in range(values.shape[0]):
        if values[i] < m:
            m = values[i]
    return m


@njit(cache=True)
def physical_steps(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch):
    """``nsteps`` symplectic Euler steps of ``dt`` [s]: tet forces (+ springs), handles,
    integration, contact, checks.  Returns ``(steps done, status)``."""
    g, decay, q, ptr, slot = fem[8], fem[9], fem[10], fem[11], fem[12]
    springs = model_arrays[3]
    use_springs = springs[7]
    kinds, data, rest_speed, center, bound2 = (contact_arrays[0], contact_arrays[1],
                                               contact_arrays[2], contact_arrays[3],
                                               contact_arrays[4])
    tet_force, tet_j, fsum, scalar, min_j = (scratch[0], scratch[1], scratch[2], scratch[3],
                                             scratch[4])
    for s in range(nsteps):
        tet_forces(x, fem, g, decay, q, tet_force, tet_j)
        min_j[0] = _serial_min(tet_j, min_j[0])
        gather_tet_forces(tet_force, ptr, slot, fsum)
        if use_springs:
            _spring_forces(x, springs, scalar, fsum)
        # pins move along the line from pin_from to pin_to over the nsteps steps
        nonfinite, runaway = _integrate(x, v, a, fsum, model_arrays, handles, dt,
                                        (s + 1.0) / nsteps, center, bound2)
        if kinds.shape[0] > 0:
            contact(x, v, kinds, data, rest_speed, dt)
        status = _status(nonfinite, runaway)
        if status != STATUS_OK:
            return s + 1, status
    return nsteps, STATUS_OK
