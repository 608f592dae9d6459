"""Simulator: owns a Model, its State, the integrator choice and the corrections.

One step (see ARCHITECTURE in docs/architecture.md)::

    integrator       paper: x += v dt; v += a dt; a = F(x, v)/m   |  symplectic: a, v, x
    provot           strain limiting on springs or all pairs, Jacobi or Gauss-Seidel
    ground + check   the report's y = 0 ground, then non-finite / runaway detection

All of it runs inside one compiled call per batch of steps (``advance``); nothing is allocated
inside the loop.  The state is updated in place.
"""
from __future__ import annotations

import time
import warnings

import numpy as np

from .errors import SceneError, SimulationError, SolverWarning, StabilityWarning
from .kernels import (INTEGRATOR_CODES, STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY, Backend,
                      get_backend)
from .params import (MAX_ALL_PAIRS_POINTS, GroundModel, GroundParams, ImplicitParams,
                     ImplicitScheme, Integrator, ProvotOrder, ProvotPairs, ProvotParams)
from .handles import HandleMethods
from .physical_stepping import PhysicalStepping, blowup_error, travel_error
from .sim_control import Control
from .sim_state import InternalState
from .physics.contact import start_checks
from .stability import (MAX_AUTO_SUBSTEPS, StabilityEstimate, estimate_stability,  # noqa: F401
                        implicit_accuracy, springs_auto_substeps)
from ._interrupts import Deferred
from .state import check_state, clock
from . import thread_choice
from .thread_choice import (PARALLEL_MIN_POINTS, PARALLEL_MIN_SPRINGS,  # noqa: F401
                           PHYSICAL_PARALLEL_MIN_TETS, auto_threads)

__all__ = ["Simulator", "StabilityWarning", "SolverWarning", "auto_threads",
           "springs_auto_substeps"]

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


def _usable_threads(threads: int, backend) -> int:
    """``threads`` capped at numba's pool (``NUMBA_NUM_THREADS``, by default the cores), said
    (by rank 0 under mpiexec): ``Simulator.threads`` is what the steps use."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise SceneError(f"threads must be an integer >= 1 (or None: by size), got {threads!r}")
    threads = int(threads)
    import numba

    from ._numba_cache import _rank

    most = int(numba.config.NUMBA_NUM_THREADS)
    if backend is Backend.NUMBA and threads > most and _rank() == "0":
        warnings.warn(f"threads = {threads}: numba runs at most {most} here (NUMBA_NUM_THREADS, "
                      f"by default the cores); using {most}", stacklevel=3)
    return min(threads, most) if backend is Backend.NUMBA else threads




class Simulator(HandleMethods, PhysicalStepping, InternalState, Control):
    """Time-steps one :class:`~jellysim.model.Model`.

    Parameters
    ----------
    model: the body.
    dt: time step [s], > 0.
    integrator: :class:`~jellysim.params.Integrator`.
    provot: :class:`~jellysim.params.ProvotParams` to turn on the report's strain limiting
        (``ProvotParams()`` = its defaults, as in a scene: tau = 0.1 %, 5 loops); ``None``
        (default): none.
    ground: :class:`~jellysim.params.GroundParams` for a ground plane (``GroundParams()`` =
        the report's mu/nu ground at y = 0, for the springs path; a physical (tet) body needs
        ``GroundParams(model="contact")``); ``None`` (default): none.
    backend: ``"numba"`` (default), ``"numpy"`` (the reference) or ``"warp"`` (NVIDIA Warp,
        integrators ``paper`` and ``symplectic``, and the physical path; ``pip install
        'jellysim[gpu]'``).
    device: Warp only: ``"auto"`` (a GPU when present, else Warp's CPU device), ``"cpu"``,
        ``"cuda"``, ``"cuda:N"``.
    precision: ``"float64"`` or ``"float32"`` (Warp; numba's explicit step: x, v, a stored in
        float32, sums in float64, ``state`` float64 holding float32 values; docs/architecture.md).
    threads: numba threads (default: starts on :func:`auto_threads`, then 1 and all are
        timed as the run goes and the faster kept, one on a tie: :mod:`jellysim.thread_choice`;
        capped, with a warning, at numba's pool, ``NUMBA_NUM_THREADS``).  Results do not
        depend on it; ``sim.threads`` is what the last piece or frame ran on,
        ``sim.thread_steps`` how many steps ran on each count ({threads: steps}; numba).
    runaway_distance: a point farther than this [m] from the body's starting centre stops the
        run (default: 100 x the body's bounding-box diagonal, at least 100 m).
    check_stability: estimate the stable dt now and warn (:class:`StabilityWarning`) if
        ``dt`` exceeds it.
    substeps: take this many steps of ``dt / substeps`` per step (``advance(n)`` still
        advances ``n dt``); the guard checks ``dt / substeps``.  ``"auto"`` (the default):
        what the stability estimate needs for the symplectic integrator (FEM or springs; with
        ``check_stability``), 1 for ``paper`` (the report's step) and ``implicit`` (stable
        without, but damps less with them).
    implicit: :class:`~jellysim.params.ImplicitParams` for ``integrator = "implicit"``.
    obstacles: static :class:`~jellysim.physics.contact.Plane` / ``Sphere`` / ``Box``
        obstacles with restitution and Coulomb friction (a ``GroundModel.CONTACT`` ground adds
        its plane to them).
    rest_speed: normal speed [m/s] under which a contact is resting (no bounce); default
        ``2 |g| dt`` (per substep).
    state: a :class:`~jellysim.state.State` to start from (x, v, a: (n, 3) float64), used as
        is and updated in place; ``None`` (default): ``model.state()``, at rest.
    """

    def __init__(self, model, *, dt: float, integrator: Integrator | str = Integrator.SYMPLECTIC,
                 provot: ProvotParams | None = None, ground: GroundParams | None = None,
                 backend: Backend | str = Backend.NUMBA, threads: int | None = None,
                 runaway_distance: float | None = None, check_stability: bool = True,
                 state=None, substeps: int | str = "auto", implicit: ImplicitParams =
                 ImplicitParams(), obstacles=(), rest_speed: float | None = None,
                 device: str | None = None, precision: str = "float64"):
        from ._forked import check as _check_fork

        _check_fork("Simulator")  # (a forked pool worker: a clear error, not a hang)
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.number)) or not (
                np.isfinite(dt) and dt > 0):
            raise SceneError(f"time step dt must be a positive number of seconds, got {dt!r}")
        self.model = model
        self.dt = float(dt)
        try:
            self.integrator = Integrator(integrator)
        except ValueError:
            raise SceneError(f"integrator must be one of {[i.value for i in Integrator]}, got "
                             f"{integrator!r}") from None
        provot, ground = (ProvotParams(enabled=False) if provot is None else provot,
                          GroundParams(enabled=False) if ground is None else ground)
        if not isinstance(provot, ProvotParams):
            raise TypeError(f"provot must be a jellysim.ProvotParams (e.g. ProvotParams(tau="
                            f"0.01, loops=5)) or None (off), got {provot!r}")
        implicit = ImplicitParams() if implicit is None else implicit
        if not isinstance(implicit, ImplicitParams):
            raise TypeError(f"implicit must be a jellysim.ImplicitParams, got {implicit!r}")
        if not isinstance(ground, GroundParams):
            raise TypeError(f"ground must be a jellysim.GroundParams (e.g. GroundParams(model="
                            f"GroundModel.CONTACT), the physical contact ground) or None, got "
                            f"{ground!r}")
        self.provot, self.ground = provot, ground
        obstacles = start_checks(model, state, ground, obstacles)  # (ground: plane below)
        self.physical = getattr(model, "fem", None) is not None
        if self.physical and self.integrator is not Integrator.SYMPLECTIC:
            raise SceneError(
                f"a body with a physical (FEM) material is integrated by symplectic substeps "
                f"(integrator = 'symplectic', the default); got '{self.integrator.value}'")
        if self.physical and ground.enabled and GroundModel(ground.model) is GroundModel.PAPER:
            raise SceneError("the report's paper ground (mu, nu) acts on the springs path only: "
                             "a physical (tet) body falls through it; give GroundParams(model="
                             "'contact', friction=...) ([ground] model = 'contact')")
        if self.physical and provot.enabled:
            raise SceneError("Provot strain limiting is not used by the physical (FEM) path: "
                             "its tets keep their shape; disable it")
        self.needed_substeps = self._auto_substeps(model, dt) if self.physical else 1
        """Substeps the stability estimate asks for (physical path; and the springs' symplectic
        path when ``substeps = "auto"``)."""
        if substeps == "auto" and not self.physical and check_stability and (
                self.integrator is Integrator.SYMPLECTIC):
            self.needed_substeps = self._springs_auto_substeps(model, dt)
        if substeps == "auto":
            substeps = self.needed_substeps
        if isinstance(substeps, bool) or not isinstance(substeps, (int, float, np.number)) or (
                not np.isfinite(substeps) or substeps != int(substeps) or substeps < 1):
            raise SceneError(f"substeps must be an integer >= 1 or 'auto', got {substeps!r}")
        if substeps > 100 * max(MAX_AUTO_SUBSTEPS, self.needed_substeps):  # (1e10 ran for hours)
            raise SceneError(f"substeps = {substeps:g} per step is more than 100 x "
                             f"{max(MAX_AUTO_SUBSTEPS, self.needed_substeps)}: one step would "
                             "run for minutes to hours; give a smaller dt, or 'auto'")
        self.substeps = int(substeps)
        if self.physical and self.substeps < self.needed_substeps:
            warnings.warn(
                f"substeps = {self.substeps} gives a substep of {dt / self.substeps:.3g} s, above "
                f"the physical path's stable substep {dt / self.needed_substeps:.3g} s for this "
                f"material and mesh: use substeps >= {self.needed_substeps} (or 'auto')",
                StabilityWarning, stacklevel=2)
        self.implicit = implicit
        if self.integrator is Integrator.IMPLICIT:
            if provot.enabled:
                raise SceneError("Provot strain limiting is a crutch of the explicit "
                                 "integrators and is not applied by integrator = 'implicit'; "
                                 "disable it ([provot] enabled = false)")
        if ground.enabled and GroundModel(ground.model) is GroundModel.CONTACT:
            from .physics.contact import ground_plane

            try:
                obstacles = (ground_plane(ground),) + obstacles
            except ValueError as exc:
                raise SceneError(f"ground: {exc}") from None
        self.obstacles = obstacles
        from .physics.contact import pack_obstacles

        try:
            self._obstacle_kind, self._obstacle_data = pack_obstacles(self.obstacles)
        except ValueError as exc:
            raise SceneError(str(exc)) from None
        if self.integrator is Integrator.IMPLICIT and np.isinf(self._obstacle_data).any():
            raise SceneError("no_slip is for the explicit integrators (the implicit one's "
                             "contact is Coulomb only): remove it or choose another integrator")
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
        try:
            self.backend = Backend(backend)
        except ValueError:
            raise SceneError(f"backend must be one of {', '.join(b.value for b in Backend)}, "
                             f"got {backend!r}") from None
        from .scene import check_backend

        if not isinstance(precision, str):  # np.float64, np.dtype("float32"): their names
            try:
                precision = np.dtype(precision).name
            except TypeError:
                pass
        check_backend(self.backend.value, self.integrator.value, device or "auto", precision)
        self._k = get_backend(self.backend, device=device, precision=precision)
        self.precision = precision
        f32 = self.backend is Backend.NUMBA and precision == "float32"
        if f32 and self.physical:
            raise SceneError("precision = 'float32' on backend 'numba' applies to spring "
                             "bodies; the physical (FEM) path computes in float64")
        n = model.point_count
        if provot.enabled and ProvotPairs(provot.pairs) is ProvotPairs.ALL and (
                n > MAX_ALL_PAIRS_POINTS):
            raise SceneError(
                f"provot pairs = 'all' is O(n^2) and limited to {MAX_ALL_PAIRS_POINTS} points; "
                f"this body has {n}. Use pairs = 'springs' (and a stiffer material) instead.")
        if not self.physical and not provot.enabled and n > 1 and not np.any(
                model.spring_stiffness != 0):
            what = ("every spring has stiffness 0 N/m" if model.spring_count else
                    "the body has no springs")
            warnings.warn(f"{what} and strain limiting is off: nothing "
                          "holds the body's shape, its points move independently (give "
                          "finalize(body, stiffness=...) in N/m, or a material: "
                          "js.physical_model(body, js.material('gelatin')))", UserWarning,
                          stacklevel=2)
        choose = threads is None and self.backend is Backend.NUMBA
        if threads is None:  # (the physical path's work is its tets; then timed frames)
            threads = (1 if self.physical and model.fem.tet_count < PHYSICAL_PARALLEL_MIN_TETS
                       else auto_threads(n, None if self.physical else model.spring_count))
        self.threads = _usable_threads(threads, self.backend)
        self._thread_choice = choose and (thread_choice.for_physical if self.physical else
                                          thread_choice.for_springs)(self.threads, model)
        self.state = model.state() if state is None else check_state(state, n, "Simulator(state=)")
        x0 = model.point_x0
        self.center = np.ascontiguousarray(x0.mean(axis=0))
        reach = float(np.sqrt(np.max(np.sum((x0 - self.center) ** 2, axis=1)))) if n else 0.0
        if runaway_distance is None:
            diag = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
            runaway_distance = max(100.0 * diag, 100.0)
        elif not float(runaway_distance) > 2.0 * reach:  # (it stopped a resting body as a
            raise SceneError(  # blow-up after doubling its substeps: the reliability trial)
                f"runaway_distance = {runaway_distance!r} m: the body's own points reach "
                f"{reach:.3g} m from its centre; the guard must lie well outside it (more than "
                f"{2.0 * reach:.3g} m; the default is 100 x the body's size, at least 100 m)")
        self.runaway_distance = float(runaway_distance)
        spread = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(x0, rowvar=False)), 0.0)) if (
            n >= COLLAPSE_MIN_POINTS) else np.zeros(3)
        self._rest_thin = float(spread[0])
        # the stiff-stable and physical paths claim physics at large steps: a body flattened
        # within one call there is a solver failure; the report's explicit step is what it is
        self._collapse_check = bool(n >= COLLAPSE_MIN_POINTS and spread[0] > 0.1 * spread[2]
                                    and (self.integrator is Integrator.IMPLICIT
                                         or self.physical))
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
        self._slip = np.zeros(n)
        """Each point's contact slip [m] since it last stuck (the friction's weakening)."""
        self._obstacles = rec.obstacles(self._obstacle_kind, self._obstacle_data,
                                        self.rest_speed, self._slip)
        if self.integrator is Integrator.IMPLICIT:
            im = implicit
            self._implicit_opts = rec.implicit_options(im.theta, im.cg_tolerance,
                                                       im.max_iterations, im.scheme is ImplicitScheme.BDF2)
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
            dtype = np.float32 if f32 else np.float64
            self._scratch = rec.explicit_scratch(n, k, dtype)
            sc = self._scratch
            # float32 copies of the state the kernels advance (precision = "float32")
            self._state32 = tuple(np.zeros((n, 3), dtype) for _ in range(3)) if f32 else None
            # the scratch arrays under their former names (other integration paths use them)
            self._dx, self._count, self._max_corr = sc.dx, sc.count, sc.max_corr
            self._x_pre, self._provot_scalar = sc.x_pre, sc.provot_scalar
        self._scalar = self._scratch.spring_scalar
        from .handles import Handles

        self.handles = Handles.empty(n)
        """Pins, point forces, gravity scale and drag (physical path; :mod:`jellysim.handles`)."""
        if self.physical:
            self._setup_physical()
        self.stability: StabilityEstimate | None = None
        if check_stability and not self.physical:
            self.check_stability()
        self._remember_start()  # (what reset() restores)

    def _springs_auto_substeps(self, model, dt) -> int:
        """:func:`springs_auto_substeps`, its estimate kept for :meth:`check_stability`."""
        need, self._symplectic_estimate = springs_auto_substeps(model, dt)
        return need

    def check_stability(self) -> StabilityEstimate:
        """Estimate the largest stable dt; warn when ``dt`` exceeds it."""
        est = getattr(self, "_symplectic_estimate", None)
        if est is None or self.integrator is not Integrator.SYMPLECTIC:
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
            if est.dt_max > 0 and self.integrator is Integrator.SYMPLECTIC:
                need = int(np.ceil(self.dt / (0.9 * est.dt_max)))
                hint = (f"use substeps >= {need} (or 'auto')" if self.substeps > 1 else
                        f"{hint}, or substeps >= {need} (or 'auto': [integrator] substeps)")
            limit = (f"exceeds the estimated stable limit {est.dt_max:.3g} s" if est.dt_max > 0
                     else "is unstable, as every dt is,")
            warnings.warn(
                f"dt = {self.dt_step:g} s {limit} "
                f"for the {self.integrator.value} integrator ({est.reason}; omega_max = "
                f"{est.omega_max:.3g} rad/s by {est.method}){held}: {hint}",
                StabilityWarning, stacklevel=2)
        return est

    def advance(self, steps: int = 1) -> None:
        """Take ``steps`` time steps.  Raises :class:`SimulationError` on blow-up, leaving
        the state as it was after the failing step."""
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise SceneError(f"advance(steps): steps must be a whole number >= 0, got {steps!r}")
        check_state(self.state, self.model.point_count, "advance")
        self._check_moved_inside()  # (a state moved there by hand: refused, as when made)
        # Ctrl-C (SIGINT) and a stop handler's SIGTERM act between whole steps: an
        # interrupted advance leaves x, v, t and step of one step (_interrupts.Deferred)
        with Deferred() as signals:
            self._signals = signals
            try:
                self._advance_scheduled(int(steps))  # (split where a timed handle ends)
            finally:
                self._signals = None

    PIECE_SECONDS = 0.2
    """Wall time [s] of one compiled call at most (about): :meth:`advance` steps in pieces so
    that a Ctrl-C is acted on within about this long (the physical path: one frame a piece).
    Results do not depend on the pieces (tested: bitwise the same as one call)."""

    def _piece(self, remaining: int, choice) -> int:
        if self.physical:
            return 1
        per_step = vars(self).get("_step_seconds")
        if per_step is None:
            return min(remaining, 8)
        seconds = thread_choice.TRY_PIECE_SECONDS if choice and choice.trying else (
            self.PIECE_SECONDS)  # (the springs path's thread count is timed on its pieces)
        return max(1, min(remaining, int(seconds / max(per_step, 1e-12))))

    def _advance_chunk(self, steps: int) -> None:
        if steps == 0:
            return
        s = self.state
        thin_before = self._thinness(s.x) if self._collapse_check else None
        import numba

        implicit = self.integrator is Integrator.IMPLICIT and not self.physical
        done_all, status, worst = 0, STATUS_OK, 0.0
        t0, step0 = s.t, s.step  # (the clock counts from here, however the call is cut)
        choice = None if self.physical else getattr(self, "_thread_choice", None)
        while done_all < steps:
            timed = False
            if choice:
                self.threads, timed = choice.next_frame()
            n = self._piece(steps - done_all, choice)
            started = time.perf_counter()
            previous = numba.get_num_threads()
            numba.set_num_threads(max(1, min(self.threads, numba.config.NUMBA_NUM_THREADS)))
            try:
                if self.physical:
                    done, status = self._advance_physical(n)
                elif implicit:
                    done, status = self._advance_implicit(n)
                    worst = max(worst, self._last_worst)
                else:
                    done, status = self._advance_explicit(n)
            finally:
                numba.set_num_threads(previous)
            done_all += int(done)
            if self.backend is Backend.NUMBA:  # steps run on each numba thread count
                used = vars(self).setdefault("thread_steps", {})
                used[self.threads] = used.get(self.threads, 0) + int(done)
            s.t, s.step = clock(t0, step0, self.dt, done_all), step0 + done_all
            if status != STATUS_OK:
                break
            self._step_seconds = (time.perf_counter() - started) / n
            if timed:
                choice.record(self.threads, self._step_seconds * n, n)
            signals = vars(self).get("_signals")
            if done_all < steps and signals is not None:
                signals.deliver()  # (a Ctrl-C raises here, at a whole step)
        if status != STATUS_OK:
            self._raise(status)
        self._check_collapse(thin_before, done_all)
        if implicit:
            self._last_worst = worst  # (the worst solve of the call, as one piece gave it)
            self._check_solves()

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
        tol = float(self.implicit.cg_tolerance)
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
        self._last_worst = float(worst)
        self.cg_worst_residual = max(self.cg_worst_residual, float(worst))
        return (done + sub - 1) // sub, status

    def _advance_explicit(self, steps):
        s = self.state
        sub = self.substeps
        state = self._state32 or (s.x, s.v, s.a)
        for mine, theirs in zip(self._state32 or (), (s.x, s.v, s.a)):
            mine[...] = theirs  # precision = "float32": the kernels advance float32 copies
        done, status = self._k.run_steps(
            steps * sub, self.dt_step, INTEGRATOR_CODES[self.integrator.value], *state,
            self._springs, self._points, self._provot_opts, self._ground, self._obstacles,
            self._scratch)
        for mine, theirs in zip(self._state32 or (), (s.x, s.v, s.a)):
            theirs[...] = mine
        # a failing substep counts its whole step
        return (done + sub - 1) // sub, status

    def _raise(self, status):
        m, s = self.model, self.state
        failed = s.step
        if status == STATUS_RUNAWAY and (getattr(self, "travelled", False) or not self.physical
                                         and getattr(self, "_travelled", lambda _: 0)(status)):
            raise travel_error(self, failed)  # intact, far: not a blow-up
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
        if self.physical:  # its substeps were counted and doubled: the forces are the cause
            raise blowup_error(self, failed, what, int(status))
        hint = ("add damping or use integrator = 'symplectic'" if est.dt_max <= 0 else
                f"try dt <= {0.9 * est.dt_max:.3g} s" if self.dt_step > est.dt_max else
                f"try dt <= {0.5 * self.dt_step:.3g} s")  # (stable linearly: the nonlinearity)
        raise SimulationError(
            f"simulation went unstable at step {failed} (t = {s.t:.6g} s): {what}; "
            f"{hint}" + (f" (estimated stable limit {est.dt_max:.3g} s)" if est.dt_max > 0
                         else " (no dt is stable for it)"), step=failed,
            status=int(status))
