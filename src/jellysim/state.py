"""State: what changes during a run (positions, velocities, accelerations, time)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kernels.records import point_arrays, spring_arrays

__all__ = ["State"]


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
