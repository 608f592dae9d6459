"""State: what changes during a run (positions, velocities, accelerations, time)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError

from .kernels.records import point_arrays, spring_arrays

__all__ = ["State", "check_state", "clock"]


@dataclass(eq=False)
class State:
    """Mutable simulation state.  The kernels update it in place (no allocation per step).

    ``x``: positions [m], (n, 3); ``v``: velocities [m/s], (n, 3); ``a``: the last
    accelerations [m/s^2], (n, 3) (float64 arrays); ``t``: simulated time [s]; ``step``: time
    steps taken."""

    x: np.ndarray
    """Positions [m], shape (n, 3), float64."""
    v: np.ndarray
    """Velocities [m/s], shape (n, 3), float64."""
    a: np.ndarray
    """Accelerations [m/s^2], shape (n, 3), float64 (the last ones evaluated)."""
    t: float = 0.0
    """Simulated time [s]."""
    step: int = 0
    """Number of time steps taken."""

    @classmethod
    def at_rest(cls, model) -> "State":
        """Rest positions, zero velocity, accelerations from the forces there."""
        from .kernels import numpy_backend as nb

        x = np.array(model.point_x0, dtype=np.float64, copy=True)
        v = np.zeros_like(x)
        a = np.zeros_like(x)
        scalar = np.zeros(model.spring_count)
        nb.accelerations(x, v, point_arrays(model), spring_arrays(model), scalar, a)
        return cls(x=x, v=v, a=a)

    def copy(self) -> "State":
        return State(self.x.copy(), self.v.copy(), self.a.copy(), self.t, self.step)

    def assign(self, other: "State") -> None:
        """Copy ``other`` into this state without reallocating."""
        self.x[:] = other.x
        self.v[:] = other.v
        self.a[:] = other.a
        self.t = other.t
        self.step = other.step


def clock(t: float, step: int, dt: float, steps: int) -> float:
    """The time [s] ``steps`` steps of ``dt`` [s] after a state at time ``t`` and step
    ``step``: ``origin + (step + steps) dt``, where ``origin = t - step dt`` (exactly 0 when
    the state's clock started at zero).  So ``t`` is ``step dt`` to the last bit, whatever
    the advances' sizes (a sum of steps drifts: 150 of 1/60 s made 2.4999999999999996 s), and
    a state moved in time by hand keeps its offset."""
    origin = float(t) - int(step) * float(dt)
    if abs(origin) <= 1e-9 * abs(float(dt)):
        origin = 0.0
    return origin + (int(step) + int(steps)) * float(dt)


def check_state(state, n: int, where: str) -> "State":
    """Refuse a state the kernels cannot update in place: ``x``, ``v``, ``a`` must each be a
    writeable, C-contiguous float64 numpy array of shape (n, 3) (the kernels read and write
    them without bounds checks: another shape read past its end, another dtype was
    truncated), ``t`` a finite number of seconds and ``step`` a whole number >= 0."""
    if not isinstance(state, State):
        raise SceneError(f"{where}: the state must be a jellysim State (model.state(), or "
                         f"sim.state), got {type(state).__name__}")
    for name in ("x", "v", "a"):
        a = getattr(state, name)
        what = {"x": "positions [m]", "v": "velocities [m/s]", "a": "accelerations [m/s^2]"}
        ok = (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (n, 3)
              and a.flags.c_contiguous and a.flags.writeable)
        if not ok:
            got = (f"{a.dtype} {a.shape}" + ("" if a.flags.c_contiguous else ", not contiguous")
                   + ("" if a.flags.writeable else ", read-only")
                   if isinstance(a, np.ndarray) else type(a).__name__)
            raise SceneError(
                f"{where}: state.{name} ({what[name]}) must be a writeable float64 array of "
                f"shape ({n}, 3), one row per point of this model; got {got}.  Set its "
                f"values in place (sim.state.{name}[:] = ...) rather than giving it another "
                "array, or start from model.state()")
    if isinstance(state.t, bool) or not isinstance(state.t, (int, float, np.number)) or (
            not np.isfinite(state.t)):
        raise SceneError(f"{where}: state.t (the simulated time [s]) must be a finite number, "
                         f"got {state.t!r}")
    if isinstance(state.step, bool) or not isinstance(state.step, (int, np.integer)) or (
            state.step < 0):
        raise SceneError(f"{where}: state.step must be a whole number >= 0, got "
                         f"{state.step!r}")
    return state
