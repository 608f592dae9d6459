"""Changing a running simulator from outside (:class:`Control`, a mixin of
:class:`~jellysim.simulator.Simulator`): start over (:meth:`Control.reset`), change gravity
(:attr:`Control.gravity`), and the checks that catch a state moved by hand.

A game developer's trial (session 26) found three silent traps: writing a fresh state into
``sim.state`` kept the damping branch's strain, the contact slip and doubled substeps (the
"reset" body drifted 3.2 cm with no force on it and ran 32x slower); ``sim.gravity = ...`` was
accepted and did nothing; and a body moved below the ground between two ``advance`` calls was
shot out of it (5 cm under: 15 J, 1.2 m high), where the same body at construction is refused.
"""
from __future__ import annotations

import numpy as np

from .errors import SceneError
from .params import GroundModel, Integrator, _user_stacklevel

__all__ = ["Control"]


def _fixed(name: str, why: str, how: str):
    """Getter and setter of an attribute set once, when the simulator is made: a later
    assignment is refused, saying how to get a simulator with another value."""
    key = f"_{name}_params"

    def get(self):
        return vars(self)[key]

    def put(self, value) -> None:
        if key in vars(self):
            raise SceneError(
                f"sim.{name} is fixed when the Simulator is made ({why}), so assigning it "
                f"would change nothing the body feels: make a new Simulator(model, {how}, "
                "state=sim.state) and give it the old one's internal state with "
                "new.restore_internal_state(sim.internal_state())")
        vars(self)[key] = value

    return get, put


class Control:
    """:meth:`reset`, :attr:`gravity` / :meth:`set_gravity`, :attr:`dt` (read-only), and
    copying: ``copy.deepcopy(sim)`` and ``pickle`` give a simulator that goes on exactly as
    the original would (its state, history, handles and clock), e.g. to try two futures from
    one moment, or to hand a running simulation to another process."""

    def __getstate__(self):
        from .kernels import Backend

        if self.backend is Backend.WARP:  # (its state lives on the device)
            raise SceneError("a simulator on backend 'warp' cannot be copied or pickled (its "
                             "arrays are on the device): save sim.state and "
                             "sim.internal_state() and make a new Simulator from them")
        state = dict(vars(self))
        state["_k"] = None  # (the kernels' module: imported again on the other side)
        state.pop("_signals", None)  # (an advance's signal catcher: not the simulation's)
        return state

    def __copy__(self):
        """``copy.copy(sim)``: an independent simulator, as ``copy.deepcopy`` gives (the
        read-only Model shared).  A shallow copy would share the state arrays, so stepping one
        would move the other (notebook trial, session 30)."""
        import copy

        return copy.deepcopy(self, {id(self.model): self.model})

    def __setstate__(self, state) -> None:
        from .kernels import get_backend

        vars(self).update(state)
        self._k = get_backend(self.backend, precision=self.precision)

    @property
    def dt(self) -> float:
        """The time step [s] of one :meth:`advance` step, fixed when the simulator is made
        (its substeps and stability follow from it)."""
        return self._dt

    @dt.setter
    def dt(self, value) -> None:
        if "_dt" in vars(self):
            raise SceneError(f"dt is fixed when the Simulator is made (its substeps and stable "
                             f"step follow from it), got sim.dt = {value!r}: make a new "
                             f"Simulator(model, dt=..., state=sim.state)")
        self._dt = float(value)

    ground = property(*_fixed("ground", "its contact is packed into the kernels' records",
                              "ground=GroundParams(...)"), doc=(
        """The :class:`~jellysim.params.GroundParams` the simulator was made with (fixed:
        API trial, session 28: assigning another was accepted, the body kept resting on the old
        ground, and the checks read the new one)."""))
    provot = property(*_fixed("provot", "its strain limiting is packed into the kernels' "
                              "records", "provot=ProvotParams(...)"),
                      doc="The :class:`~jellysim.params.ProvotParams` the simulator was made "
                          "with (fixed).")
    obstacles = property(*_fixed("obstacles", "they are packed into the kernels' records",
                                 "obstacles=(...)"), doc=(
        """The contact obstacles, a contact ground first (fixed when the simulator is
        made)."""))

    @property
    def dt_step(self) -> float:
        """The kernels' step [s]: ``dt / substeps`` (read-only: it follows the substeps)."""
        return self._dt / self.substeps

    @dt_step.setter
    def dt_step(self, value) -> None:
        if abs(float(value) - self._dt / self.substeps) > 1e-12 * abs(float(value)):
            raise SceneError(f"dt_step is dt / substeps ({self._dt:g} s / {self.substeps}), "
                             f"got sim.dt_step = {value!r}: make a new Simulator(model, dt=..., "
                             "substeps=..., state=sim.state)")

    @property
    def gravity(self) -> np.ndarray:
        """Gravitational acceleration [m/s^2], shape (3,) (a read-only copy); assign a vector
        to change it from the next :meth:`advance` on (:meth:`set_gravity`)."""
        g = np.array(self.model.gravity, dtype=np.float64)
        g.flags.writeable = False
        return g

    @gravity.setter
    def gravity(self, value) -> None:
        self.set_gravity(value)

    def set_gravity(self, gravity) -> None:
        """Change gravity to ``gravity`` [m/s^2], shape (3,), from the next :meth:`advance`
        on: tilt the world (a slope without tilting the ground), or 0 for weightless.  The
        simulator's model becomes a copy of its model with that gravity (``sim.model``; the
        model passed in is unchanged); nothing else changes (the contact's resting speed
        stays the one set when the simulator was made).  The report's step (``paper``) moves
        velocities by the stored accelerations first: those are shifted by the change, so its
        next step sees the new gravity (tested: free flight gains M g t exactly); the implicit
        BDF2 scheme, a two-step method, lags it by about half a step."""
        import dataclasses

        from .kernels import Backend
        from .model import _frozen
        from .physics.contact import check_gravity_meets_ground

        try:
            g = np.asarray(gravity, dtype=np.float64)
        except (TypeError, ValueError):
            g = None
        if g is None or g.shape != (3,) or not np.all(np.isfinite(g)):
            raise SceneError(f"gravity must be 3 finite accelerations [m/s^2], e.g. (0, -9.81, "
                             f"0) (y is up), got {gravity!r}")
        if np.linalg.norm(g) > 1e3:  # (1e300 blew up, blamed on an impact)
            import warnings

            warnings.warn(f"gravity {g.tolist()} m/s^2 is {np.linalg.norm(g) / 9.81:.3g} g: "
                          "accelerations are in m/s^2 (Earth: 9.81)", UserWarning,
                          stacklevel=_user_stacklevel())
        if self.backend is Backend.WARP:  # (its gravity is on the device, set when made)
            raise SceneError("set_gravity: not on the warp backend; make a new Simulator("
                             "dataclasses.replace(sim.model, gravity=...), state=sim.state)")
        if self.integrator is Integrator.PAPER:  # (its next step uses the stored a: shifted
            self.state.a += g - self.model.gravity  # so it sees the new gravity at once)
        self.model = dataclasses.replace(self.model, gravity=_frozen(g, np.float64))
        from .kernels import records as rec

        self._points = rec.point_arrays(self.model)
        if self.ground.enabled:
            check_gravity_meets_ground(g)

    def reset(self, state=None) -> None:
        """Start over, as a new simulator of the same model and settings would: the body at
        ``state`` (its positions, velocities and accelerations; default: the model at rest),
        the clock at t = 0, step 0, and everything the simulator keeps between steps as when
        it was made: the damping branch's strain, the contacts' slip, substeps doubled after
        an impact or a blow-up, the implicit solver's warm start.  Handles are dropped (pins,
        point forces, gravity scales, the drag spring); the gravity set last stays.  Writing a
        state into ``sim.state`` instead keeps all of that (right for resuming a run, wrong
        for starting again).  A body below the ground is refused, as when the simulator is
        made."""
        from .physics.contact import check_ground_placement, user_obstacles
        from .state import check_state

        n = self.model.point_count
        new = self.model.state() if state is None else check_state(state, n, "reset(state=)")
        if not all(np.all(np.isfinite(a)) for a in (new.x, new.v, new.a)):
            raise SceneError("reset(state=): its positions, velocities and accelerations must "
                             "be finite (NaN or infinite values found)")
        if self.ground.enabled:
            check_ground_placement(new.x, float(self.ground.height))
        try:  # (inside an obstacle: refused, as when the simulator is made)
            user_obstacles(self._others(), new.x)
        except ValueError as exc:
            raise SceneError(f"reset(state=): {exc}") from None
        s = self.state
        s.x[:], s.v[:], s.a[:] = new.x, new.v, new.a
        s.t, s.step = 0.0, 0
        self.restore_internal_state(self._made)
        self.handles.clear()
        self.__dict__.pop("_releases", None)
        if self.physical:
            self.min_tet_volume_ratio = 1.0
            self.substeps_taken = self.substeps
            self.__dict__.pop("_warned_inverted", None)

    def _others(self) -> tuple:
        """The obstacles besides the ground (a contact ground is the first of
        ``self.obstacles``; the ground is checked on its own, with its own message)."""
        g = self.ground
        contact = g.enabled and GroundModel(g.model) is GroundModel.CONTACT
        return self.obstacles[1:] if contact else self.obstacles

    def _remember_start(self) -> None:
        """Keep what :meth:`reset` restores (called once, at the end of ``__init__``)."""
        self._made = self.internal_state()
        self._size = float(np.ptp(self.model.point_x0, axis=0).max()) if (
            self.model.point_count) else 0.0

    def _check_moved_inside(self) -> None:
        """Refuse to step a body whose free points were moved below the ground or into an
        obstacle from outside (``sim.state.x`` written between advances): the contact would
        throw them out at once (5 cm into a plane: 15 J).  The steps themselves never leave a
        point inside (it is put on the surface), so this allows 1 % of the body's size (under
        it: a harmless nudge, 0.5-1 mm on a 10 cm body gave 3-10 mJ)."""
        pinned = self.handles.pinned
        if self.model.point_count == 0 or pinned.all():
            return
        x = self.state.x[pinned == 0] if pinned.any() else self.state.x  # (no copy if no pin)
        if not np.isfinite(x).all():
            return  # (said by the step's own check)
        g = self.ground
        height = float(g.height)
        low = float(x[:, 1].min())
        if g.enabled and low < height - 0.01 * self._size:
            raise SceneError(
                f"advance: {int(np.sum(x[:, 1] < height))} of {len(self.state.x)} points are "
                f"below the ground, the lowest {height - low:.4g} m under it (y = {low:.4g} m, "
                f"the ground at y = {height:g} m): the state was moved there from outside "
                "(sim.state.x written?), and the ground would throw them out at once.  Move the "
                "body above the ground first; sim.reset(state) starts over from a state (its "
                "history cleared)")
        if others := self._others():
            from .physics.contact import user_obstacles

            try:
                user_obstacles(others, x, tol=0.01 * self._size)
            except ValueError as exc:
                raise SceneError(f"advance: {exc} (moved there from outside: sim.state.x "
                                 "written?; sim.reset(state) starts over from a state)") from None
