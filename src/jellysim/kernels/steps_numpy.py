"""Numpy (the spec): the explicit step drivers (report order and symplectic Euler)."""
from __future__ import annotations

import numpy as np

from . import STATUS_OK
from .contact_numpy import contact, finish_step
from .forces_numpy import accelerations
from .provot_numpy import provot


def run_steps(nsteps, dt, integrator, x, v, a, springs, points, provot_opts, ground,
              obstacles, scratch):
    """Advance ``nsteps`` steps of size ``dt`` [s] in place on x [m], v [m/s], a [m/s^2]
    (n, 3).

    One step (``integrator`` 0 = paper, 1 = symplectic):

    * paper: ``x += v dt; v += a dt; a = F(x, v) / m`` (report section 4.1);
    * symplectic: ``a = F(x, v) / m; v += a dt; x += v dt``;

    then ``provot_opts.loops`` Provot passes (if > 0; with ``velocity_update`` the total
    correction / dt is added to v), then :func:`contact` with the obstacles (if any), then
    :func:`finish_step` with ``ground``.  Records: ``springs``
    :class:`~.records.SpringArrays`, ``points`` :class:`~.records.PointArrays`,
    ``provot_opts`` :class:`~.records.ProvotOptions`, ``ground``
    :class:`~.records.GroundGuard`, ``obstacles`` :class:`~.records.Obstacles`, ``scratch``
    :class:`~.records.ExplicitScratch`.  Returns ``(steps_done, status)``: on a non-zero
    status, ``steps_done`` counts the steps completed including the failing one.
    """
    po, g = provot_opts, ground
    x_pre, spring_scalar = scratch.x_pre, scratch.spring_scalar
    save = po.loops > 0 and po.velocity_update
    for step in range(nsteps):
        if integrator == 0:
            x += v * dt
            v += a * dt
            if save:
                x_pre[:] = x
            accelerations(x, v, points, springs, spring_scalar, a)
        else:
            accelerations(x, v, points, springs, spring_scalar, a)
            v += a * dt
            x += v * dt
            if save:
                x_pre[:] = x
        if po.loops > 0:
            provot(x, points, springs, po.tau, po.loops, po.tolerance, po.all_pairs,
                   po.gauss_seidel, scratch)
            if po.velocity_update:
                v += (x - x_pre) / dt
        if obstacles.kind.shape[0] > 0:
            contact(x, v, obstacles.kind, obstacles.data, obstacles.rest_speed, dt, obstacles.slip)
        status = finish_step(x, v, a, g.paper, g.height, g.mu, g.nu, g.center, g.bound2)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK
