"""Numpy (the spec): the report's ground and the guard (:func:`finish_step`), obstacle
contact with restitution and Coulomb friction, and the implicit solve's contact constraints."""
from __future__ import annotations

import numpy as np

from .records import OBSTACLE_E, OBSTACLE_MU_K, OBSTACLE_MU_S, OBSTACLE_SLIP
from . import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY


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


def contact(x, v, obstacle_kind, obstacle_data, rest_speed, dt, slip):
    """Non-penetration, restitution and Coulomb friction against static obstacles, in place.

    For each obstacle in order (``obstacle_data`` row: 6 geometry numbers, restitution e,
    static friction mu_s, kinetic friction mu_k, slip-weakening distance D_c [m]), a point with
    signed distance ``phi < 0`` is moved out along the normal; if it approaches (``v_n < 0``)
    its normal velocity becomes ``-e v_n`` (0 when ``-v_n <= rest_speed`` [m/s] or when it
    touched at the step's start, :func:`touching`: resting contact), and the normal impulse
    per mass ``dv_n`` buys friction with the coefficient ``mu(s) = mu_s - (mu_s - mu_k) min(s / D_c, 1)`` (``D_c = 0``: mu_k once ``s > 0``), ``s``
    = ``slip`` (n,) [m], the point's tangential slip since it last stuck: the tangential
    velocity ``v_t`` is removed when ``|v_t| <= mu(s) dv_n`` (it sticks: ``s = 0``), else
    reduced by ``mu(s) dv_n`` (it slides: ``s += |v_t'| dt``).  The position is moved
    tangentially by ``(v_t' - v_t) dt`` so that it follows the corrected velocity (a sticking
    point does not creep).  An infinite mu_s (above :data:`NO_SLIP`: a no-slip surface) holds
    every touching point, approaching or not.
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
        e, mu_s, mu_k = geom[OBSTACLE_E], geom[OBSTACLE_MU_S], geom[OBSTACLE_MU_K]
        bounce = (-vn > rest_speed) & ~touching(phi[hit], vh, vn, dt)
        vn_new = np.where(app, np.where(bounce, -e * vn, 0.0), vn)
        dvn = vn_new - vn
        speed = np.sqrt(np.einsum("ij,ij->i", vt, vt))
        s = slip[hit]
        if mu_s > NO_SLIP:
            stick = np.ones(len(vn), dtype=bool)
            mu = np.zeros(len(vn))
        else:
            mu = mu_k + weakening(s, geom[OBSTACLE_SLIP]) * (mu_s - mu_k)
            stick = app & (speed <= mu * dvn)
        scale = np.where(stick, 0.0, np.where(
            app & (speed > 0.0), 1.0 - mu * dvn / np.where(speed > 0.0, speed, 1.0), 1.0))
        scale = np.maximum(scale, 0.0)
        vt_new = scale[:, None] * vt
        x[hit] = xh + (vt_new - vt) * dt
        v[hit] = vt_new + vn_new[:, None] * nh
        slip[hit] = np.where(stick, 0.0, np.where(app, s + scale * speed * dt, s))


def touching(phi, v, vn, dt):
    """Whether a point that is ``phi`` [m] inside an obstacle after a step of ``dt`` at
    velocity ``v`` [m/s] (``vn``: its normal part) touched it at the step's start: its distance
    then, ``phi - vn dt``, within ``RESTING_SHARE`` of its step ``|v| dt`` (a point left on the
    surface by the last step's contact is there to round-off, or to the surface's curvature),
    or within ``RESTING_GAP``.
    Its contact is resting, not an impact: no restitution."""
    step = np.sqrt(np.einsum("ij,ij->i", v, v)) * dt
    return phi - vn * dt <= RESTING_SHARE * step + RESTING_GAP


RESTING_GAP = 1.0e-7
"""[m] See :func:`touching`: a start this close above the surface is touching whatever the step
(float32 positions of a 10 cm body round to ~1e-8 m)."""

RESTING_SHARE = 0.01
"""See :func:`touching`: how far above the surface, as a share of its step, a point may start
a step and still be in resting contact (a plane's round-off is ~1e-17 m; a sphere's curvature
puts a point sliding along it ``(|v_t| dt)^2 / 2R`` off, 2e-3 of the step at 1 m/s, dt = 1e-4
s, R = 3 cm)."""


def weakening(s, dc):
    """The static share ``1 - min(s / D_c, 1)`` of the friction coefficient after a slip ``s``
    [m] (``D_c = 0``: 1 at ``s = 0``, else 0)."""
    if dc > 0.0:
        return np.maximum(1.0 - s / dc, 0.0)
    return np.where(s > 0.0, 0.0, 1.0)


NO_SLIP = 1.0e30
"""A static coefficient above this is a no-slip surface (stored as infinity)."""

MAX_CONE_PASSES = 4
"""Solves per implicit step at most: the first, and again while the contact active set changes
(:func:`update_active_set`: lift-off, slip, stick, the sliding points' friction)."""

CONTACT_FREE = 0
"""Contact state of a point: no special state (constrained along the normal if touching)."""


CONTACT_RELEASED = 1
"""Its constraint pulled last step: left free for one step."""


CONTACT_STUCK = 2
"""Static friction held it last step: constrained in all three directions."""


def contact_normals(x, v, obstacle_kind, obstacle_data, margin, contact_state, dt, rest_speed,
                    springs, cnrm, cobs, offset):
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
    first_ptr, second_ptr = springs.first_ptr, springs.second_ptr
    cnrm[:] = 0.0
    cobs[:] = -1
    for o in range(obstacle_kind.shape[0]):
        phi, nrm = _contact_geometry(obstacle_kind[o], obstacle_data[o], x)
        vn = np.einsum("ij,ij->i", v, nrm)
        gap = phi + np.einsum("ij,ij->i", offset, nrm)
        # a stuck point stays a candidate whatever the sign of vn (round-off would free it);
        # the active set (update_active_set) releases it in the step if its constraint pulls
        hit = ((cobs < 0) & (gap + dt * np.minimum(vn, 0.0) <= margin)
               & ((vn <= 0.0) | (contact_state == CONTACT_STUCK))
               & (contact_state != CONTACT_RELEASED))
        cnrm[hit, 0:3] = nrm[hit]
        impact = np.where(-vn[hit] > rest_speed, -vn[hit], 0.0)
        free = (np.diff(first_ptr) + np.diff(second_ptr))[hit] == 0
        cnrm[hit, 3] = np.where((impact > 0.0) & free, obstacle_data[o, OBSTACLE_E] * impact,
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



FRICTION_REL_TOL = 1e-2
"""The active set of an implicit step is settled when no point changes state and no sliding
point's friction impulse changes by more than this fraction of its Coulomb bound."""


def update_active_set(v, dv, b, ap, mass, cnrm, cobs, obstacle_data, contact_state, friction):
    """Contact conditions inside an implicit step (one pass of its active-set iteration).

    With the constraint impulse ``J = A dv - b`` [kg m/s] of the solve just done (``b``
    includes ``friction`` (n, 3) [kg m/s], the kinetic friction the sliding points got in it):

    * a point whose constraint pulls it onto the surface (``J_n < 0``: it would leave) is
      released (``CONTACT_RELEASED``, no friction);
    * a point held stuck whose tangential impulse exceeds ``mu_s J_n`` (it would slip) slides:
      ``CONTACT_FREE``, friction ``mu_k J_n`` along ``J_t``;
    * a sliding point gets friction ``mu_k J_n`` against its new tangential velocity
      ``(v + dv)_t``; if the friction it had reversed that velocity, it sticks instead
      (``CONTACT_STUCK``: held inside the next solve; a point-local test, "the impulse that
      would stop this point", would stick the bottom of a sliding body too early, since the
      body above pushes it).  A point that kinetic friction slows without stopping may
      still stick after the solve on its static budget (:func:`constraint_friction`).

    The caller solves again while anything changed (a state, or a friction impulse by more
    than :data:`FRICTION_REL_TOL` of its bound).  Friction so acts on the whole body through
    the solve, bounded by Coulomb at every point, however few points carry the weight.
    Returns how many points changed."""
    on = np.nonzero(cobs >= 0)[0]
    if on.size == 0:
        return 0
    nrm = cnrm[on, 0:3]
    j = ap[on] - b[on]
    jn = np.einsum("ij,ij->i", j, nrm)
    jt = j - jn[:, None] * nrm
    jt_norm = np.sqrt(np.einsum("ij,ij->i", jt, jt))
    data = obstacle_data[cobs[on]]
    stuck = cnrm[on, 5] > 0.0
    vt = (v[on] + dv[on])
    vt = vt - np.einsum("ij,ij->i", vt, nrm)[:, None] * nrm
    speed = np.sqrt(np.einsum("ij,ij->i", vt, vt))
    old = friction[on].copy()
    bound = data[:, OBSTACLE_MU_K] * np.maximum(jn, 0.0)
    new = np.zeros_like(old)
    state = contact_state[on].copy()
    pulls = jn < 0.0
    state[pulls] = CONTACT_RELEASED
    slips = ~pulls & stuck & (jt_norm > data[:, OBSTACLE_MU_S] * jn)
    state[slips] = CONTACT_FREE
    new[slips] = bound[slips, None] * jt[slips] / np.where(jt_norm > 0, jt_norm, 1.0)[slips,
                                                                                      None]
    sliding = ~pulls & ~stuck
    reversed_ = sliding & (np.einsum("ij,ij->i", old, vt) > 0.0)
    state[reversed_] = CONTACT_STUCK
    go = sliding & ~reversed_ & (speed > 0.0)
    new[go] = -bound[go, None] * vt[go] / np.where(speed > 0, speed, 1.0)[go, None]
    moved = np.sqrt(np.einsum("ij,ij->i", new - old, new - old))
    changed = (state != contact_state[on]) | (moved > FRICTION_REL_TOL * bound + 1e-300)
    contact_state[on] = state
    friction[on] = new
    return int(changed.sum())


def constraint_friction(x, v, b, ap, mass, cnrm, cobs, obstacle_data, dt, contact_state,
                        friction):
    """Coulomb friction on the constrained points after an implicit step, in place on x, v,
    and their next ``contact_state``.

    The constraint impulse is ``J = A dv - b`` [kg m/s].  ``J_n < 0`` (the constraint pulled):
    the point is ``CONTACT_RELEASED`` next step.  A sticking point stays ``CONTACT_STUCK``
    while ``|J_t| <= mu_s J_n`` (static friction held it, inside the solve), else it slides
    from the next step.  A sliding point's tangential velocity is removed when
    ``|v_t| <= mu_s J_n / m`` (it sticks from the next step on), else reduced by
    ``mu_k J_n / m``; its position follows (``x += (v_t' - v_t) dt``).  The kinetic
    friction the point already got inside the solve (``friction`` (n, 3) [kg m/s],
    :func:`update_active_set`) is taken off that budget.
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
    used = np.sqrt(np.einsum("ij,ij->i", friction[on], friction[on])) / mass[on]
    vv = v[on]
    vn = np.einsum("ij,ij->i", vv, nrm)
    vt = vv - vn[:, None] * nrm
    speed = np.sqrt(np.einsum("ij,ij->i", vt, vt))
    stick = speed <= np.maximum(data[:, OBSTACLE_MU_S] * budget - used, 0.0)
    left = np.maximum(data[:, OBSTACLE_MU_K] * budget - used, 0.0)
    scale = np.where(stick | was_stuck, 0.0,
                     np.maximum(1.0 - left / np.where(speed > 0, speed, 1.0), 0.0))
    x[on] += ((scale - 1.0)[:, None] * vt) * dt
    v[on] = scale[:, None] * vt + vn[:, None] * nrm
    holds = np.where(was_stuck, jt_norm <= data[:, OBSTACLE_MU_S] * np.maximum(jn, 0.0), stick)
    contact_state[idx[holds]] = CONTACT_STUCK
    contact_state[idx[jn < 0.0]] = CONTACT_RELEASED
