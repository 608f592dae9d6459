"""The physical path's time stepping (FEM tets, symplectic Euler substeps), a part of
:class:`jellysim.simulator.Simulator`: the substep count from the stability estimate, one
kernel call per frame, and the frames retaken at half the substep (a strong compression) or
with doubled substeps (a blow-up).  See docs/physics.md section 0."""
from __future__ import annotations

import time
import warnings

import numpy as np

from .errors import StabilityWarning
from .params import _user_stacklevel
from .kernels import STATUS_OK, STATUS_RUNAWAY, Backend
from .physics.stability_fem import fem_omega_max
from .physics.fem import FemArrays
from .state import clock

__all__ = ["PhysicalStepping"]


SETTLE_TIME = 0.02
"""[s] Time constant of the extra damping :meth:`PhysicalStepping.settle` adds (every point's
velocity relaxes as exp(-t / SETTLE_TIME) under it)."""

SLOW_SUBSTEPS = 1000
"""Substeps per step above which the physical path says that a frame will be slow (a game
developer's trial: 1e8 Pa gave 1,841 substeps, 77 ms a frame for 216 points, unsaid)."""

SETTLE_RAMP = 0.25
"""[s] :meth:`PhysicalStepping.settle` turns gravity and the standing point loads on over this
time (linearly, frame by frame), so the body is loaded quasi-statically.  Switched on at once,
a load's dynamic overshoot asks the base for up to twice the static friction: a block set down
on a slope at 0.9 atan(mu) broke away and, once sliding, did not stop (docs/physics.md
section 2: friction-induced hopping)."""


SMALL_BODY = 0.01
"""[m] A body smaller than this across that needs too many substeps is said to be small: a
mesh in millimetres read as metres (the artist trial's 0.1 mm mesh: 40,108 substeps)."""


def _substep_fixes(model) -> str:
    """What makes a physical body need fewer substeps, for an error: the size first when the
    body is tiny (a mesh's unit), the builder only when it is not already 'marching'."""
    x = np.asarray(model.point_x0, dtype=np.float64)
    extent = float(np.max(x.max(axis=0) - x.min(axis=0))) if len(x) else 0.0
    fixes = []
    if extent < SMALL_BODY:
        fixes.append(f"the body is only {extent * 1e3:.3g} mm across (a mesh's coordinates "
                     "are read as metres: [body] size = 0.1, jellysim build --size 0.1 or "
                     "size=0.1 scales it to 10 cm)")
    fixes.append("check the material's youngs_modulus [Pa] and density [kg/m^3] (gelatin: 1e4 "
                 "and 1141)")
    connect = model.body.meta.get("connect") if getattr(model, "body", None) is not None \
        else None
    fixes.append("use fewer points (larger tets)" + (
        "" if connect == "marching" else " or connect = 'marching' (well-shaped tets)"))
    return "; ".join(fixes) + ", or a smaller dt"


class PhysicalStepping:
    """Mixin: needs ``model``, ``state``, ``handles``, ``dt``, ``substeps``, ``backend``,
    ``_k`` (the backend), ``_obstacle_kind``/``_obstacle_data``, ``rest_speed``, ``center``,
    ``runaway_distance`` and ``_scalar`` (set by the Simulator)."""

    @property
    def substeps(self) -> int:
        """Substeps per :meth:`advance` step (the physical path doubles them to take a
        frame of an unstable impact again, then halves them back to the start after calm
        frames).  Assigning them is the user's: below the stability estimate
        ``needed_substeps`` on the physical path it warns (API trial, session 28: 5 was taken
        in silence, then reported as "an unstable impact"), and the value becomes the one
        halved back to."""
        return self._substep_count

    @substeps.setter
    def substeps(self, value) -> None:
        from .errors import SceneError

        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise SceneError(f"substeps must be a whole number >= 1, got {value!r}")
        value = int(value)
        if "_substep_count" in vars(self):  # (a change after construction: the user's)
            need = int(getattr(self, "needed_substeps", 1))
            if getattr(self, "physical", False) and value < need:
                warnings.warn(f"substeps = {value} gives a substep of {self.dt / value:.3g} s, "
                              f"above the physical path's stable substep {self.dt / need:.3g} "
                              f"s for this material and mesh: use substeps >= {need}",
                              StabilityWarning, stacklevel=2)
            relax = vars(self).get("_relax")
            if relax is not None:  # (the start the doubling halves back to)
                relax[:] = (0, value)
        self._substep_count = value

    def energy(self) -> dict[str, float]:
        """The body's energies now [J]: ``kinetic`` (sum 1/2 m |v|^2), ``gravity`` (sum
        -m g . x: zero at x = 0; handles' gravity scales not counted), ``elastic`` (the
        springs' sum 1/2 k (|x_j - x_i| - L0)^2, plus the tets' stored Stable Neo-Hookean
        energy on the physical path) and ``total`` (their sum).  The damping branch's own
        stored energy (the strain held by its internal state ``Q``, ``damping_ratio > 0``) is
        not counted, so in a damped wobble ``kinetic + elastic`` can rise for an instant while
        the branch gives back what it held.  Damping, contact friction and
        handles do work on the body, so only a free, undamped body keeps ``total``, and then
        as symplectic Euler does: it swings by about omega h (a mode's angular frequency times
        the substep) around a conserved value, without drift, when gravity is off.  Under
        gravity it also falls steadily by ``1/2 M |g|^2 h`` per second (the scheme's free
        fall runs ``g h t / 2`` ahead of (below) the parabola: 1.3e-3 of a tumbling brick's
        energy in 2 s at h = 1/6240 s; ``total + h/2 sum m g . v`` is the conserved one)."""
        m, x, v = self.model, self.state.x, self.state.v
        mass = np.asarray(m.point_mass, dtype=np.float64)
        kinetic = 0.5 * float(mass @ np.einsum("ij,ij->i", v, v))
        gravity = -float(mass @ (x @ np.asarray(m.gravity, dtype=np.float64)))
        elastic = 0.0
        if m.spring_count and np.any(m.spring_stiffness != 0):
            ij = m.spring_ij
            stretch = np.linalg.norm(x[ij[:, 1]] - x[ij[:, 0]], axis=1) - m.spring_rest_length
            elastic += 0.5 * float(m.spring_stiffness @ stretch**2)
        if getattr(m, "fem", None) is not None:
            from .physics.fem import elastic_energy

            elastic += float(elastic_energy(m.fem, x))
        return {"kinetic": kinetic, "gravity": gravity, "elastic": elastic,
                "total": kinetic + gravity + elastic}

    def pin_force(self) -> np.ndarray:
        """The force [N], shape (3,), the pins exert on the body now (at the end of the last
        step): minus every other force on the pinned points, summed (their tets and springs,
        point forces, the drag spring, gravity, viscous damping).  A body hanging at rest from
        its pins gets its weight back (``-M g``); one dragged along the ground by a pin reads
        the friction.  It is instantaneous: a wobbling body's reading swings with the
        wobble, so average it over frames for a gauge's reading; a pin moving along a path
        is taken as moving steadily (the impulse at a keyframe's turn is not included).
        Zero without pins.  Physical path only."""
        self._require_physical("pin_force()")
        pinned = self.handles.pinned != 0
        forces = -self._forces_now() if pinned.any() else np.zeros_like(self.state.x)
        return self._gauge(forces, pinned)

    def drag_force(self) -> np.ndarray:
        """The pull [N], shape (3,), of :meth:`drag`'s spring on the body now (zero when
        nothing is dragged): ``sum_p w_p (k (target + offset_p - x_p) - c v_p)``, the
        spring and its damper at the current velocities.  Physical path only."""
        self._require_physical("drag_force()")
        return self._gauge(self._drag_pull(), self.handles.drag_weight > 0.0)

    def _gauge(self, forces, rows) -> np.ndarray:
        """A gauge's reading [N], shape (3,): ``forces`` (n, 3) summed over the points
        ``rows`` (the distributed simulator sums its owned ones over the ranks)."""
        return forces[rows].sum(axis=0)

    def _drag_pull(self) -> np.ndarray:
        """Each point's pull [N] by the drag spring and its damper, shape (n, 3):
        ``w_p (k (target + offset_p - x_p) - c v_p)``; zeros when nothing is dragged."""
        h, s = self.handles, self.state
        d = h.drag
        if d[0] < 0.0:
            return np.zeros_like(s.x)
        return h.drag_weight[:, None] * (d[4] * (d[1:4] + h.drag_offset - s.x) - d[5] * s.v)

    @property
    def _force_model(self):
        """The model whose points :meth:`_forces_now` returns (a rank's local model under
        MPI)."""
        return self.model

    def _forces_now(self) -> np.ndarray:
        """Every force [N] on each point at the current state, shape (n, 3): the tets (the
        damping branch as it stands), springs, point forces, drag spring, gravity and the
        model's viscous damping (the numpy spec's terms, :mod:`.kernels.fem_numpy`)."""
        from .kernels import fem_numpy

        m, s, h = self._force_model, self.state, self.handles
        fem = m.fem.kernel_tuple(self._q.copy(), 0.0)  # (decay 1: the branch as it is)
        t = m.fem.tet_count
        corner = np.zeros((4 * t, 3))
        f = np.zeros_like(s.x)
        fem_numpy.tet_forces(s.x, fem, fem[8], fem[9], fem[10], corner, np.zeros(t))
        fem_numpy.gather_tet_forces(corner, fem[11], fem[12], f)
        if m.spring_count and np.any(m.spring_stiffness != 0):
            springs = (m.spring_ij, m.spring_rest_length, m.spring_stiffness,
                       m.point_first_ptr, m.point_second_ptr, m.spring_second_slot,
                       m.point_second_other)
            f += fem_numpy.spring_forces(s.x, springs, np.zeros(m.spring_count))
        f += self._drag_pull()
        mass = np.asarray(m.point_mass, dtype=np.float64)
        f += h.point_force - float(m.damping) * s.v
        f += (mass * h.gravity_scale)[:, None] * np.asarray(m.gravity, dtype=np.float64)
        return f

    def volume_ratios(self) -> np.ndarray:
        """Each tet's volume ratio ``J = det F`` now (its volume over its rest volume), shape
        (t,) [-]: below 0 the tet is inside out.  (:attr:`min_tet_volume_ratio` keeps the
        smallest J reached at any substep so far.)  Physical path only."""
        from .errors import SceneError
        from .geometry.tetra import tet_signed_volumes

        if not self.physical:
            raise SceneError("volume_ratios: this body has no tets on the physical path (a "
                             "FEM material); it runs on springs")
        fem = self.model.fem
        return tet_signed_volumes(self.state.x, fem.tets) / fem.rest_volume

    def tet_stresses(self) -> np.ndarray:
        """Each tet's Cauchy (true) stress now [Pa], shape (t, 3, 3), tension positive: the
        Stable Neo-Hookean stress plus the damping branch's (zero at rest); NaN for a tet
        inside out.  ``jellysim.physics.fem.von_mises(sim.tet_stresses())`` gives the von
        Mises stress (t,) [Pa].  Checked: a bar hanging from its pinned top carries
        ``rho g s`` at a height ``s`` above its free end (``tests/test_physical_path.py``).
        Physical path only."""
        from .errors import SceneError
        from .physics.fem import tet_stresses

        if not self.physical:
            raise SceneError("tet_stresses: this body has no tets on the physical path (a "
                             "FEM material); it runs on springs")
        return tet_stresses(self.model.fem, self.state.x, self._q)

    def settle(self, *, max_seconds: float = 10.0, speed: float = 1e-4) -> int:
        """Let the body come to rest where it is (under gravity, on its ground and obstacles,
        its handles on) before the run: it is stepped with a strong extra viscous damping
        (every point's velocity relaxing with a time constant of :data:`SETTLE_TIME` s), gravity
        and the standing point loads turned on over the first :data:`SETTLE_RAMP` s, until
        no point moves more than ``speed`` x dt in a step, for three steps, or ``max_seconds`` of
        simulated time (then a warning).  The settled shape is the start: velocities zero, the
        clock back to t = 0, step 0 (the material's own damping is untouched).  A point force
        with no release acts while settling (the body settles under that load); one given
        ``until`` a release time is an event of the run and is off while settling (it acts
        from t = 0 to its release); a pin moving along a path is held where it was pinned
        while settling, and follows its path from t = 0.  The body is set down gently: its contacts stay static
        while it settles (every point's slip is healed after each step, so the slip of the
        base spreading under its own weight does not weaken the friction to kinetic; a slope
        steeper than the static friction angle still lets it slide).  Physical path only.
        Returns the steps taken."""
        import dataclasses
        import math

        from .errors import SceneError

        if not self.physical:
            raise SceneError("settle is for the physical path (a body with a FEM material)")
        if self.state.step != 0 or self.state.t != 0:  # (it sets the clock back: timed pins
            # and releases would replay)
            raise SceneError(f"settle is for the start of a run: it sets the clock back to t = "
                             f"0, and this simulator is at t = {self.state.t:.4g} s (step "
                             f"{self.state.step}); call it before the first advance, or "
                             "sim.reset(sim.state) first to start over from here")
        gravity = np.asarray(self.model.gravity, dtype=np.float64)
        if np.any(gravity != 0.0) and not self.obstacles and not np.any(self.handles.pinned):
            raise SceneError("settle: nothing holds the body up (no ground, no obstacle, no "
                             "pin), so under gravity it would fall for ever: give it a ground "
                             "(GroundParams(model='contact'); a scene's [ground]), an obstacle "
                             "or a pin, or remove settle")
        s, model = self.state, self.model
        # a pin's path runs on the run's clock, which settling sets back to 0: its points are
        # held where they were pinned while settling (a scene could not settle a shaken
        # base, and its error's "settle first, then pin" had no scene form: teacher trial)
        paths, self.handles.paths = self.handles.paths, []
        # a timed force (released at some t) is an event of the run, from t = 0: it is off
        # while settling (and its release clock is the run's); an untimed force is a load
        # the body settles under
        releases = self.__dict__.pop("_releases", None)
        timed = (np.unique(np.concatenate([np.asarray(rows) for _, rows in releases]))
                 if releases else np.zeros(0, dtype=np.int64))
        held = self.handles.point_force[timed].copy()
        self.handles.point_force[timed] = 0.0
        loads = self.handles.point_force.copy()
        mass = np.asarray(model.point_mass, dtype=np.float64)
        damped = float(model.damping) + float(mass.mean()) / SETTLE_TIME
        ramp = max(1, math.ceil(SETTLE_RAMP / self.dt - 1e-9))
        calm, taken = 0, 0
        weights = mass / mass.sum()
        start = weights @ s.x
        try:
            for taken in range(1, max(ramp, math.ceil(max_seconds / self.dt)) + 1):
                share = min(1.0, taken / ramp)  # loads turned on gently (SETTLE_RAMP)
                self.model = dataclasses.replace(model, damping=damped,
                                                 gravity=share * gravity)
                self.handles.point_force[:] = share * loads
                before = s.x.copy()
                self.advance(1)
                self._slip[:] = 0.0  # set down gently: static contacts
                d = s.x - before  # (what moved: a resting contact's velocity is not zero)
                fastest = float(np.sqrt(np.einsum("ij,ij->i", d, d).max())) / self.dt
                calm = calm + 1 if fastest < speed and share == 1.0 else 0
                if calm >= 3:
                    break
            else:
                moved = float(np.linalg.norm(weights @ s.x - start))
                why = ("pushed by a standing point force (a force with no until, on while "
                       "settling) or sliding down a slope steeper than its friction holds?"
                       if np.any(loads) else
                       "sliding down a slope steeper than its friction holds?")
                warnings.warn(f"settle: the body did not come to rest in {max_seconds:g} s (a "
                              f"point still moved faster than {speed:g} m/s; its centre of "
                              f"mass travelled {moved * 1e3:.3g} mm while settling: {why}); "
                              "it starts from where settling left it (at t = 0)",
                              StabilityWarning, stacklevel=2)
        finally:
            self.model = model
            self.handles.paths = paths
            self.handles.point_force[:] = loads
            self.handles.point_force[timed] = held
            if releases is not None:
                self._releases = releases
        s.v[:] = 0.0
        self._slip[:] = 0.0
        s.t, s.step = 0.0, 0
        return taken

    SUBSTEP_SAFETY = 0.7
    """Fraction of the linear stability limit ``2 / omega_max`` (at rest) used as the substep.
    Large compression stiffens the material above its rest stiffness, so a chunk of frames in
    which some tet was compressed below :attr:`RETAKE_BELOW_J` of its volume is taken again
    with twice the substeps (0.35 of the limit).  Measured (docs/physics.md): a 5 kPa ball
    dropped 50 cm blows up at 0.5 throughout (and, retaken with twice the substeps, ends a
    frame with an inverted tet); at 0.35 every tet stays positive (smallest J 0.07)."""

    SQUEEZED_FRAMES = 30
    """After a frame with a tet below ``RETAKE_BELOW_J + 0.05``, this many frames (0.5 s at 60
    frames/s) run at half the substep from the start: a bouncing body's next impacts are not
    each taken twice."""

    RELAX_AFTER_FRAMES = 120
    """Substeps doubled after a blow-up are halved again (never below the starting count)
    after this many frames (2 s at 60 frames/s) without another blow-up: one hard impact does
    not slow the rest of the run."""

    RETAKE_BELOW_J = 0.8
    """A chunk whose smallest tet volume ratio ``J`` fell below this is retaken at half the
    substep: a tet squeezed to J along one axis stiffens its fastest mode by up to ~1 / J, and
    0.7 / 0.8 < 1 keeps the symplectic step inside its stability limit above it."""

    @classmethod
    def _auto_substeps(cls, model, dt) -> int:
        from .errors import SceneError
        from .simulator import MAX_AUTO_SUBSTEPS

        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            omega = float(fem_omega_max(model))  # (absurd moduli, densities or sizes: inf/NaN)
            ratio = float(dt) * omega / (cls.SUBSTEP_SAFETY * 2.0)
        need = max(1, int(np.ceil(ratio))) if ratio < 1e15 else None
        if need is None or need > MAX_AUTO_SUBSTEPS:  # refused before a frame runs for minutes
            why = (f"stable limit {2.0 / omega:.3g} s: its fastest vibration, {omega:.4g} "
                   "rad/s, is a pressure wave sqrt((lam + 2 mu) / rho) across its smallest "
                   "tet" if need is not None else "its stiffness over its masses is beyond "
                   "floating point: an absurd modulus, density or size")
            raise SceneError(
                f"the physical (FEM) material needs {need or 'countless'} substeps per step "
                f"of dt = {float(dt):g} s ({why}; more than {MAX_AUTO_SUBSTEPS} is refused): "
                + _substep_fixes(model))
        if need > SLOW_SUBSTEPS:  # (1e8 Pa on a 216-point box: 1,841 substeps, 77 ms a frame)
            fem = model.fem
            e = float(fem.youngs_modulus)
            rho = float(np.sum(model.point_mass)) / max(float(np.sum(fem.rest_volume)), 1e-300)
            meta = getattr(getattr(model, "body", None), "meta", None) or {}
            fixes = ["fewer points (larger tets)"] + (  # (a box's grid tets are the best)
                [] if meta.get("connect") == "marching" or meta.get("builder") == "box" else
                ["connect = 'marching' (well-shaped tets)"])
            if rho < 100.0 and e <= 1e6:  # (a density in g/cm^3: the teacher trial's 1.141,
                what = (f"a light material (density {rho:.4g} kg/m^3; gelatin 1141) is slow "
                        "on this explicit path: give the density in kg/m^3")  # was blamed
            else:  # on its stiffness)
                what = (f"a stiff material (E = {e:.3g} Pa) is slow on this explicit path: a "
                        "softer one (gelatin: 1e4 Pa)")
            warnings.warn(
                f"the physical (FEM) material needs {need} substeps per step of dt = "
                f"{float(dt):g} s (stable limit {2.0 / omega:.3g} s: a pressure wave across its "
                f"smallest tet), each a force pass over its {fem.tet_count:,} tets: {what}, or "
                + " or ".join(fixes) + ", runs faster", UserWarning, stacklevel=_user_stacklevel())
        return need

    def _setup_physical(self):
        m, fem = self.model, self.model.fem
        assert isinstance(fem, FemArrays)
        t = fem.tet_count
        n = m.point_count
        self._q = np.zeros((t, 6))
        self._tet_force = np.zeros((4 * t, 3))
        self._tet_j = np.ones(t)
        self._fsum = np.zeros((n, 3))
        self._min_j = np.ones(1)
        self._squeezed = np.zeros(1, dtype=np.int8)
        """Frames left at half the substep: set to :attr:`SQUEEZED_FRAMES` whenever a frame
        squeezed a tet below ``RETAKE_BELOW_J + 0.05`` (a body resting compressed, or bouncing,
        is not taken twice per frame)."""
        self._relax = np.array([0, self.substeps], dtype=np.int64)
        """Frames since the last blow-up doubling, and the starting substep count."""
        self.substeps_taken = self.substeps
        """Substeps the last frame ran (twice :attr:`substeps` while a compression lasts)."""
        self.min_tet_volume_ratio = 1.0
        """Smallest ``J = det F`` (deformed / rest volume) of any tet at any substep so far
        [-]; <= 0 means a tet was inverted."""

    def _physical_tuples(self, h):
        m, fem = self.model, self.model.fem
        ft = fem.kernel_tuple(self._q, h)
        use_springs = bool(m.spring_count and np.any(m.spring_stiffness != 0))
        springs = (m.spring_ij, m.spring_rest_length, m.spring_stiffness, m.point_first_ptr,
                   m.point_second_ptr, m.spring_second_slot, m.point_second_other, use_springs)
        model_arrays = (m.point_inv_mass, float(m.damping), m.gravity, springs)
        contact = (self._obstacle_kind, self._obstacle_data, float(self.rest_speed),
                   self.center, float(self.runaway_distance**2), self._slip)
        tet_force = self._tet_force
        if self.backend is Backend.NUMBA and self.threads == 1:
            tet_force = tet_force[:0]  # one thread: the tet pass sums into fsum itself
        scratch = (tet_force, self._tet_j, self._fsum, self._scalar, self._min_j)
        return model_arrays, ft, contact, scratch

    MAX_SUBSTEP_DOUBLINGS = 3
    """A chunk that blows up is taken again from its start with twice the substeps, up to
    this many times (a hard impact compresses tets far beyond their rest stiffness)."""

    def _advance_physical(self, steps):
        """``steps`` frames, one kernel call each: a frame that squeezed a tet below
        :attr:`RETAKE_BELOW_J` is retaken at half the substep (and the next
        :attr:`SQUEEZED_FRAMES` run there), one that blew up with doubled substeps.  The
        hooks :meth:`_physical_chunk`, :meth:`_agreed_min_j` and :meth:`_announce` are what
        the MPI driver (:class:`jellysim.distributed.fem.PhysicalMethods`) replaces.
        Returns ``(steps done, status)``."""
        from . import _warmup

        _warmup.wait()  # a first run's step kernels, compiled by a second process (if any)
        s, hd = self.state, self.handles
        done = 0
        status = STATUS_OK
        while done < steps and status == STATUS_OK:
            t0 = clock(s.t, s.step, self.dt, done)  # (the same, however the frames are cut)
            hd.targets(t0, hd.pin_from)
            hd.targets(t0 + self.dt, hd.pin_to)
            saved = (s.x.copy(), s.v.copy(), s.a.copy(), self._q.copy(), self._slip.copy())
            timed, ran, started = self._frame_threads(), 0, time.perf_counter()
            running_min_j = float(self._min_j[0])
            squeezed = bool(self._squeezed[0])
            self.travelled = False
            for attempt in range(self.MAX_SUBSTEP_DOUBLINGS + 2):
                sub = self.substeps * (2 if squeezed else 1)
                self._min_j[0] = 1.0  # this frame's smallest J
                k, status = self._physical_chunk(sub, self.dt / sub)
                ran += k
                self._min_j[0] = self._agreed_min_j(self._min_j[0])
                compressed = status == STATUS_OK and self._min_j[0] < self.RETAKE_BELOW_J
                if (status == STATUS_OK and (squeezed or not compressed)) or (
                        attempt == self.MAX_SUBSTEP_DOUBLINGS + 1) or self._travelled(status):
                    break
                for dst, src in zip((s.x, s.v, s.a, self._q, self._slip), saved):
                    dst[:] = src
                if status == STATUS_OK:
                    squeezed = True
                    continue
                self._substep_count *= 2  # (the property's setter is the user's)
                self.dt_step = self.dt / self.substeps
                self._relax[0] = -1
                cause = ("an impact, or a handle's pull or push" if self.handles.active
                         else "an impact")  # (handles trial: a 1e6 N push was "an impact")
                self._announce(f"an unstable frame at t = {t0:.4g} s ({cause} too strong for "
                               f"the substeps): the physical path took that frame again with "
                               f"{self.substeps} substeps per frame (kept until "
                               f"{self.RELAX_AFTER_FRAMES} frames pass without another)")
            if self._min_j[0] < self.RETAKE_BELOW_J + 0.05:
                self._squeezed[0] = self.SQUEEZED_FRAMES
            elif self._squeezed[0] > 0:
                self._squeezed[0] -= 1
            self._min_j[0] = min(running_min_j, float(self._min_j[0]))
            if timed:
                self._thread_choice.record(self.threads, time.perf_counter() - started, ran)
            self.substeps_taken = sub
            self._relax_substeps(status)
            done += 1 if status == STATUS_OK else (k + sub - 1) // sub
        self.min_tet_volume_ratio = float(self._min_j[0])
        if self.min_tet_volume_ratio <= 0.0 and not getattr(self, "_warned_inverted", False):
            self._warned_inverted = True
            since = vars(self).get("_restored_min_j")  # (J <= 0 restored: a resumed run's
            when = (f"before t = {since[1]:.4g} s, where this run was resumed" if since
                    and since[0] <= 0.0 else f"by t = {s.t + done * self.dt:.4g} s")
            self._announce(  # time said "by t = 0.5833 s" of a 0.25 s inversion: scale trial)
                f"a tet was turned inside out {when} (volume ratio "
                f"J = {self.min_tet_volume_ratio:.3g} by then; sim.min_tet_volume_ratio follows "
                "the run's smallest): the body "
                "was squashed or pulled harder than its tets hold (their Stable Neo-Hookean "
                "forces push it back; the shape is wrong meanwhile).  "
                + ("A stiffer" if (getattr(getattr(self.model, "body", None), "meta", None)
                                   or {}).get("connect") == "marching"  # (already: scale trial)
                   else "Better-shaped tets (connect='marching', or 'delaunay' with its relaxed "
                   "points), a stiffer")
                + " material or a gentler drag or handle help.  (Said once per run.)")
        return done, status

    def _frame_threads(self) -> bool:
        """With a thread chooser (``threads = None``: :mod:`jellysim.thread_choice`), set the
        next frame's thread count (``self.threads`` and numba's); whether to time the frame."""
        if not getattr(self, "_thread_choice", None):
            return False
        import numba

        self.threads, timed = self._thread_choice.next_frame()
        numba.set_num_threads(self.threads)
        return timed

    def _physical_chunk(self, nsteps, dt):
        """``nsteps`` substeps of ``dt`` [s] by the backend's ``physical_steps``:
        ``(done, status)``."""
        model_arrays, ft, contact, scratch = self._physical_tuples(dt)
        s = self.state
        return self._k.physical_steps(nsteps, dt, s.x, s.v, s.a, model_arrays, ft,
                                      self.handles.tuple(), contact, scratch)

    @staticmethod
    def _thinness(x) -> float:
        """The body's smallest principal standard deviation [m] (its thinnest direction; the
        collapse check of every path)."""
        c = np.cov(x, rowvar=False)
        return float(np.sqrt(max(np.linalg.eigvalsh(c)[0], 0.0)))

    def _travelled(self, status) -> bool:
        """A runaway of an intact body (every point within half the runaway distance of the
        points' mean): it travelled, it did not blow up, so more substeps will not help.
        Kept in ``self.travelled`` for the error (:func:`travel_error`)."""
        self.travelled = False
        if status == STATUS_RUNAWAY:
            x = self.state.x
            spread2 = float(np.max(np.sum((x - x.mean(axis=0)) ** 2, axis=1)))
            ok = float(spread2 < 0.25 * self.runaway_distance**2)
            self.travelled = self._agreed_min_j(ok) == 1.0
        return self.travelled

    def _agreed_min_j(self, value) -> float:
        """The frame's smallest J [-] (one process: its own)."""
        return float(value)

    def _announce(self, message) -> None:
        warnings.warn(message, StabilityWarning, stacklevel=5)

    def _relax_substeps(self, status) -> None:
        """After a frame: count it, and halve a blow-up's doubled substeps once
        :attr:`RELAX_AFTER_FRAMES` frames passed without another (never below the start)."""
        if status != STATUS_OK:
            return
        self._relax[0] += 1
        if self.substeps > self._relax[1] and self._relax[0] >= self.RELAX_AFTER_FRAMES:
            self._substep_count = max(int(self._relax[1]), self.substeps // 2)
            self.dt_step = self.dt / self.substeps
            self._relax[0] = 0


def travel_error(sim, failed: int):
    """The :class:`~jellysim.errors.SimulationError` of a body that travelled past
    ``sim.runaway_distance`` intact (not a blow-up: no advice about dt or stiffness)."""
    from .errors import SimulationError

    return SimulationError(
        f"the body travelled more than {sim.runaway_distance:g} m from its start by step "
        f"{failed} (t = {sim.state.t:.6g} s), intact: nothing went unstable, but the run stops "
        "there as a guard against blow-ups; a body meant to travel that far: [integrator] "
        "runaway_distance in a scene, Simulator(runaway_distance=...) in Python",
        step=failed, status=int(STATUS_RUNAWAY))


def blowup_error(sim, failed: int, what: str, status: int):
    """The :class:`~jellysim.errors.SimulationError` of a physical-path blow-up: its substeps
    were counted and doubled, so the forces (handles, a squashed body) are the cause."""
    from .errors import SimulationError

    handles = sim.handles.active
    more = (f"more substeps ([integrator] substeps = {4 * sim.substeps}; Python: "
            "Simulator(substeps=...))")
    fix = (f"check the handles first (a pin path's offsets are metres, forces newtons: a "
           f"path typed in millimetres or a force far beyond the body's weight does this), "
           f"then {more}, a stiffer material or a gentler drop help" if handles else
           f"{more}, a stiffer material or a gentler drop help")
    return SimulationError(
        f"simulation went unstable at step {failed} (t = {sim.state.t:.6g} s): {what}, with "
        f"{sim.substeps} substeps per step (doubled up to {sim.MAX_SUBSTEP_DOUBLINGS} times "
        f"after a blow-up); " + ("a force, drag or pin path too strong for the material, or "
                                 "a body squashed inside out" if handles else
                                 "a body squashed inside out") + f" does that: {fix}",
        step=failed, status=status)
