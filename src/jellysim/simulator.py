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
from .params import (MAX_ALL_PAIRS_POINTS, GroundParams, Integrator, ProvotOrder,
                     ProvotPairs, ProvotParams)
from .stability import StabilityEstimate, estimate_stability

__all__ = ["Simulator", "StabilityWarning", "auto_threads"]

PARALLEL_MIN_POINTS = 20_000
"""Below this many points one thread is faster (thread start-up costs more than the work)."""


class StabilityWarning(UserWarning):
    """The time step exceeds the estimated stable limit."""


def auto_threads(point_count: int) -> int:
    """Thread count used when none is given: 1 for small bodies, all cores otherwise."""
    import numba

    return 1 if point_count < PARALLEL_MIN_POINTS else numba.config.NUMBA_NUM_THREADS


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
    """

    def __init__(self, model, *, dt: float, integrator: Integrator | str = Integrator.SYMPLECTIC,
                 provot: ProvotParams = ProvotParams(enabled=False),
                 ground: GroundParams = GroundParams(enabled=False),
                 backend: Backend | str = Backend.NUMBA, threads: int | None = None,
                 runaway_distance: float | None = None, check_stability: bool = True,
                 state=None):
        if not (np.isfinite(dt) and dt > 0):
            raise SceneError(f"time step dt must be a positive number of seconds, got {dt}")
        self.model = model
        self.dt = float(dt)
        self.integrator = Integrator(integrator)
        self.provot = provot
        self.ground = ground
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
        self._scalar = np.zeros(k)
        self._dx = np.zeros((n, 3))
        self._count = np.zeros(n, dtype=np.int64)
        self._max_corr = np.zeros(n)
        self._x_pre = np.zeros((n, 3))
        self._provot_scalar = np.zeros(k)
        self.stability: StabilityEstimate | None = None
        if check_stability:
            self.check_stability()

    def check_stability(self) -> StabilityEstimate:
        """Estimate the largest stable dt; warn when ``dt`` exceeds it."""
        est = estimate_stability(self.model, self.integrator, self.dt)
        self.stability = est
        if self.dt > est.dt_max:
            hint = (f"use dt <= {0.9 * est.dt_max:.3g} s" if est.dt_max > 0
                    else "add damping or use integrator = 'symplectic'")
            held = ""
            if self.provot.enabled:
                held = (f"; Provot strain limiting (tau = {self.provot.tau:g}) bounds the "
                        "springs' stretch and may keep the run bounded anyway")
            warnings.warn(
                f"dt = {self.dt:g} s exceeds the estimated stable limit {est.dt_max:.3g} s "
                f"for the {self.integrator.value} integrator ({est.reason}; omega_max = "
                f"{est.omega_max:.3g} rad/s by {est.method}){held}: {hint}",
                StabilityWarning, stacklevel=2)
        return est

    def advance(self, steps: int = 1) -> None:
        """Take ``steps`` time steps.  Raises :class:`SimulationError` on blow-up, leaving
        the state as it was after the failing step."""
        if steps <= 0:
            return
        m = self.model
        p = self.provot
        g = self.ground
        s = self.state
        import numba

        previous = numba.get_num_threads()
        numba.set_num_threads(max(1, min(self.threads, numba.config.NUMBA_NUM_THREADS)))
        try:
            done, status = self._k.run_steps(
                int(steps), self.dt, INTEGRATOR_CODES[self.integrator.value], s.x, s.v, s.a,
                m.particle_x0, m.particle_inv_mass, m.damping, m.gravity,
                m.spring_ij, m.spring_rest_length, m.spring_stiffness, m.point_first_ptr,
                m.point_second_ptr, m.spring_second_slot, m.point_second_other,
                int(p.loops) if p.enabled else 0, float(p.tau), float(p.tolerance),
                ProvotPairs(p.pairs) is ProvotPairs.ALL,
                ProvotOrder(p.order) is ProvotOrder.GAUSS_SEIDEL, bool(p.velocity_update),
                bool(g.enabled), float(g.height), float(g.mu), float(g.nu),
                self.center, self.runaway_distance**2,
                self._scalar, self._dx, self._count, self._max_corr, self._x_pre,
                self._provot_scalar)
        finally:
            numba.set_num_threads(previous)
        s.step += int(done)
        s.t += int(done) * self.dt
        if status != STATUS_OK:
            failed = s.step
            what = ("a position, velocity or acceleration became NaN/infinite"
                    if status == STATUS_NONFINITE else
                    f"a point flew more than {self.runaway_distance:g} m from the start")
            est = self.stability or estimate_stability(m, self.integrator, self.dt)
            hint = (f"try dt <= {0.5 * min(self.dt, est.dt_max):.3g} s" if est.dt_max > 0 else
                    "add damping or use integrator = 'symplectic'")
            raise SimulationError(
                f"simulation went unstable at step {failed} (t = {s.t:.6g} s): {what}; "
                f"{hint} (estimated stable limit {est.dt_max:.3g} s)", step=failed,
                status=int(status))
