"""Numpy (the spec): the linearly implicit theta-method and BDF2, matrix-free
Jacobi-preconditioned conjugate gradients with contact constraints inside the solve."""
from __future__ import annotations

import numpy as np

from . import STATUS_OK
from .contact_numpy import (MAX_CONE_PASSES, constrain_start, constraint_friction, contact,
                            contact_normals, filter_constrained, finish_step,
                            update_active_set)
from .forces_numpy import _scatter, accelerations


def spring_frames(x, springs, frame, clip=False):
    """Per-spring tangent data, ``frame`` (k, 5): unit direction n (3), ``k`` [N/m] and the
    geometric stiffness ``k (1 - L0 / L)`` [N/m]: the exact tangent.  With ``clip`` its
    compressive (negative) part is dropped so the tangent stiffness stays positive
    semi-definite (Choi & Ko 2002); the exact tangent is what keeps a pre-stressed body's
    vibration from being damped at first order in dt (a body resting under its own weight)."""
    spring_ij, rest, stiff = springs.ij, springs.rest, springs.stiff
    d = x[spring_ij[:, 1]] - x[spring_ij[:, 0]]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    safe = np.where(length > 0.0, length, 1.0)
    frame[:, 0:3] = np.where(length[:, None] > 0.0, d / safe[:, None], 0.0)
    frame[:, 3] = stiff
    geo = stiff * (1.0 - rest / safe)
    frame[:, 4] = np.where(length > 0.0, np.maximum(geo, 0.0) if clip else geo, 0.0)


def system_matvec(u, mass, shift, h2, springs, frame, spring_vec, out):
    """``out = (mass + shift) u + h2 K u`` [kg m/s] for u (n, 3): K is the tangent stiffness
    of ``frame``, ``shift`` [kg] the damping term, ``h2`` [s^2] (theta dt)^2.  ``spring_vec``
    (k, 3) is scratch (the per-spring ``K_s (u_j - u_i)``)."""
    n = u.shape[0]
    spring_ij = springs.ij
    du = u[spring_ij[:, 1]] - u[spring_ij[:, 0]]
    nrm = frame[:, 0:3]
    dn = np.einsum("ij,ij->i", nrm, du)
    spring_vec[:] = (frame[:, 3] - frame[:, 4])[:, None] * dn[:, None] * nrm + frame[:, 4][
        :, None] * du
    ku = _scatter(n, spring_ij[:, 1], spring_vec) - _scatter(n, spring_ij[:, 0], spring_vec)
    out[:] = (mass + shift)[:, None] * u + h2 * ku


def system_diagonal(mass, shift, h2, springs, frame, diag):
    """Diagonal of the system matrix [kg], (n, 3) (the Jacobi preconditioner)."""
    n = mass.shape[0]
    spring_ij = springs.ij
    nrm = frame[:, 0:3]
    kd = (frame[:, 3] - frame[:, 4])[:, None] * nrm * nrm + frame[:, 4][:, None]
    diag[:] = (mass + shift)[:, None] + h2 * (_scatter(n, spring_ij[:, 0], kd)
                                              + _scatter(n, spring_ij[:, 1], kd))


def _dot(a, b):
    return float(np.sum(a * b))


def implicit_steps(nsteps, dt, x, v, a, springs, points, ground, obstacles, options, scratch):
    """Advance ``nsteps`` steps of the linearly implicit theta-method, in place on x, v, a.

    One step (Baraff & Witkin 1998 for theta = 1; theta = 1/2 is the linearised implicit
    midpoint rule, which does not damp a linear oscillator)::

        (M + theta dt delta + theta^2 dt^2 K) dv = dt (F(x, v) - theta dt K v)
        x += dt (v + theta dv);  v += dv;  a = dv / dt

    K: the tangent stiffness at x (:func:`spring_frames`), F: springs, damping and gravity.
    The system is solved by Jacobi-preconditioned conjugate gradients from the previous step's
    ``dv`` (warm start) to a residual ``<= tol |rhs|`` (the whole right-hand side, constraint
    components included) or ``max_iter`` iterations.  Points touching or about to touch an
    obstacle (:func:`contact_normals`) are constrained inside the solve, as in Baraff &
    Witkin's modified conjugate gradients: their normal velocity change is fixed so that they
    end the step at the target normal velocity (all three components for a sticking point),
    the rest of the body feels it, and the constraint impulse gives their Coulomb friction
    (:func:`constraint_friction`).  Then
    :func:`contact` (new impacts: restitution) and :func:`finish_step`.  Records: ``springs``
    :class:`~.records.SpringArrays`, ``points`` :class:`~.records.PointArrays`, ``ground``
    :class:`~.records.GroundGuard`, ``obstacles`` :class:`~.records.Obstacles`, ``options``
    :class:`~.records.ImplicitOptions` (theta, CG tolerance and iterations, bdf2), ``scratch``
    :class:`~.records.ImplicitScratch` (``cobs``, ``contact_state``, ``dv``, ``hist`` and
    ``fresh`` carry state between calls; the rest is scratch).
    Returns ``(steps_done, status, total CG iterations, largest relative residual left)``.

    With ``bdf2`` the step is the linearised BDF2 (see :class:`jellysim.params.ImplicitParams`)
    with ``beta = 2 dt / 3`` in place of ``theta dt``; ``hist`` (4, n, 3) holds the previous
    positions and velocities (and two scratch arrays), ``fresh`` (n,) uint8 marks the points
    whose history is restarted at the next step as ``x_n-1 = x_n - dt v_n``,
    ``v_n-1 = v_n - dt a_n`` (a backward-Euler-like step): all
    of them at first, then those an obstacle or the ground constrained or moved (a projection
    is not part of the multistep history).
    """
    theta, tol, max_iter, bdf2 = (options.theta, options.tolerance, options.max_iterations,
                                  options.bdf2)
    mass, damping = points.mass, points.damping
    obstacle_kind, obstacle_data = obstacles.kind, obstacles.data
    rest_speed = obstacles.rest_speed
    sc = scratch
    frame, spring_vec, dv, r, z, p, ap, diag, b = (sc.frame, sc.spring_vec, sc.dv, sc.r, sc.z,
                                                   sc.p, sc.ap, sc.diag, sc.b)
    cnrm, cobs, contact_state, hist, fresh = (sc.cnrm, sc.cobs, sc.contact_state, sc.hist,
                                              sc.fresh)
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    g = ground
    h = 2.0 * dt / 3.0 if bdf2 else theta * dt
    h2 = h * h
    shift = np.full(mass.shape[0], h * damping)
    no_offset = np.zeros_like(x)  # theta-method: the step moves a point by dt v_new only
    iters = 0
    worst = 0.0
    for step in range(nsteps):
        accelerations(x, v, points, springs, sc.spring_scalar, a)
        if bdf2:
            x_prev, v_prev = hist[0], hist[1]
            restart = fresh.astype(bool)
            x_prev[restart] = x[restart] - dt * v[restart]
            v_prev[restart] = v[restart] - dt * a[restart]
        # Coulomb inside the step: an active-set iteration over the contact points (lift off,
        # slip, stick, kinetic friction inside the solve), at most MAX_CONE_PASSES solves
        sc.friction[:] = 0.0
        for cone_pass in range(MAX_CONE_PASSES):
            # the exact tangent first; if compression makes the system indefinite (CG breaks
            # down or the preconditioner is not positive), again with the compressive part dropped
            for clip in (False, True):
                spring_frames(x, springs, frame, clip)
                system_diagonal(mass, shift, h2, springs, frame, diag)
                if not clip and np.any(diag <= 0.0):
                    continue
                if bdf2:
                    w = (x - x_prev) / 3.0 + h * v
                    system_matvec(w, mass, shift * 0.0, 1.0, springs, frame, spring_vec, ap)
                    ap -= mass[:, None] * w  # = K w
                    b[:] = h * (mass[:, None] * a - ap) + mass[:, None] * (v - v_prev) / 3.0
                else:
                    # rhs = dt (m a - h K v); K v = A v - m v with A = m + K (no shift, h2 = 1)
                    system_matvec(v, mass, shift * 0.0, 1.0, springs, frame, spring_vec, ap)
                    ap -= mass[:, None] * v  # = K v
                    b[:] = dt * (mass[:, None] * a - h * ap)
                b += sc.friction  # the sliding points' kinetic friction (active-set passes)
                offset = (x - x_prev) / 3.0 if bdf2 else no_offset
                contact_normals(x, v, obstacle_kind, obstacle_data, 1e-9, contact_state,
                                h if bdf2 else dt, rest_speed, springs, cnrm, cobs, offset)
                if clip:
                    dv[:] = 0.0  # the failed solve's iterate is no warm start
                constrain_start(dv, v, cnrm)
                # the scale of the stopping test: the whole right-hand side, constraint components
                # included (at rest the free part of b vanishes, the weight on the supports does not)
                bnorm = np.sqrt(_dot(b, b))
                system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
                r[:] = b - ap
                filter_constrained(r, cnrm)
                z[:] = r / diag
                filter_constrained(z, cnrm)
                p[:] = z
                rz = _dot(r, z)
                res = np.sqrt(_dot(r, r))
                it = 0
                broke = False
                while it < max_iter and res > tol * bnorm:
                    system_matvec(p, mass, shift, h2, springs, frame, spring_vec, ap)
                    filter_constrained(ap, cnrm)
                    pap = _dot(p, ap)
                    if pap <= 0.0:
                        broke = True
                        break
                    alpha = rz / pap
                    dv += alpha * p
                    r -= alpha * ap
                    z[:] = r / diag
                    filter_constrained(z, cnrm)
                    rz_new = _dot(r, z)
                    p[:] = z + (rz_new / rz) * p
                    rz = rz_new
                    res = np.sqrt(_dot(r, r))
                    it += 1
                iters += it
                if not broke:
                    break
            if obstacle_kind.shape[0] == 0 or cone_pass == MAX_CONE_PASSES - 1:
                break
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            if update_active_set(v, dv, b, ap, mass, cnrm, cobs, obstacle_data, contact_state,
                                 sc.friction) == 0:
                break
        if bnorm > 0.0:
            worst = max(worst, res / bnorm)
        if not np.any(cobs >= 0):
            # free flight: the solve's residual must not act as a net force; a uniform dv
            # shift c changes A dv by (m + h delta) c (K annihilates translations), so this
            # makes sum(A dv) = sum(b) exactly: momentum exact whatever the tolerance
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            dv += (np.sum(b - ap, axis=0) / np.sum(mass + shift))[None, :]
        if bdf2:
            x_new = x + (x - hist[0]) / 3.0 + h * (v + dv)
            hist[0][:] = x
            hist[1][:] = v
            x[:] = x_new
        else:
            x += dt * (v + theta * dv)
        v += dv
        a[:] = dv / dt
        if bdf2:
            # a constrained body point's normal velocity is the one its step took: the BDF2
            # velocity that lands it on the surface also cancels its history, and would launch
            # it (a free particle keeps its prescribed bounce)
            on = (cobs >= 0) & ((np.diff(first_ptr) + np.diff(second_ptr)) > 0)
            nrm = cnrm[on, 0:3]
            moved = np.einsum("ij,ij->i", x[on] - hist[0][on], nrm) / dt
            v[on] += (moved - np.einsum("ij,ij->i", v[on], nrm))[:, None] * nrm
            hist[2][:] = x
            hist[3][:] = v
        if obstacle_kind.shape[0] > 0:
            system_matvec(dv, mass, shift, h2, springs, frame, spring_vec, ap)
            constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data,
                                h if bdf2 else dt, contact_state, sc.friction)
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt, obstacles.slip)
        status = finish_step(x, v, a, g.paper, g.height, g.mu, g.nu, g.center, g.bound2)
        if bdf2:
            fresh[:] = ((cobs >= 0) | np.any(x != hist[2], axis=1)
                        | np.any(v != hist[3], axis=1))
        if status != STATUS_OK:
            return step + 1, status, iters, worst
    return nsteps, STATUS_OK, iters, worst
