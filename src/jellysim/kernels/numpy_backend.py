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
              ground, height, mu, nu, center, bound2,
              spring_scalar, dx, count, max_corr, x_pre, provot_scalar):
    """Advance ``nsteps`` steps of size ``dt`` [s] in place on x, v, a.

    One step (``integrator`` 0 = paper, 1 = symplectic):

    * paper: ``x += v dt; v += a dt; a = F(x, v) / m`` (report section 4.1);
    * symplectic: ``a = F(x, v) / m; v += a dt; x += v dt``;

    then ``provot_loops`` Provot passes (if > 0; with ``velocity_update`` the total
    correction / dt is added to v), then :func:`finish_step`.  ``provot_scalar`` (k,) is
    scratch for the numba backend's fused force + first Provot pass (paper order).  Returns ``(steps_done, status)``:
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
        status = finish_step(x, v, a, ground, height, mu, nu, center, bound2)
        if status != STATUS_OK:
            return step + 1, status
    return nsteps, STATUS_OK
