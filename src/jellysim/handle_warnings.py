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
    (it wins over the pin), reach so far that the numbers are likely millimetres, or change
    faster than the steps that sample it."""
    x, out = sim.state.x[idx], []
    size = max(float(getattr(sim, "_size", 0.0)), 1e-12)
    reach = float(np.abs(path.offsets).max())
    if reach > UNITS_SLIP * size:
        out.append(f"pin: the path moves the pinned points up to {reach:.4g} m, "
                   f"{reach / size:.0f} times the body's size ({size:.3g} m): likely a slip of "
                   "units (offsets are metres: 50 mm is 0.05)")
    out += _sampling_note(path, float(sim.state.t), float(sim.dt), reach)
    ground = getattr(sim, "ground", None)
    low = float(x[:, 1].min() + path.offsets[:, 1].min())
    if ground is not None and ground.enabled and low < float(ground.height) - 1e-9:
        out.append(f"pin: the path takes pinned points {float(ground.height) - low:.3g} m below "
                   "the ground, which holds them on it there")
    others = sim._others() if hasattr(sim, "_others") else ()
    lo = x.min(axis=0) + path.offsets.min(axis=0)  # (the box every pinned point stays in)
    hi = x.max(axis=0) + path.offsets.max(axis=0)
    corners = np.array([[(lo, hi)[(c >> a) & 1][a] for a in range(3)] for c in range(8)])
    for k, o in enumerate(others):
        kind, v = o.row()
        if kind == 1 and np.any(np.maximum(lo - np.asarray(v[:3]), np.asarray(v[:3]) - hi)
                                > v[3]):
            continue  # (a sphere clear of that box)
        if kind == 2 and np.any((hi < np.asarray(v[:3])) | (lo > np.asarray(v[3:6]))):
            continue  # (a box clear of it)
        if kind == 0 and depth_inside(o, corners).max() <= 0:
            continue  # (a plane the whole box is in front of)
        deepest = _deepest(o, x, path.offsets, size)
        if deepest > 1e-6 * size:
            out.append(f"pin: the path takes pinned points {deepest:.3g} m into obstacle "
                       f"#{k + 1} (a {type(o).__name__.lower()}), whose contact holds them on "
                       "its surface there: the obstacle wins over the pin (steer the path "
                       "around it)")
    return out


def _deepest(obstacle, x, offsets, size) -> float:
    """The deepest [m] any point ``x`` (n, 3) goes into ``obstacle`` along the straight
    segments between the path's ``offsets`` (k, 3), each sampled at least every quarter of the
    obstacle's size (a sphere's radius, a box's thinnest side, the body's size for a plane),
    at most a million positions at a time."""
    kind, v = obstacle.row()
    scale = (v[3] if kind == 1 else float(np.min(np.asarray(v[3:6]) - np.asarray(v[:3])))
             if kind == 2 else size)
    step = max(0.25 * scale, 1e-9)
    seg = np.diff(offsets, axis=0)
    n = np.clip(np.ceil(np.linalg.norm(seg, axis=1) / step), 1, 1000).astype(np.int64)
    rows = np.repeat(np.arange(len(seg)), n)  # segment i sampled at j / n_i, j = 1..n_i
    j = np.arange(rows.size) - np.repeat(np.cumsum(n) - n, n) + 1
    offs = np.concatenate([offsets[:1], offsets[rows] + seg[rows] * (j / n[rows])[:, None]])
    chunk = max(1, 1_000_000 // max(len(x), 1))
    return max(float(depth_inside(obstacle, (x[None] + offs[i:i + chunk, None]).reshape(-1, 3))
                     .max()) for i in range(0, len(offs), chunk))


SAMPLED_LOSS = 0.05
"""A pin path that steps sample less faithfully than this (the largest miss over its reach)
is said (:func:`_sampling_note`)."""


def _sampling_note(path, t0: float, dt: float, reach: float) -> list[str]:
    """The pins follow their path at the step ends (every ``dt`` [s] from ``t0``), straight
    between (the substeps interpolate): a path whose keyframes come faster loses its detail,
    a shake faster than about a tenth of the step rate is cut short (re-trial, session 31: a
    40 Hz shake at dt = 1/60 moved the base as a 20 Hz zig-zag).  The miss is largest at a
    keyframe (both are straight between keyframes and step ends, equal at the step ends)."""
    if reach <= 0 or len(path.times) < 2:
        return []
    tk = path.times
    k = np.floor((tk - t0) / dt)
    ta, tb = t0 + k * dt, t0 + (k + 1) * dt
    w = ((tk - ta) / dt)[:, None]
    at = path.offsets
    lerp = [np.column_stack([np.interp(t, tk, path.offsets[:, c]) for c in range(3)])
            for t in (ta, tb)]
    miss = float(np.linalg.norm(at - ((1 - w) * lerp[0] + w * lerp[1]), axis=1).max())
    if miss <= SAMPLED_LOSS * reach:
        return []
    return [f"pin: the pins follow their path at the end of each step (dt = {dt:g} s), "
            f"straight between, and this path changes faster: up to {miss:.3g} m "
            f"({miss / reach:.0%} of its reach) of it is cut short; use a smaller dt (a shake "
            "needs about 10 steps a period: dt <= 1 / (10 f))"]


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
