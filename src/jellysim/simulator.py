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
from .stability import StabilityEstimate, estimate_stability, implicit_accuracy

__all__ = ["Simulator", "StabilityWarning", "SolverWarning", "auto_threads"]

PARALLEL_MIN_POINTS = 500
"""Below this many points one thread is used.  From the paper scene's 600 points on, two
threads win on a quiet machine (about 20k vs 12k steps/s, BENCHMARKS.md); on a machine whose
other core is busy they can lose badly: pass ``threads=1`` there."""


class StabilityWarning(UserWarning):
    """The time step exceeds the estimated stable limit."""


class SolverWarning(UserWarning):
    """A linear solve stopped above its tolerance (see :data:`CG_ERROR_RESIDUAL`)."""


CG_ERROR_RESIDUAL = 0.1
"""A conjugate-gradient solve that stops with a relative residual above this is an error
(:class:`SimulationError`); above the tolerance but below this, a :class:`SolverWarning`."""

COLLAPSE_FRACTION = 0.02
"""One :meth:`Simulator.advance` call that shrinks the body's thickness (smallest principal
spread of its points) below this fraction of its rest value is a blow-up (e.g. an implicit
step far too large for the material, which flattens the body in one step)."""

COLLAPSE_MIN_POINTS = 20
"""Bodies with fewer points (or thin at rest: sheets, rods) are not checked for collapse."""

STATUS_NOT_CONVERGED = 101
"""``SimulationError.status`` of a solve that did not converge (not a kernel code)."""
STATUS_COLLAPSE = 102
"""``SimulationError.status`` of a body that collapsed in one call (not a kernel code)."""


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
        self.cg_unconverged = 0
        """Advance calls in which a CG solve stopped above its tolerance (implicit)."""
        self._last_worst = 0.0
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
        spread = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(x0, rowvar=False)), 0.0)) if (
            n >= COLLAPSE_MIN_POINTS) else np.zeros(3)
        self._rest_thin = float(spread[0])
        self._collapse_check = bool(n >= COLLAPSE_MIN_POINTS and spread[0] > 0.1 * spread[2])
        k = model.spring_count
        self._scalar = np.zeros(k)
        self._dx = np.zeros((n, 3))
        self._count = np.zeros(n, dtype=np.int64)
        self._max_corr = np.zeros(n)
        self._x_pre = np.zeros((n, 3))
        self._provot_scalar = np.zeros(k)
        if self.integrator is Integrator.IMPLICIT:
            self._frame = np.zeros((k, 5))
            self._spring_vec = np.zeros((k, 3))
            self._cg = [np.zeros((n, 3)) for _ in range(7)]  # dv, r, z, p, Ap, diag, b
            self._cg.append(np.zeros((n, 6)))  # normal, target speed, impact speed, stuck
            self._cobs = np.full(n, -1, dtype=np.int64)
            self._contact_state = np.zeros(n, dtype=np.int8)
            # BDF2: previous x and v, two scratch arrays; points whose history restarts
            self._hist = np.zeros((4, n, 3))
            self._fresh = np.ones(n, dtype=np.uint8)
            self._last = None  # (x, v) at the end of the last advance
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

    _COUNTERS = ("cg_iterations", "cg_worst_residual", "cg_unconverged")

    def internal_state(self) -> dict[str, np.ndarray]:
        """Every private array the simulator keeps between :meth:`advance` calls, copied.

        Collected generically: each ``numpy`` array attribute whose name starts with ``_``
        (``_hist``, ``_fresh``, ``_contact_state``, ``_cg``'s warm start and scratch...), each
        list/tuple of arrays as ``name.i`` (``_cg.0``), ``_last`` when set, and the CG counters.
        A new private array is therefore checkpointed without touching this method.  With
        :attr:`state` (x, v, a, t, step) it is everything a bitwise resume needs."""
        out: dict[str, np.ndarray] = {}
        for name, value in vars(self).items():
            if not name.startswith("_"):
                continue
            if isinstance(value, np.ndarray):
                out[name] = value.copy()
            elif isinstance(value, (list, tuple)) and value and all(
                    isinstance(v, np.ndarray) for v in value):
                for i, v in enumerate(value):
                    out[f"{name}.{i}"] = v.copy()
        for name in self._COUNTERS:
            out[name] = np.array(getattr(self, name))
        return out

    def restore_internal_state(self, d) -> None:
        """Inverse of :meth:`internal_state`: copy the arrays back in place.  Raises
        :class:`SceneError` when ``d`` does not fit this simulator (another body or
        integrator)."""
        own = self.internal_state()
        missing = sorted(set(own) - set(d) - {"_last.0", "_last.1"})
        extra = sorted(set(d) - set(own) - {"_last.0", "_last.1"})
        if missing or extra:
            raise SceneError(f"saved simulator state does not fit this simulator (missing "
                             f"{missing}, unexpected {extra}): same scene and integrator?")
        for key in own:
            if key in self._COUNTERS:
                continue
            if key.startswith("_last."):
                continue
            if own[key].shape != np.shape(d[key]) or own[key].dtype != np.asarray(d[key]).dtype:
                raise SceneError(f"saved simulator state '{key}' has shape "
                                 f"{np.shape(d[key])}, expected {own[key].shape}")
        for key in own:
            if key in self._COUNTERS or key.startswith("_last."):
                continue
            name, _, i = key.partition(".")
            target = getattr(self, name)[int(i)] if i else getattr(self, name)
            np.copyto(target, d[key])
        if "_last" in vars(self):
            self._last = ((np.array(d["_last.0"]), np.array(d["_last.1"]))
                          if "_last.0" in d else None)
        self.cg_iterations = int(d["cg_iterations"])
        self.cg_worst_residual = float(d["cg_worst_residual"])
        self.cg_unconverged = int(d["cg_unconverged"])

    def advance(self, steps: int = 1) -> None:
        """Take ``steps`` time steps.  Raises :class:`SimulationError` on blow-up, leaving
        the state as it was after the failing step."""
        if steps <= 0:
            return
        s = self.state
        thin_before = self._thinness(s.x) if self._collapse_check else None
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
        self._check_collapse(thin_before, int(done))
        if self.integrator is Integrator.IMPLICIT:
            self._check_solves()

    @staticmethod
    def _thinness(x) -> float:
        """The body's smallest principal standard deviation [m] (its thinnest direction)."""
        c = np.cov(x, rowvar=False)
        return float(np.sqrt(max(np.linalg.eigvalsh(c)[0], 0.0)))

    def _check_collapse(self, before, steps) -> None:
        """A 3D body (>= COLLAPSE_MIN_POINTS points, not thin at rest) whose thinnest
        direction shrinks below COLLAPSE_FRACTION of its rest value within one call, having
        been above a quarter of it before the call, collapsed: a blow-up."""
        if before is None or steps <= 0 or before < 0.25 * self._rest_thin:
            return
        after = self._thinness(self.state.x)
        if after >= COLLAPSE_FRACTION * self._rest_thin:
            return
        s = self.state
        if self.integrator is Integrator.IMPLICIT:
            est = self.stability or estimate_stability(
                self.model, self.integrator, self.dt_step, theta=self.implicit.theta,
                scheme=self.implicit.scheme)
            _, _, words = implicit_accuracy(est.omega_max, self.dt_step,
                                            theta=self.implicit.theta,
                                            scheme=self.implicit.scheme)
            fix = (f"the step is far too large for this material ({words}): use a smaller dt "
                   "or [integrator] substeps (omega_max dt below about 1)")
        else:
            fix = ("the forces are far too strong for this dt or the body too soft: check "
                   "[physics] gravity and the stiffness, or use a smaller dt")
        raise SimulationError(
            f"the body collapsed at step {s.step} (t = {s.t:.6g} s): its thickness (smallest "
            f"principal spread) went from {before:.4g} m to {after:.4g} m within {steps} "
            f"step(s), {self._rest_thin:.4g} m at rest; {fix}", step=s.step,
            status=STATUS_COLLAPSE)

    def _check_solves(self) -> None:
        worst = self._last_worst
        tol = float(self.implicit.tolerance)
        if not worst > tol * (1 + 1e-9):
            return
        s = self.state
        fix = (f"raise [integrator] cg_max_iterations (now {self.implicit.max_iterations}), "
               "or use a smaller dt (fewer iterations needed); if neither helps, check the "
               "material (Young's modulus, masses): the system may be ill-conditioned")
        what = (f"a conjugate-gradient solve stopped at relative residual {worst:.3g} "
                f"(tolerance {tol:g}) after {self.implicit.max_iterations} iterations")
        if worst > CG_ERROR_RESIDUAL:
            raise SimulationError(f"{what} by step {s.step} (t = {s.t:.6g} s): the step is "
                                  f"not solved; {fix}", step=s.step,
                                  status=STATUS_NOT_CONVERGED)
        self.cg_unconverged += 1
        if self.cg_unconverged == 1:
            warnings.warn(f"{what} by step {s.step} (t = {s.t:.6g} s); {fix} (later ones are "
                          "counted in Simulator.cg_unconverged)", SolverWarning, stacklevel=3)

    def _advance_implicit(self, steps):
        m, g, s, im = self.model, self.ground, self.state, self.implicit
        paper = g.enabled and GroundModel(g.model) is GroundModel.PAPER
        dv, r, z, p, ap, diag, b, cnrm = self._cg
        sub = self.substeps
        bdf2 = im.scheme == "bdf2"
        if bdf2 and self._last is not None and not (
                np.array_equal(self._last[0], s.x) and np.array_equal(self._last[1], s.v)):
            self._fresh[:] = 1  # the state was changed from outside: restart the history
        done, status, iters, worst = self._k.implicit_steps(
            steps * sub, self.dt_step, float(im.theta), float(im.tolerance),
            int(im.max_iterations),
            s.x, s.v, s.a, m.particle_inv_mass, m.damping, m.gravity, m.spring_ij,
            m.spring_rest_length, m.spring_stiffness, m.point_first_ptr, m.point_second_ptr,
            m.spring_second_slot, m.point_second_other, paper, float(g.height), float(g.mu),
            float(g.nu), self._obstacle_kind, self._obstacle_data, self.rest_speed,
            self.center, self.runaway_distance**2, self._scalar, self._frame,
            self._spring_vec, dv, r, z, p, ap, diag, b, cnrm, m.particle_mass, self._cobs,
            self._contact_state, bdf2, self._hist, self._fresh)
        if bdf2:
            self._last = (s.x.copy(), s.v.copy())
        self.cg_iterations += int(iters)
        self._last_worst = float(worst)
        self.cg_worst_residual = max(self.cg_worst_residual, float(worst))
        return (done + sub - 1) // sub, status

    def _advance_explicit(self, steps):
        m, p, g, s = self.model, self.provot, self.ground, self.state
        paper = g.enabled and GroundModel(g.model) is GroundModel.PAPER
        sub = self.substeps
        done, status = self._k.run_steps(
            steps * sub, self.dt_step, INTEGRATOR_CODES[self.integrator.value], s.x, s.v, s.a,
            m.particle_x0, m.particle_inv_mass, m.damping, m.gravity,
            m.spring_ij, m.spring_rest_length, m.spring_stiffness, m.point_first_ptr,
            m.point_second_ptr, m.spring_second_slot, m.point_second_other,
            int(p.loops) if p.enabled else 0, float(p.tau), float(p.tolerance),
            ProvotPairs(p.pairs) is ProvotPairs.ALL,
            ProvotOrder(p.order) is ProvotOrder.GAUSS_SEIDEL, bool(p.velocity_update),
            paper, float(g.height), float(g.mu), float(g.nu),
            self._obstacle_kind, self._obstacle_data, self.rest_speed,
            self.center, self.runaway_distance**2,
            self._scalar, self._dx, self._count, self._max_corr, self._x_pre,
            self._provot_scalar)
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
            _, _, words = implicit_accuracy(est.omega_max, self.dt_step,
                                            theta=self.implicit.theta,
                                            scheme=self.implicit.scheme)
            raise SimulationError(
                f"simulation went unstable at step {failed} (t = {s.t:.6g} s): {what}; the "
                "implicit step is linearised: try a smaller dt, theta closer to 1 or a tighter "
                f"CG tolerance ({words})", step=failed, status=int(status))
        if est.dt_max > 0:
            hint = f"try dt <= {0.5 * min(self.dt_step, est.dt_max):.3g} s"
        else:
            hint = "add damping or use integrator = 'symplectic'"
        raise SimulationError(
            f"simulation went unstable at step {failed} (t = {s.t:.6g} s): {what}; "
            f"{hint} (estimated stable limit {est.dt_max:.3g} s)", step=failed,
            status=int(status))
