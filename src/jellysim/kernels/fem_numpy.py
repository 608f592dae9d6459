"""Executable specification of the tetrahedral (physical) kernels, vectorised numpy.

:mod:`.fem_numba` has the same functions with the same arguments and results (tested to agree);
this file is the one to read.

Per tet (``F = Ds Dm^-1``, ``Ds = [x1 - x0, x2 - x0, x3 - x0]``)::

    P = mu (1 - 1 / (I_C + 1)) F + lam (J - alpha) cof(F)            Stable Neo-Hookean
    E_G = (F^T F - I) / 2;  Q <- E_G + (Q - E_G) exp(-dt / tau)          damping branch state
    P += F g 2 mu_L dev(E_G - Q)                                         its stress
    H = -V P Dm^-T;  f1, f2, f3 = columns of H;  f0 = -(f1 + f2 + f3)

``cof(F) = dJ/dF`` has the columns ``F1 x F2, F2 x F0, F0 x F1``.  The forces of tet t on its
corners are written to rows ``4 t + c`` of ``tet_force``; a point sums its rows in tet order.
"""
from __future__ import annotations

import numpy as np

from . import STATUS_OK, numpy_backend as nb

__all__ = ["tet_forces", "gather_tet_forces", "physical_steps"]


def tet_forces(x, fem, g, decay, q, tet_force, tet_j):
    """Corner forces [N] of every tet into ``tet_force`` (shape (4 t, 3)); J into ``tet_j``
    (shape (t,)); the damping branch's internal strain ``q`` (shape (t, 6): xx yy zz xy yz xz)
    is advanced by ``decay = exp(-dt / tau)`` when ``g > 0``."""
    tets, dm_inv, vol, mu, lam, alpha, mu_l, lam_l = fem[:8]
    x0 = x[tets[:, 0]]
    ds = np.stack([x[tets[:, c]] - x0 for c in (1, 2, 3)], axis=2)
    F = ds @ dm_inv
    ic = np.einsum("tij,tij->t", F, F)
    c0, c1, c2 = F[:, :, 0], F[:, :, 1], F[:, :, 2]
    cof = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=2)
    J = np.einsum("ti,ti->t", c0, cof[:, :, 0])
    tet_j[:] = J
    P = (mu * (1.0 - 1.0 / (ic + 1.0)))[:, None, None] * F \
        + (lam * (J - alpha))[:, None, None] * cof
    if g > 0.0:
        C = np.einsum("tki,tkj->tij", F, F)
        e = 0.5 * (C - np.eye(3))
        ev = np.stack([e[:, 0, 0], e[:, 1, 1], e[:, 2, 2], e[:, 0, 1], e[:, 1, 2],
                       e[:, 0, 2]], axis=1)
        q[:] = ev + (q - ev) * decay
        d = ev - q
        tr = d[:, 0] + d[:, 1] + d[:, 2]
        S = np.empty_like(F)
        for a, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
            S[:, i, j] = 2.0 * mu_l * d[:, a]
            S[:, j, i] = S[:, i, j]
        for i in range(3):
            S[:, i, i] -= 2.0 * mu_l * tr / 3.0  # deviatoric: 2 mu_L dev(E_G - Q)
        P = P + g * (F @ S)
    H = -vol[:, None, None] * (P @ np.transpose(dm_inv, (0, 2, 1)))
    f = tet_force.reshape(-1, 4, 3)
    f[:, 1] = H[:, :, 0]
    f[:, 2] = H[:, :, 1]
    f[:, 3] = H[:, :, 2]
    f[:, 0] = -(H[:, :, 0] + H[:, :, 1] + H[:, :, 2])


def gather_tet_forces(tet_force, ptr, slot, out):
    """``out[p]`` = sum of point p's corner rows, in tet order [N], shape (n, 3)."""
    n = out.shape[0]
    counts = np.diff(ptr)
    owner = np.repeat(np.arange(n), counts)
    out[:] = 0.0
    for c in range(3):
        # bincount sums in slot order, which is the tet order within each point
        out[:, c] = np.bincount(owner, weights=tet_force[slot, c], minlength=n)


def spring_forces(x, springs, spring_scalar):
    """The springs' forces [N], shape (n, 3), from the physical path's ``springs`` tuple
    (:mod:`.fem_numba`'s ``model_arrays[3]``): report eq. 1 without damping or gravity."""
    from .records import PointArrays, SpringArrays

    n = x.shape[0]
    points = PointArrays(None, None, np.ones(n), 0.0, np.zeros(3))
    acc = np.zeros_like(x)
    springs = SpringArrays._make(list(springs[:7]) + [None] * 5)  # (numpy reads the first 7)
    nb.accelerations(x, np.zeros_like(x), points, springs, spring_scalar, acc)
    return acc


def physical_steps(nsteps, dt, x, v, a, model_arrays, fem, handles, contact_arrays, scratch):
    """``nsteps`` symplectic Euler steps of ``dt`` with tet (and spring) forces, handles and
    contact.  Same arguments and results as the numba driver; see :mod:`.fem_numba`."""

    inv_mass, damping, gravity, springs = model_arrays
    g, decay, q = fem[8], fem[9], fem[10]
    gscale, fext, pinned, pin_from, pin_to, drag, drag_w, drag_off = handles
    kinds, data, rest_speed, center, bound2, slip = contact_arrays
    tet_force, tet_j, fsum, spring_scalar, min_j = scratch
    ptr, slot = fem[11], fem[12]
    use_springs = springs[7]
    pin = pinned != 0
    for s in range(nsteps):
        tet_forces(x, fem, g, decay, q, tet_force, tet_j)
        min_j[0] = min(min_j[0], float(tet_j.min()))
        gather_tet_forces(tet_force, ptr, slot, fsum)
        if use_springs:
            fsum += spring_forces(x, springs, spring_scalar)
        if drag[0] >= 0:  # the grabbed patch: k w (target + offset - x) on each point
            fsum += drag[4] * drag_w[:, None] * (drag[1:4] + drag_off - x)
        a[:] = (fsum + fext - damping * v) * inv_mass[:, None] + gscale[:, None] * gravity
        if drag[0] >= 0 and drag[5] > 0:  # its damper c w v, implicit per point (any c)
            held = drag_w > 0
            rate = dt * drag[5] * drag_w[held] * inv_mass[held]
            v_new = (v[held] + dt * a[held]) / (1.0 + rate)[:, None]
            a[held] = (v_new - v[held]) / dt
        v += dt * a
        x += dt * v
        if pin.any():
            frac = (s + 1.0) / nsteps
            target = pin_from[pin] + frac * (pin_to[pin] - pin_from[pin])
            v[pin] = (target - (x[pin] - dt * v[pin])) / dt
            x[pin] = target
            a[pin] = 0.0
        nb.contact(x, v, kinds, data, rest_speed, dt, slip)
        status = nb.finish_step(x, v, a, False, 0.0, 0.0, 0.0, center, bound2)
        if status != STATUS_OK:
            return s + 1, status
    return nsteps, STATUS_OK
