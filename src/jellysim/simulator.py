"""Simulator: owns a Model, its State, the integrator choice and the corrections.

One step (see ARCHITECTURE in docs/architecture.md)::

    integrator       paper: x += v dt; v += a dt; a = F(x, v)/m   |  symplectic: a, v, x
    provot           strain limiting on springs or all pairs, Jacobi or Gauss-Seidel
    ground + check   the report's y = 0 ground, then non-finite / runaway detection

All of it runs inside one compiled call per batch of steps (``advance``); nothing is allocated
inside the loop.  The state is updated in place.
"""
from __future__ import annotations

import warnings

import numpy as np

from .errors import SceneError, SimulationError
from .kernels import INTEGRATOR_CODES, STATUS_NONFINITE, STATUS_OK, Backend, get_backend
from .params import (MAX_ALL_PAIRS_POINTS, GroundModel, GroundParams, ImplicitParams,
                     Integrator, ProvotOrder, ProvotPairs, ProvotParams)
from .stability import StabilityEstimate, estimate_stability

__all__ = ["Simulator", "StabilityWarning", "auto_threads"]

PARALLEL_MIN_POINTS = 500
"""Below this many points one thread is used.  From the paper scene's 600 points on, two
threads win on a quiet machine (about 20k vs 12k steps/s, BENCHMARKS.md); on a machine whose
cores are taken by other work they lose badly, so :func:`auto_threads` also counts the free
cores."""


class StabilityWarning(UserWarning):
    """The time step exceeds the estimated stable limit."""


def auto_threads(point_count: int) -> int:
    """Thread count used when none is given: 1 for small bodies; 1 on a heavily oversubscribed
    machine (1-minute load average above twice the CPU count); otherwise all of numba's
    threads.  With one busy process per core, passive-waiting threads keep a run within
    1.2-2.2x of its quiet speed (one thread: 2.9-3.4x); with a load average of 19 on 2 cores
    a second thread has to wait for a core at every parallel region and the paper scene ran 39
    steps/s on 2 threads, 3,244 on one (BENCHMARKS.md, "Contention")."""
    import os

    import numba

    if point_count < PARALLEL_MIN_POINTS:
        return 1
    most = numba.config.NUMBA_NUM_THREADS
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average on this platform
        return most
    return 1 if load > 2.0 * (os.cpu_count() or 1) else most


class Simulator:
    """Time-steps one :class:`~jellysim.model.Model`.

    Parameters
    ----------
    model: the body.
    dt: time step [s], > 0.
    integrator: :class:`~jellysim.params.Integrator`.
    provot, ground: correction options.
    backend: ``"numba"`` (default) or ``"numpy"`` (the reference).
    threads: numba threads (default: :func:`auto_threads`).  Results do not depend on it.
    runaway_distance: a point farther than this [m] from the body's starting centre stops the
        run (default: 100 x the body's bounding-box diagonal, at least 100 m).
    check_stability: estimate the stable dt now and warn (:class:`StabilityWarning`) if
        ``dt`` exceeds it.
    substeps: take this many steps of ``dt / substeps`` per step (``advance(n)`` still
        advances ``n dt``); the guard checks ``dt / substeps``.  The explicit integrators need
        it for stiff materials; the implicit one is stable without it but damps less with it.
    implicit: :class:`~jellysim.params.ImplicitParams` for ``integrator = "implicit"``.
    obstacles: static :class:`~jellysim.physics.contact.Plane` / ``Sphere`` / ``Box``
        obstacles with restitution and Coulomb friction (a ``GroundModel.CONTACT`` ground adds
        its plane to them).
    rest_speed: normal speed [m/s] under which a contact is resting (no bounce); default
        ``2 |g| dt`` (per substep).
    """

    def __init__(self, model, *, dt: float, integrator: Integrator | str = Integrator.SYMPLECTIC,
                 provot: ProvotParams = ProvotParams(enabled=False),
                 ground: GroundParams = GroundParams(enabled=False),
                 backend: Backend | str = Backend.NUMBA, threads: int | None = None,
                 runaway_distance: float | None = None, check_stability: bool = True,
                 state=None, substeps: int = 1, implicit: ImplicitParams = ImplicitParams(),
                 obstacles=(), rest_speed: float | None = None):
        if not (np.isfinite(dt) and dt > 0):
            raise SceneError(f"time step dt must be a positive number of seconds, got {dt}")
        self.model = model
        self.dt = float(dt)
        self.integrator = Integrator(integrator)
        self.provot = provot
        self.ground = ground
        self.substeps = int(substeps)
        if self.substeps < 1:
            raise SceneError(f"substeps must be an integer >= 1, got {substeps}")
        self.implicit = implicit
        if self.integrator is Integrator.IMPLICIT:
            if provot.enabled:
                raise SceneError("Provot strain limiting is a crutch of the explicit "
                                 "integrators and is not applied by integrator = 'implicit'; "
                                 "disable it ([provot] enabled = false)")
        self.obstacles = tuple(obstacles)
        if ground.enabled and GroundModel(ground.model) is GroundModel.CONTACT:
            from .physics.contact import Plane

            self.obstacles = (Plane(point=(0.0, ground.height, 0.0), normal=(0.0, 1.0, 0.0),
                                    restitution=ground.restitution, friction=ground.friction,
                                    static_friction=ground.static_friction),) + self.obstacles
        from .physics.contact import pack_obstacles

        try:
            self._obstacle_kind, self._obstacle_data = pack_obstacles(self.obstacles)
        except ValueError as exc:
            raise SceneError(str(exc)) from None
        self.dt_step = self.dt / self.substeps
        """The kernels' step [s]: ``dt / substeps``."""
        if rest_speed is None:
            rest_speed = 2.0 * float(np.linalg.norm(model.gravity)) * self.dt_step
        self.rest_speed = float(rest_speed)
        self.cg_iterations = 0
        """Conjugate-gradient iterations taken so far (implicit integrator)."""
        self.cg_worst_residual = 0.0
        """Largest relative residual a CG solve stopped at (implicit integrator)."""
        self.backend = Backend(backend)
        self._k = get_backend(self.backend)
        n = model.particle_count
        if provot.enabled and ProvotPairs(provot.pairs) is ProvotPairs.ALL and (
                n > MAX_ALL_PAIRS_POINTS):
            raise SceneError(
                f"provot pairs = 'all' is O(n^2) and limited to {MAX_ALL_PAIRS_POINTS} points; "
                f"this body has {n}. Use pairs = 'springs' (and a stiffer material) instead.")
        self.threads = auto_threads(n) if threads is None else int(threads)
        self.state = model.state() if state is None else state
        x0 = model.particle_x0
        self.center = np.ascontiguousarray(x0.mean(axis=0))
        if runaway_distance is None:
            diag = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
            runaway_distance = max(100.0 * diag, 100.0)
        self.runaway_distance = float(runaway_distance)
        k = model.spring_count
        # the backend interface (kernels/records.py): records built once, the drivers called
        # with them and the state arrays only
        from .kernels import records as rec

        self._springs = rec.spring_arrays(model)
        self._points = rec.point_arrays(model)
        p, g = provot, ground
        self._provot_opts = rec.provot_options(
            int(p.loops) if p.enabled else 0, p.tau, p.tolerance,
            ProvotPairs(p.pairs) is ProvotPairs.ALL,
            ProvotOrder(p.order) is ProvotOrder.GAUSS_SEIDEL, p.velocity_update)
        self._ground = rec.ground_guard(g.enabled and GroundModel(g.model) is GroundModel.PAPER,
                                        g.height, g.mu, g.nu, self.center,
                                        self.runaway_distance**2)
        self._obstacles = rec.obstacles(self._obstacle_kind, self._obstacle_data,
                                        self.rest_speed)
        if self.integrator is Integrator.IMPLICIT:
            im = implicit
            self._implicit_opts = rec.implicit_options(im.theta, im.tolerance,
                                                       im.max_iterations, im.scheme == "bdf2")
            self._scratch = rec.implicit_scratch(n, k)
            sc = self._scratch
            # dv, r, z, p, ap, diag, b; cnrm (normal, target speed, impact speed, stuck)
            self._cg = [sc.dv, sc.r, sc.z, sc.p, sc.ap, sc.diag, sc.b, sc.cnrm]
            self._cobs = sc.cobs
            self._contact_state = sc.contact_state
            # BDF2: previous x and v, two scratch arrays; points whose history restarts
            self._hist = sc.hist
            self._fresh = sc.fresh
            self._last = None  # (x, v) at the end of the last advance
            self._frame, self._spring_vec = sc.frame, sc.spring_vec
        else:
            self._scratch = rec.explicit_scratch(n, k)
            sc = self._scratch
            # the scratch arrays under their former names (other integration paths use them)
            self._dx, self._count, self._max_corr = sc.dx, sc.count, sc.max_corr
            self._x_pre, self._provot_scalar = sc.x_pre, sc.provot_scalar
        self._scalar = self._scratch.spring_scalar
        self.stability: StabilityEstimate | None = None
        if check_stability:
            self.check_stability()

    def check_stability(self) -> StabilityEstimate:
        """Estimate the largest stable dt; warn when ``dt`` exceeds it."""
        est = estimate_stability(self.model, self.integrator, self.dt_step,
                                 theta=self.implicit.theta,
                                 scheme=self.implicit.scheme)
        self.stability = est
        if self.dt_step > est.dt_max:
            hint = (f"use dt <= {0.9 * est.dt_max:.3g} s" if est.dt_max > 0
                    else "add damping or use integrator = 'symplectic'")
            held = ""
            if self.provot.enabled:
                held = (f"; Provot strain limiting (tau = {self.provot.tau:g}) bounds the "
                        "springs' stretch and may keep the run bounded anyway")
            if self.substeps > 1:
                hint = (f"use substeps >= {int(np.ceil(self.dt / (0.9 * est.dt_max)))}"
                        if est.dt_max > 0 else hint)
            warnings.warn(
                f"dt = {self.dt_step:g} s exceeds the estimated stable limit {est.dt_max:.3g} s "
                f"for the {self.integrator.value} integrator ({est.reason}; omega_max = "
                f"{est.omega_max:.3g} rad/s by {est.method}){held}: {hint}",
                StabilityWarning, stacklevel=2)
        return est

    def advance(self, steps: int = 1) -> None:
        """Take ``steps`` time steps.  Raises :class:`SimulationError` on blow-up, leaving
        the state as it was after the failing step."""
        if steps <= 0:
            return
        s = self.state
        import numba

        previous = numba.get_num_threads()
        numba.set_num_threads(max(1, min(self.threads, numba.config.NUMBA_NUM_THREADS)))
        try:
            if self.integrator is Integrator.IMPLICIT:
                done, status = self._advance_implicit(int(steps))
            else:
                done, status = self._advance_explicit(int(steps))
        finally:
            numba.set_num_threads(previous)
        s.step += int(done)
        s.t += int(done) * self.dt
        if status != STATUS_OK:
            self._raise(status)

    def _advance_implicit(self, steps):
        s = self.state
        sub = self.substeps
        bdf2 = self._implicit_opts.bdf2
        if bdf2 and self._last is not None and not (
                np.array_equal(self._last[0], s.x) and np.array_equal(self._last[1], s.v)):
            self._fresh[:] = 1  # the state was changed from outside: restart the history
        done, status, iters, worst = self._k.implicit_steps(
            steps * sub, self.dt_step, s.x, s.v, s.a, self._springs, self._points,
            self._ground, self._obstacles, self._implicit_opts, self._scratch)
        if bdf2:
            self._last = (s.x.copy(), s.v.copy())
        self.cg_iterations += int(iters)
        self.cg_worst_residual = max(self.cg_worst_residual, float(worst))
        return (done + sub - 1) // sub, status

    def _advance_explicit(self, steps):
        s = self.state
        sub = self.substeps
        done, status = self._k.run_steps(
            steps * sub, self.dt_step, INTEGRATOR_CODES[self.integrator.value], s.x, s.v, s.a,
            self._springs, self._points, self._provot_opts, self._ground, self._obstacles,
            self._scratch)
        # a failing substep counts its whole step
        return (done + sub - 1) // sub, status

    def _raise(self, status):
        m, s = self.model, self.state
        failed = s.step
        what = ("a position, velocity or acceleration became NaN/infinite"
                if status == STATUS_NONFINITE else
                f"a point flew more than {self.runaway_distance:g} m from the start")
        est = self.stability or estimate_stability(m, self.integrator, self.dt_step,
                                                   theta=self.implicit.theta,
                                                   scheme=self.implicit.scheme)
        if self.integrator is Integrator.IMPLICIT:
            hint = ("the implicit step is linearised: try a smaller dt, theta closer to 1 "
                    "or a tighter CG tolerance")
        elif est.dt_max > 0:
            hint = f"try dt <= {0.5 * min(self.dt_step, est.dt_max):.3g} s"
        else:
            hint = "add damping or use integrator = 'symplectic'"
        raise SimulationError(
            f"simulation went unstable at step {failed} (t = {s.t:.6g} s): {what}; "
            f"{hint} (estimated stable limit {est.dt_max:.3g} s)", step=failed,
            status=int(status))
