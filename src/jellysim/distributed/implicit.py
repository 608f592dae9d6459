"""The implicit integrator over MPI ranks: matrix-free conjugate gradients, distributed.

The serial step is :func:`jellysim.kernels.implicit_numba.implicit_steps` (theta-method or
BDF2, Jacobi-preconditioned CG, contact constraints inside the solve).  This driver runs the
same numba pieces, in the same order, on one rank's local Model (owned points + one ghost
layer of the spring graph, global relative order kept, :mod:`.local`):

* every per-point operation (right-hand side, preconditioner, constraint filters, updates,
  contact, the ground) runs on the local points as serially;
* a **matrix-vector product** reads neighbours: the ghost rows of its input vector are
  refreshed from their owners first (``Isend``/``Irecv``, 24 bytes per ghost point); its
  owned rows are then the serial ones, in the serial summation order;
* a **dot product** (or any body-wide sum: the net-residual projection) is summed over the
  owned points, then over the ranks (:meth:`~.fem.PhysicalMethods._global_sum`, the same
  value on every rank, so every rank stops the CG loop at the same iteration);
* body-wide minima / maxima (the diagonal's sign, "any point in contact") by ``Allreduce``;
* after each step the x, v, a of the ghosts are refreshed and the run status agreed, as for
  the explicit integrators.

The dot products add in another order than the serial loop, so results agree with the serial
run to the CG tolerance, not bitwise.
"""
from __future__ import annotations

import time

import numpy as np
from numba import njit

from ..kernels import STATUS_OK
from ..kernels import implicit_numba as K
from ..kernels.contact_numba import (constrain_start, constraint_friction, contact,
                                     contact_normals, filter_constrained, finish_step,
                                     update_active_set)
from ..kernels.contact_numpy import MAX_CONE_PASSES
from ..kernels.forces_numba import accelerations

__all__ = ["implicit_steps_distributed"]


@njit(cache=True)
def _owned_dots(a, b, c, d, owned):
    """(sum a.b, sum c.d) over the owned rows, in local order."""
    s = 0.0
    t = 0.0
    for i in range(owned.shape[0]):
        p = owned[i]
        for k in range(3):
            s += a[p, k] * b[p, k]
            t += c[p, k] * d[p, k]
    return s, t


@njit(cache=True)
def _owned_residual_sums(b, ap, mass, shift, owned):
    """[sum (m + shift), sum (b - ap) per axis] over the owned rows."""
    out = np.zeros(4)
    for i in range(owned.shape[0]):
        q = owned[i]
        out[0] += mass[q] + shift[q]
        for k in range(3):
            out[1 + k] += b[q, k] - ap[q, k]
    return out


@njit(cache=True)
def _shift_all(dv, s):
    for q in range(dv.shape[0]):
        for k in range(3):
            dv[q, k] += s[k]


class _Comm:
    """The collective pieces of one rank's solve."""

    def __init__(self, sim):
        self.sim, self.owned = sim, sim.part.owned_local
        part = sim.part
        self.send = {r: np.empty((len(i), 3)) for r, i in part.send.items()}
        self.recv = {r: np.empty((len(i), 3)) for r, i in part.recv.items()}

    def refresh(self, u):
        """Ghost rows of ``u`` (local, shape (n, 3)) from their owners."""
        from mpi4py import MPI

        t0 = time.perf_counter()
        sim, part = self.sim, self.sim.part
        reqs = [sim.comm.Irecv(buf, source=r, tag=11) for r, buf in self.recv.items()]
        for r, idx in part.send.items():
            buf = self.send[r]
            np.take(u, idx, axis=0, out=buf)
            reqs.append(sim.comm.Isend(buf, dest=r, tag=11))
            sim.halo_bytes += buf.nbytes
        MPI.Request.Waitall(reqs)
        for r, idx in part.recv.items():
            u[idx] = self.recv[r]
        sim.comm_seconds += time.perf_counter() - t0

    def dots(self, a, b, c=None, d=None):
        c = a if c is None else c
        d = b if d is None else d
        local = np.array(_owned_dots(a, b, c, d, self.owned))
        t0 = time.perf_counter()
        s = self.sim._global_sum(local)
        self.sim.comm_seconds += time.perf_counter() - t0
        return float(s[0]), float(s[1])

    def reduce(self, value, op):
        from mpi4py import MPI

        t0 = time.perf_counter()
        buf = np.array([value], dtype=np.float64)
        self.sim.comm.Allreduce(MPI.IN_PLACE, buf, op=MPI.MIN if op == "min" else MPI.MAX)
        self.sim.comm_seconds += time.perf_counter() - t0
        return float(buf[0])


def implicit_steps_distributed(sim, nsteps, dt):
    """``nsteps`` implicit steps of ``dt`` [s] of the rank's local Simulator ``sim.local``
    (its records and scratch); a collective call.  Returns ``(steps done, status,
    CG iterations, worst relative residual)`` like the serial kernel, the same on every rank."""
    loc = sim.local
    s = loc.state
    x, v, a = s.x, s.v, s.a
    springs, points, g, obstacles = loc._springs, loc._points, loc._ground, loc._obstacles
    options, sc = loc._implicit_opts, loc._scratch
    theta, tol, max_iter, bdf2 = (options.theta, options.tolerance, options.max_iterations,
                                  options.bdf2)
    mass, damping = points.mass, points.damping
    kinds, data, rest_speed = obstacles.kind, obstacles.data, obstacles.rest_speed
    frame, spring_vec, dv, r, z, p, ap, diag, b = (sc.frame, sc.spring_vec, sc.dv, sc.r, sc.z,
                                                   sc.p, sc.ap, sc.diag, sc.b)
    cnrm, cobs, contact_state, hist, fresh = (sc.cnrm, sc.cobs, sc.contact_state, sc.hist,
                                              sc.fresh)
    cm = _Comm(sim)
    owned = cm.owned
    h = 2.0 * dt / 3.0 if bdf2 else theta * dt
    h2 = h * h
    n = mass.shape[0]
    shift = np.full(n, h * damping)
    zero = np.zeros(n)
    iters = 0
    worst = 0.0

    def matvec(u, sh, hh):
        cm.refresh(u)
        K.system_matvec(u, mass, sh, hh, springs, frame, spring_vec, ap)

    for step in range(nsteps):
        accelerations(x, v, points, springs, sc.spring_scalar, a)
        bnorm = 0.0
        res = 0.0
        # Coulomb inside the step: the serial kernel's active set (update_active_set), the
        # number of passes agreed by all ranks
        sc.friction[:] = 0.0
        for cone_pass in range(MAX_CONE_PASSES):
            for attempt in range(2):
                clip = attempt == 1
                K.spring_frames(x, springs, frame, clip)
                K.system_diagonal(mass, shift, h2, springs, frame, diag)
                if not clip and cm.reduce(diag[owned].min() if owned.size else np.inf,
                                          "min") <= 0.0:
                    continue
                if bdf2:
                    K._bdf2_start(x, v, a, hist[0], hist[1], fresh, hist[2], dt, h)
                    matvec(hist[2], zero, 1.0)
                    K._bdf2_rhs(b, ap, mass, a, v, hist[1], hist[2], h)
                    K._bdf2_offset(hist[3], x, hist[0])
                else:
                    matvec(v, zero, 1.0)
                    K._implicit_rhs(b, ap, mass, a, v, dt, h)
                K._add(b, sc.friction)
                contact_normals(x, v, kinds, data, 1e-9, contact_state, h if bdf2 else dt,
                                rest_speed, springs, cnrm, cobs, hist[3])
                if clip:
                    dv[:] = 0.0
                constrain_start(dv, v, cnrm)
                bnorm = np.sqrt(cm.dots(b, b)[0])
                matvec(dv, shift, h2)
                K._residual(r, b, ap)
                filter_constrained(r, cnrm)
                K._precondition(z, r, diag)
                filter_constrained(z, cnrm)
                K._copy(p, z)
                rz, rr = cm.dots(r, z, r, r)
                res = np.sqrt(rr)
                it = 0
                broke = False
                while it < max_iter and res > tol * bnorm:
                    matvec(p, shift, h2)
                    filter_constrained(ap, cnrm)
                    pap = cm.dots(p, ap)[0]
                    if pap <= 0.0:
                        broke = True
                        break
                    alpha = rz / pap
                    K._axpy_pair(dv, r, p, ap, alpha)
                    K._precondition(z, r, diag)
                    filter_constrained(z, cnrm)
                    rz_new, rr = cm.dots(r, z, r, r)
                    K._update_direction(p, z, rz_new / rz)
                    rz = rz_new
                    res = np.sqrt(rr)
                    it += 1
                iters += it
                if not broke:
                    break
            if kinds.shape[0] == 0 or cone_pass == MAX_CONE_PASSES - 1:
                break
            matvec(dv, shift, h2)
            changed = update_active_set(v, dv, b, ap, mass, cnrm, cobs, data, contact_state,
                                        sc.friction)
            if cm.reduce(changed, "max") == 0:
                break
        if bnorm > 0.0:
            worst = max(worst, res / bnorm)
        if cm.reduce(cobs[owned].max() if owned.size else -1, "max") < 0:
            # free flight: project the solve's net residual out (a body-wide sum)
            matvec(dv, shift, h2)
            sums = sim._global_sum(_owned_residual_sums(b, ap, mass, shift, owned))
            _shift_all(dv, sums[1:] / sums[0])
        if bdf2:
            K._bdf2_update(x, v, a, dv, hist[0], hist[1], hist[2], dt, h)
            K._bdf2_contact_velocity(v, x, hist[0], cnrm, cobs, dt, springs)
            K._copy(hist[3], v)
        else:
            K._implicit_update(x, v, a, dv, dt, theta)
        if kinds.shape[0] > 0:
            matvec(dv, shift, h2)
            constraint_friction(x, v, b, ap, mass, cnrm, cobs, data, h if bdf2 else dt,
                                contact_state, sc.friction)
            contact(x, v, kinds, data, rest_speed, dt, obstacles.slip)
        finish_step(x, v, a, g.paper, g.height, g.mu, g.nu, g.center, g.bound2)
        status = sim.part.owned_status(s, g.center, g.bound2)
        if bdf2:
            K._bdf2_mark(fresh, cobs, x, v, hist[2], hist[3])
        status = sim._agree(status)  # and the ghosts' x, v, a
        if status != STATUS_OK:
            return step + 1, status, iters, worst
    return nsteps, STATUS_OK, iters, worst
