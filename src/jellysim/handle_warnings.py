"""What a handle asked for cannot do, said when it is given (handles trial, session 31).

A pin path that reaches below the ground or into an obstacle: the contact holds the points on
the surface there (the contact runs after the pin in each substep, so it wins), which the
ground's warning said and an obstacle's did not (a lift 8 cm into a sphere ended 18.8 mm off
its path, the pin pulling 763 N on an 11 N body).  And numbers likely typed in other units (a
path in millimetres, a force far beyond any jelly's weight), which otherwise blew the run up
with advice about substeps.
"""
from __future__ import annotations

import numpy as np

from .params import GRAVITY
from .physics.contact import depth_inside

__all__ = ["UNITS_SLIP", "path_warnings", "force_warnings"]

UNITS_SLIP = 100.0
"""A pin path reaching farther than this many times the body's size, or a force giving the
whole body more than this many g, is said to be a likely slip of units."""


def path_warnings(sim, idx, path) -> list[str]:
    """What a pin path of the points ``idx`` cannot do as asked (handles trial, session 31):
    reach below the ground or into an obstacle, whose contact holds the points on its surface
    (it wins over the pin), or reach so far that the numbers are likely millimetres."""
    x, out = sim.state.x[idx], []
    size = max(float(getattr(sim, "_size", 0.0)), 1e-12)
    reach = float(np.abs(path.offsets).max())
    if reach > UNITS_SLIP * size:
        out.append(f"pin: the path moves the pinned points up to {reach:.4g} m, "
                   f"{reach / size:.0f} times the body's size ({size:.3g} m): likely a slip of "
                   "units (offsets are metres: 50 mm is 0.05)")
    ground = getattr(sim, "ground", None)
    low = float(x[:, 1].min() + path.offsets[:, 1].min())
    if ground is not None and ground.enabled and low < float(ground.height) - 1e-9:
        out.append(f"pin: the path takes pinned points {float(ground.height) - low:.3g} m below "
                   "the ground, which holds them on it there")
    others = sim._others() if hasattr(sim, "_others") else ()
    if not others:
        return out
    offs = path.offsets  # the keyframes and the midpoints between them (straight between)
    offs = np.concatenate([offs, 0.5 * (offs[1:] + offs[:-1])])
    step = max(1, 1_000_000 // max(len(x), 1))  # (at most a million positions at a time)
    for k, o in enumerate(others):
        deepest = max(float(depth_inside(o, (x[None] + offs[a:a + step, None]).reshape(-1, 3))
                            .max()) for a in range(0, len(offs), step))
        if deepest > 1e-6 * size:
            out.append(f"pin: the path takes pinned points {deepest:.3g} m into obstacle "
                       f"#{k + 1} ({o!r}), whose contact holds them on its surface there: "
                       "the obstacle wins over the pin (steer the path around it)")
    return out


def force_warnings(sim, idx, force, total: bool) -> list[str]:
    """A point force [N] (``force`` (3,), on the points ``idx``, split over them with
    ``total``) that would accelerate the whole body at more than :data:`UNITS_SLIP` g."""
    whole = float(np.linalg.norm(force)) * (1 if total else len(idx))
    g = float(np.linalg.norm(GRAVITY))  # (one g, whatever the run's gravity)
    mass = float(np.sum(sim.model.point_mass))
    if mass > 0 and whole > UNITS_SLIP * g * mass:
        return [f"apply_force: {whole:.4g} N would accelerate the whole body ({mass:.4g} kg) "
                f"at {whole / mass / g:.0f} g: likely a slip of units (forces are newtons), or "
                "a push far too strong for a jelly"]
    return []
