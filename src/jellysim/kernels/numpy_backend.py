"""Numpy reference kernels: the executable specification of one time step.

Every function here has a numba twin of the same name and signature in
:mod:`jellysim.kernels.numba_backend`; tests check that they agree.  Arrays follow the Model's
conventions: positions ``x`` [m] (n, 3), velocities ``v`` [m/s] (n, 3), accelerations ``a``
[m/s^2] (n, 3), springs ``spring_ij`` (k, 2) with i < j.  The CSR arguments (``first_ptr``,
``second_ptr``, ``second_slot``, ``second_other``) are unused here; they are part of the
shared signature because the numba kernels gather through them.  ``spring_scalar`` is scratch
whose layout is backend-specific (numpy: spring order; numba: second-list slot order).
"""
from __future__ import annotations

import numpy as np

from . import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY


def _scatter(n: int, idx: np.ndarray, values: np.ndarray) -> np.ndarray:
    out = np.empty((n, 3))
    for c in range(3):
        out[:, c] = np.bincount(idx, weights=values[:, c], minlength=n)
    return out


def accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff,
                  first_ptr, second_ptr, second_slot, second_other, spring_scalar, a_out):
    """Report eq. 1: ``a = (sum_s k_s (|d| - L0_s) d / |d| - delta v) / m + g``.

    For spring s = (i, j), ``d = x_j - x_i``; the force ``k (|d| - L0) d / |d|`` acts on i and
    its opposite on j.  A spring of zero current length exerts no force (direction undefined).
    The per-spring scalar ``k (|d| - L0) / |d|`` is left in ``spring_scalar`` [N/m], shape (k,).
    Writes ``a_out`` [m/s^2], shape (n, 3).
    """
    n = x.shape[0]
    i, j = spring_ij[:, 0], spring_ij[:, 1]
    d = x[j] - x[i]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    safe = np.where(length > 0.0, length, 1.0)
    spring_scalar[:] = np.where(length > 0.0, stiff * (length - rest) / safe, 0.0)
    f = spring_scalar[:, None] * d
    force = _scatter(n, i, f) - _scatter(n, j, f)
    a_out[:] = (force - damping * v) * inv_mass[:, None] + gravity


def _provot_scalar(length, rest, tau):
    """Half the relative excess of a pair over its band (0 inside the band or at length 0)."""
    hi = (1.0 + tau) * rest
    lo = (1.0 - tau) * rest
    target = np.clip(length, lo, hi)
    safe = np.where(length > 0.0, length, 1.0)
    return np.where(length > 0.0, 0.5 * (length - target) / safe, 0.0)


def provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot, second_other,
           tau, loops, tolerance, all_pairs, gauss_seidel, spring_scalar, dx, count, max_corr):
    """Provot (1995) strain limiting, in place on ``x`` [m] (n, 3).

    A pair (i, j) with ``d = x_j - x_i`` whose length leaves ``[(1-tau) L0, (1+tau) L0]`` asks
    for i to move by ``+c d`` and j by ``-c d`` with ``c = (|d| - bound) / (2 |d|)``: both ends
    move equally to the nearest bound.  Pairs are the springs (rest length ``rest``) or, with
    ``all_pairs``, every pair (rest length from ``x0``).

    Jacobi order: all requests of a pass are computed from the same positions and each point
    moves by the mean of its requests.  Gauss-Seidel order: pairs in index order (i, then j),
    each request applied at once.  Stops after ``loops`` passes or when a pass's largest point
    correction is <= ``tolerance`` [m].  Returns ``(passes, largest correction of the last
    pass)``.  ``spring_scalar`` (k,), ``dx`` (n, 3), ``count`` (n,), ``max_corr`` (n,) are
    scratch.
    """
    n = x.shape[0]
    passes, largest = 0, 0.0
    if all_pairs:
        iu, ju = np.triu_indices(n, 1)
        pairs = np.stack([iu, ju], axis=1)
        pair_rest = np.linalg.norm(x0[ju] - x0[iu], axis=1)
    else:
        pairs, pair_rest = spring_ij, rest
    i, j = pairs[:, 0], pairs[:, 1]
    for _ in range(loops):
        passes += 1
        if gauss_seidel:
            largest = 0.0
            for s in range(pairs.shape[0]):
                a, b = i[s], j[s]
                d = x[b] - x[a]
                length = np.sqrt(d @ d)
                c = _provot_scalar(length, pair_rest[s], tau)
                if c != 0.0:
                    x[a] += c * d
                    x[b] -= c * d
                    largest = max(largest, abs(c) * length)
        else:
            d = x[j] - x[i]
            length = np.sqrt(np.einsum("ij,ij->i", d, d))
            c = _provot_scalar(length, pair_rest, tau)
            req = c[:, None] * d
            active = (c != 0.0).astype(np.float64)
            total = _scatter(n, i, req) - _scatter(n, j, req)
            cnt = np.bincount(i, weights=active, minlength=n) + np.bincount(
                j, weights=active, minlength=n)
            step = np.where(cnt[:, None] > 0, total / np.maximum(cnt, 1.0)[:, None], 0.0)
            x += step
            largest = float(np.sqrt(np.einsum("ij,ij->i", step, step)).max(initial=0.0))
        if largest <= tolerance:
            break
    return passes, largest


def finish_step(x, v, a, ground, height, mu, nu, center, bound2):
    """The report's ground (eqs. 2, 3), then the runaway/non-finite check.

    With ``ground``, a point with ``y < height`` gets ``y = height``, ``v_y = 0``,
    ``v_x, v_z *= mu`` and ``a_y -= nu a_y``.  Returns :data:`STATUS_NONFINITE` when any
    x, v or a is NaN/inf, else :data:`STATUS_RUNAWAY` when a point is farther than
    ``sqrt(bound2)`` [m] from ``center`` [m] (3,), else :data:`STATUS_OK`.
    """
    if ground:
        below = x[:, 1] < height
        x[below, 1] = height
        v[below, 1] = 0.0
        v[below, 0] *= mu
        v[below, 2] *= mu
        a[below, 1] -= nu * a[below, 1]
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v)) and np.all(np.isfinite(a))):
        return STATUS_NONFINITE
    r = x - center
    if np.any(np.einsum("ij,ij->i", r, r) > bound2):
        return STATUS_RUNAWAY
    return STATUS_OK


def run_steps(nsteps, dt, integrator, x, v, a, x0, inv_mass, damping, gravity,
              spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other,
              provot_loops, tau, tolerance, all_pairs, gauss_seidel, velocity_update,
              ground, height, mu, nu, obstacle_kind, obstacle_data, rest_speed, center, bound2,
              spring_scalar, dx, count, max_corr, x_pre, provot_scalar):
    """Advance ``nsteps`` steps of size ``dt`` [s] in place on x, v, a.

    One step (``integrator`` 0 = paper, 1 = symplectic):

    * paper: ``x += v dt; v += a dt; a = F(x, v) / m`` (report section 4.1);
    * symplectic: ``a = F(x, v) / m; v += a dt; x += v dt``;

    then ``provot_loops`` Provot passes (if > 0; with ``velocity_update`` the total
    correction / dt is added to v), then :func:`contact` with the obstacles (if any; kinds
    (m,) int32, data (m, 9)), then :func:`finish_step`.  ``provot_scalar`` (k,) is scratch for
    the numba backend's fused force + first Provot pass (paper order).
    Returns ``(steps_done, status)``:
    on a non-zero status, ``steps_done`` counts the steps completed including the failing one.
    """
    for step in range(nsteps):
        if integrator == 0:
            x += v * dt
            v += a * dt
            if provot_loops > 0 and velocity_update:
                x_pre[:] = x
            accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff, first_ptr,
                          second_ptr, second_slot, second_other, spring_scalar, a)
        else:
            accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff, first_ptr,
                          second_ptr, second_slot, second_other, spring_scalar, a)
            v += a * dt
            x += v * dt
            if provot_loops > 0 and velocity_update:
                x_pre[:] = x
        if provot_loops > 0:
            provot(x, x0, spring_ij, rest, first_ptr, second_ptr, second_slot, second_other,
                   tau, provot_loops, tolerance, all_pairs, gauss_seidel, spring_scalar, dx,
                   count, max_corr)
            if velocity_update:
                v += (x - x_pre) / dt
        if obstacle_kind.shape[0] > 0:
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt)
        status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK


# -- physical contact (planes, spheres, boxes) ----------------------------------------------
def _contact_geometry(kind, geom, x):
    """Signed distance [m] (n,) and outward unit normal (n, 3) of points ``x`` to one
    obstacle: kind 0 plane (point, normal), 1 sphere (centre, radius), 2 solid axis-aligned
    box (lower, upper; inside points are pushed out through the nearest face)."""
    n = x.shape[0]
    if kind == 0:
        nrm = np.broadcast_to(geom[3:6], (n, 3))
        return (x - geom[0:3]) @ geom[3:6], nrm
    if kind == 1:
        d = x - geom[0:3]
        r = np.sqrt(np.einsum("ij,ij->i", d, d))
        nrm = np.where(r[:, None] > 0.0, d / np.where(r > 0.0, r, 1.0)[:, None],
                       np.array([0.0, 1.0, 0.0]))
        return r - geom[3], nrm
    lo, hi = geom[0:3], geom[3:6]
    depth = np.concatenate([x - lo, hi - x], axis=1)  # (n, 6): distance inside each face
    face = np.argmin(depth, axis=1)
    phi = -depth[np.arange(n), face]
    inside = np.all(depth > 0.0, axis=1)
    phi = np.where(inside, phi, 1.0)
    nrm = np.zeros((n, 3))
    nrm[np.arange(n), face % 3] = np.where(face < 3, -1.0, 1.0)
    return phi, nrm


def contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt):
    """Non-penetration, restitution and Coulomb friction against static obstacles, in place.

    For each obstacle in order (``obstacle_data`` row: 6 geometry numbers, restitution e,
    static friction mu_s, kinetic friction mu_k), a point with signed distance ``phi < 0`` is
    moved out along the normal; if it approaches (``v_n < 0``) its normal velocity becomes
    ``-e v_n`` (0 when ``-v_n <= rest_speed`` [m/s]: resting contact), and the normal impulse
    per mass ``dv_n`` buys friction: the tangential velocity ``v_t`` is removed when
    ``|v_t| <= mu_s dv_n`` (sticking), else reduced by ``mu_k dv_n`` (sliding).  The position
    is moved tangentially by ``(v_t' - v_t) dt`` so that it follows the corrected velocity
    (a sticking point does not creep).
    """
    for o in range(obstacle_kind.shape[0]):
        geom = obstacle_data[o]
        phi, nrm = _contact_geometry(obstacle_kind[o], geom, x)
        hit = phi < 0.0
        if not np.any(hit):
            continue
        nh = nrm[hit]
        xh = x[hit] - phi[hit][:, None] * nh
        vh = v[hit]
        vn = np.einsum("ij,ij->i", vh, nh)
        vt = vh - vn[:, None] * nh
        app = vn < 0.0
        e, mu_s, mu_k = geom[6], geom[7], geom[8]
        vn_new = np.where(app, np.where(-vn > rest_speed, -e * vn, 0.0), vn)
        dvn = vn_new - vn
        speed = np.sqrt(np.einsum("ij,ij->i", vt, vt))
        stick = app & (speed <= mu_s * dvn)
        scale = np.where(stick, 0.0, np.where(
            app & (speed > 0.0), 1.0 - mu_k * dvn / np.where(speed > 0.0, speed, 1.0), 1.0))
        scale = np.maximum(scale, 0.0)
        vt_new = scale[:, None] * vt
        x[hit] = xh + (vt_new - vt) * dt
        v[hit] = vt_new + vn_new[:, None] * nh


# -- linearly implicit theta-method (stiff-stable integrator) --------------------------------
def spring_frames(x, spring_ij, rest, stiff, frame, clip=False):
    """Per-spring tangent data, ``frame`` (k, 5): unit direction n (3), ``k`` [N/m] and the
    geometric stiffness ``k (1 - L0 / L)`` [N/m]: the exact tangent.  With ``clip`` its
    compressive (negative) part is dropped so the tangent stiffness stays positive
    semi-definite (Choi & Ko 2002); the exact tangent is what keeps a pre-stressed body's
    vibration from being damped at first order in dt (a body resting under its own weight)."""
    d = x[spring_ij[:, 1]] - x[spring_ij[:, 0]]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    safe = np.where(length > 0.0, length, 1.0)
    frame[:, 0:3] = np.where(length[:, None] > 0.0, d / safe[:, None], 0.0)
    frame[:, 3] = stiff
    geo = stiff * (1.0 - rest / safe)
    frame[:, 4] = np.where(length > 0.0, np.maximum(geo, 0.0) if clip else geo, 0.0)


def system_matvec(u, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr, second_slot,
                  second_other, spring_vec, out):
    """``out = (mass + shift) u + h2 K u`` [kg m/s] for u (n, 3): K is the tangent stiffness
    of ``frame``, ``shift`` [kg] the damping term, ``h2`` [s^2] (theta dt)^2.  ``spring_vec``
    (k, 3) is scratch (the per-spring ``K_s (u_j - u_i)``)."""
    n = u.shape[0]
    du = u[spring_ij[:, 1]] - u[spring_ij[:, 0]]
    nrm = frame[:, 0:3]
    dn = np.einsum("ij,ij->i", nrm, du)
    spring_vec[:] = (frame[:, 3] - frame[:, 4])[:, None] * dn[:, None] * nrm + frame[:, 4][
        :, None] * du
    ku = _scatter(n, spring_ij[:, 1], spring_vec) - _scatter(n, spring_ij[:, 0], spring_vec)
    out[:] = (mass + shift)[:, None] * u + h2 * ku


def system_diagonal(mass, shift, h2, spring_ij, frame, diag):
    """Diagonal of the system matrix [kg], (n, 3) (the Jacobi preconditioner)."""
    n = mass.shape[0]
    nrm = frame[:, 0:3]
    kd = (frame[:, 3] - frame[:, 4])[:, None] * nrm * nrm + frame[:, 4][:, None]
    diag[:] = (mass + shift)[:, None] + h2 * (_scatter(n, spring_ij[:, 0], kd)
                                              + _scatter(n, spring_ij[:, 1], kd))


CONTACT_FREE = 0
"""Contact state of a point: no special state (constrained along the normal if touching)."""
CONTACT_RELEASED = 1
"""Its constraint pulled last step: left free for one step."""
CONTACT_STUCK = 2
"""Static friction held it last step: constrained in all three directions."""


def contact_normals(x, v, obstacle_kind, obstacle_data, margin, contact_state, dt, rest_speed,
                    first_ptr, second_ptr, cnrm, cobs, offset):
    """Contact constraints for an implicit step (speculative contacts).

    A point is constrained by the first obstacle it touches or would reach during the step at
    its current speed (``phi + dt min(v_n, 0) <= margin``, ``phi`` [m]: signed distance),
    unless its ``contact_state`` (n,) int8 is ``CONTACT_RELEASED``.  ``cnrm`` (n, 6) gets per
    point: the obstacle normal (3; zero for free points), the target normal velocity [m/s],
    the impact speed ``-v_n`` [m/s] when it exceeds ``rest_speed`` (else 0: resting) and 1.0
    when the point sticks (``CONTACT_STUCK``: its tangential velocity is held at 0 too).  The
    target is ``-max(phi, 0) / dt`` (close the gap, no more: the point stops on the surface
    and the body's own elasticity makes it bounce), except for a point without springs (a
    free particle), whose target is ``e x impact speed`` (its bounce, up to ``|v_n| dt``
    early).  Prescribing a bounce to the surface points of a body at a frame-rate dt would
    drive the layer above through them in one step, so the solve treats body points as
    inelastic.  ``cobs`` (n,): obstacle index or -1.

    ``dt`` here is the step's position coefficient and ``offset`` (n, 3) [m] the part of the
    position change that does not depend on the new velocity: the step moves a point by
    ``offset + dt v_new`` (theta-method: offset 0 and dt; BDF2: ``(x_n - x_n-1) / 3`` and
    ``2 dt / 3``), so the gap test is ``phi + offset_n + dt min(v_n, 0)`` and the target closes
    ``phi + offset_n``.
    """
    cnrm[:] = 0.0
    cobs[:] = -1
    for o in range(obstacle_kind.shape[0]):
        phi, nrm = _contact_geometry(obstacle_kind[o], obstacle_data[o], x)
        vn = np.einsum("ij,ij->i", v, nrm)
        gap = phi + np.einsum("ij,ij->i", offset, nrm)
        hit = ((cobs < 0) & (gap + dt * np.minimum(vn, 0.0) <= margin) & (vn <= 0.0)
               & (contact_state != CONTACT_RELEASED))
        cnrm[hit, 0:3] = nrm[hit]
        impact = np.where(-vn[hit] > rest_speed, -vn[hit], 0.0)
        free = (np.diff(first_ptr) + np.diff(second_ptr))[hit] == 0
        cnrm[hit, 3] = np.where((impact > 0.0) & free, obstacle_data[o, 6] * impact,
                                -(np.maximum(phi[hit], 0.0) + gap[hit] - phi[hit]) / dt)
        cnrm[hit, 4] = impact
        cnrm[hit, 5] = np.where(contact_state[hit] == CONTACT_STUCK, 1.0, 0.0)
        cobs[hit] = o


def filter_constrained(u, cnrm):
    """Remove the constrained components of u (n, 3) in place (Baraff & Witkin 1998): the
    normal one, or all three for a sticking point; ``cnrm`` (n, 6) from
    :func:`contact_normals`."""
    nrm = cnrm[:, 0:3]
    u -= np.einsum("ij,ij->i", u, nrm)[:, None] * nrm
    u *= (1.0 - cnrm[:, 5])[:, None]


def constrain_start(dv, v, cnrm):
    """Initial guess of an implicit solve (n, 3), in place: the free components of ``dv`` (the
    last step's, a warm start) and, along each constraint, what reaches the target velocity:
    ``v + dv = target n`` on the normal (and tangentially 0 for a sticking point)."""
    nrm = cnrm[:, 0:3]
    filter_constrained(dv, cnrm)
    dv += (cnrm[:, 3] - np.einsum("ij,ij->i", v, nrm))[:, None] * nrm
    vt = v - np.einsum("ij,ij->i", v, nrm)[:, None] * nrm
    dv -= cnrm[:, 5][:, None] * vt


def constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data, dt, contact_state):
    """Coulomb friction on the constrained points after an implicit step, in place on x, v,
    and their next ``contact_state``.

    The constraint impulse is ``J = A dv - b`` [kg m/s].  ``J_n < 0`` (the constraint pulled):
    the point is ``CONTACT_RELEASED`` next step.  A sticking point stays ``CONTACT_STUCK``
    while ``|J_t| <= mu_s J_n`` (static friction held it, inside the solve), else it slides
    from the next step.  A sliding point's tangential velocity is removed when
    ``|v_t| <= mu_s J_n / m`` (it sticks from the next step on), else reduced by
    ``mu_k J_n / m``; its position follows (``x += (v_t' - v_t) dt``).
    """
    contact_state[:] = CONTACT_FREE
    on = cobs >= 0
    if not np.any(on):
        return
    idx = np.nonzero(on)[0]
    nrm = cnrm[on, 0:3]
    j = ap[on] - b[on]
    jn = np.einsum("ij,ij->i", j, nrm)
    data = obstacle_data[cobs[on]]
    was_stuck = cnrm[on, 5] > 0.0
    jt = j - jn[:, None] * nrm
    jt_norm = np.sqrt(np.einsum("ij,ij->i", jt, jt))
    budget = np.maximum(jn, 0.0) / mass[on]
    vv = v[on]
    vn = np.einsum("ij,ij->i", vv, nrm)
    vt = vv - vn[:, None] * nrm
    speed = np.sqrt(np.einsum("ij,ij->i", vt, vt))
    stick = speed <= data[:, 7] * budget
    scale = np.where(stick | was_stuck, 0.0,
                     np.maximum(1.0 - data[:, 8] * budget / np.where(speed > 0, speed, 1.0),
                                0.0))
    x[on] += ((scale - 1.0)[:, None] * vt) * dt
    v[on] = scale[:, None] * vt + vn[:, None] * nrm
    holds = np.where(was_stuck, jt_norm <= data[:, 7] * np.maximum(jn, 0.0), stick)
    contact_state[idx[holds]] = CONTACT_STUCK
    contact_state[idx[jn < 0.0]] = CONTACT_RELEASED


def _dot(a, b):
    return float(np.sum(a * b))


def implicit_steps(nsteps, dt, theta, tol, max_iter, x, v, a, inv_mass, damping, gravity,
                   spring_ij, rest, stiff, first_ptr, second_ptr, second_slot, second_other,
                   ground, height, mu, nu, obstacle_kind, obstacle_data, rest_speed,
                   center, bound2, spring_scalar, frame, spring_vec, dv, r, z, p, ap, diag,
                   b, cnrm, mass, cobs, contact_state, bdf2=False, hist=None, fresh=None):
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
    :func:`contact` (new impacts: restitution) and :func:`finish_step`.  ``mass`` (n,) [kg];
    ``cobs`` (n,) int64 and ``contact_state`` (n,) int8 carry the contact state; the other
    trailing arrays are scratch ((k,), (k, 5), (k, 3), (n, 3) each, ``cnrm`` (n, 6)).
    Returns ``(steps_done, status, total CG iterations, largest relative residual left)``.

    With ``bdf2`` the step is the linearised BDF2 (see :class:`jellysim.params.ImplicitParams`)
    with ``beta = 2 dt / 3`` in place of ``theta dt``; ``hist`` (4, n, 3) holds the previous
    positions and velocities (and two scratch arrays), ``fresh`` (n,) uint8 marks the points
    whose history is restarted at the next step as ``x_n-1 = x_n - dt v_n``,
    ``v_n-1 = v_n - dt a_n`` (a backward-Euler-like step): all
    of them at first, then those an obstacle or the ground constrained or moved (a projection
    is not part of the multistep history).
    """
    h = 2.0 * dt / 3.0 if bdf2 else theta * dt
    h2 = h * h
    shift = np.full(mass.shape[0], h * damping)
    no_offset = np.zeros_like(x)  # theta-method: the step moves a point by dt v_new only
    iters = 0
    worst = 0.0
    for step in range(nsteps):
        accelerations(x, v, inv_mass, damping, gravity, spring_ij, rest, stiff, first_ptr,
                      second_ptr, second_slot, second_other, spring_scalar, a)
        if bdf2:
            x_prev, v_prev = hist[0], hist[1]
            restart = fresh.astype(bool)
            x_prev[restart] = x[restart] - dt * v[restart]
            v_prev[restart] = v[restart] - dt * a[restart]
        # the exact tangent first; if compression makes the system indefinite (CG breaks
        # down or the preconditioner is not positive), again with the compressive part dropped
        for clip in (False, True):
            spring_frames(x, spring_ij, rest, stiff, frame, clip)
            system_diagonal(mass, shift, h2, spring_ij, frame, diag)
            if not clip and np.any(diag <= 0.0):
                continue
            if bdf2:
                w = (x - x_prev) / 3.0 + h * v
                system_matvec(w, mass, shift * 0.0, 1.0, spring_ij, frame, first_ptr,
                              second_ptr, second_slot, second_other, spring_vec, ap)
                ap -= mass[:, None] * w  # = K w
                b[:] = h * (mass[:, None] * a - ap) + mass[:, None] * (v - v_prev) / 3.0
            else:
                # rhs = dt (m a - h K v); K v = A v - m v with A = m + K (no shift, h2 = 1)
                system_matvec(v, mass, shift * 0.0, 1.0, spring_ij, frame, first_ptr,
                              second_ptr, second_slot, second_other, spring_vec, ap)
                ap -= mass[:, None] * v  # = K v
                b[:] = dt * (mass[:, None] * a - h * ap)
            offset = (x - x_prev) / 3.0 if bdf2 else no_offset
            contact_normals(x, v, obstacle_kind, obstacle_data, 1e-9, contact_state,
                            h if bdf2 else dt, rest_speed, first_ptr, second_ptr, cnrm, cobs,
                            offset)
            if clip:
                dv[:] = 0.0  # the failed solve's iterate is no warm start
            constrain_start(dv, v, cnrm)
            # the scale of the stopping test: the whole right-hand side, constraint components
            # included (at rest the free part of b vanishes, the weight on the supports does not)
            bnorm = np.sqrt(_dot(b, b))
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
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
                system_matvec(p, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                              second_slot, second_other, spring_vec, ap)
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
        if bnorm > 0.0:
            worst = max(worst, res / bnorm)
        if not np.any(cobs >= 0):
            # free flight: the solve's residual must not act as a net force; a uniform dv
            # shift c changes A dv by (m + h delta) c (K annihilates translations), so this
            # makes sum(A dv) = sum(b) exactly: momentum exact whatever the tolerance
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
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
            system_matvec(dv, mass, shift, h2, spring_ij, frame, first_ptr, second_ptr,
                          second_slot, second_other, spring_vec, ap)
            constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data,
                                h if bdf2 else dt, contact_state)
            contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt)
        status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        if bdf2:
            fresh[:] = ((cobs >= 0) | np.any(x != hist[2], axis=1)
                        | np.any(v != hist[3], axis=1))
        if status != STATUS_OK:
            return step + 1, status, iters, worst
    return nsteps, STATUS_OK, iters, worst
