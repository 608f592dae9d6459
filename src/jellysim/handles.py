"""Handles: ways to hold and push a jello (physical path).

* **pins**: points fixed where they are, or moved along a path of keyframes (kinematic
  targets, linear between keyframes, relative to where the points were when pinned);
* **point forces**: a constant force [N] on chosen points (a total split evenly);
* **gravity scale**: per-point factor on gravity (0: weightless, e.g. a buoyant part);
* **drag**: a point and the patch around it pulled towards a target by a spring (the
  viewer's mouse).

Points are chosen with :func:`select_points` (box, sphere or index list).  The arrays live in a
:class:`Handles` record the :class:`~jellysim.simulator.Simulator` owns; the kernels read them
every step.
"""
from __future__ import annotations

from typing import NamedTuple

from dataclasses import dataclass, field

import numpy as np

from .errors import SceneError, ParameterError
from .params import _user_stacklevel
from .handle_warnings import force_warnings, path_warnings

__all__ = ["DragSpring", "Handles", "HandleMethods", "PinPath", "select_points"]


def select_points(points: np.ndarray, *, box=None, sphere=None, indices=None,
                  what: str = "selection") -> np.ndarray:
    """Indices (int64, sorted) of ``points`` [m], shape (n, 3), inside an axis-aligned
    ``box = (lower, upper)`` [m], a ``sphere = (center, radius)`` [m] (or the scene's
    ``{"center": [...], "radius": r}``), or given as
    ``indices``.  Exactly one of the three; an empty selection is an error naming ``what``."""
    given = [name for name, val in (("box", box), ("sphere", sphere), ("indices", indices))
             if val is not None]
    if len(given) != 1:
        raise SceneError(f"{what}: give exactly one of box, sphere or indices "
                         f"(got {', '.join(given) or 'none'})")
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        p = np.zeros((0, 0))
    if p.ndim != 2 or p.shape[1] != 3 or not len(p):
        raise SceneError(f"{what}: points must be positions [m] of shape (n, 3) (e.g. "
                         f"sim.state.x), got shape {np.shape(points)}")
    n = p.shape[0]
    if isinstance(sphere, dict):  # the scene's own form, {center = [...], radius = r}
        if set(sphere) != {"center", "radius"}:
            raise SceneError(f"{what}: sphere as a dict needs exactly 'center' and 'radius', "
                             f"got {sorted(sphere)}")
        sphere = (sphere["center"], sphere["radius"])
    if indices is not None:
        if any(isinstance(i, (bool, np.bool_)) for i in np.ravel(np.asarray(indices, dtype=object))):
            raise SceneError(f"{what}: indices must be point numbers, not true/false (a "
                             f"boolean mask goes to the Python methods), got {indices!r}")
        idx = np.asarray(indices)
        if idx.size == 0:
            raise SceneError(f"{what}: indices is empty; list the points to select")
        if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer):
            raise SceneError(f"{what}: indices must be a list of integers")
        if idx.size and (idx.min() < 0 or idx.max() >= n):
            bad = idx.min() if idx.min() < 0 else idx.max()
            raise SceneError(f"{what}: index {bad} is out of range: indices must lie in "
                             f"[0, {n - 1}] (the body has {n} points)")
        out = np.unique(idx.astype(np.int64))
    elif box is not None:
        try:
            lo, hi = (np.asarray(b, dtype=np.float64).reshape(3) for b in box)
        except (TypeError, ValueError):
            raise SceneError(f"{what}: box must be [[x0, y0, z0], [x1, y1, z1]] in metres") \
                from None
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise SceneError(f"{what}: box corners must be finite numbers (m), got lower "
                             f"{lo.tolist()}, upper {hi.tolist()}")
        if np.any(lo > hi):
            raise SceneError(f"{what}: box lower {lo.tolist()} must not exceed upper "
                             f"{hi.tolist()} in any axis (m); swap them")
        out = np.flatnonzero(np.all((p >= lo) & (p <= hi), axis=1))
    else:
        try:
            center = np.asarray(sphere[0], dtype=np.float64).reshape(3)
            radius = float(sphere[1])
            if isinstance(sphere[1], bool) or len(sphere) != 2:
                raise ValueError
        except (TypeError, ValueError, IndexError, KeyError):
            raise SceneError(f"{what}: sphere must be ([x, y, z], radius) in metres") from None
        if not (np.isfinite(radius) and radius > 0 and np.all(np.isfinite(center))):
            raise SceneError(f"{what}: sphere radius must be a number > 0 (m), got {radius:g}")
        out = np.flatnonzero(np.sum((p - center) ** 2, axis=1) <= radius * radius)
    if out.size == 0:
        raise SceneError(f"{what} holds no point of the body; widen it "
                         f"(body spans {p.min(axis=0).round(4).tolist()} to "
                         f"{p.max(axis=0).round(4).tolist()} m)")
    return out


@dataclass
class PinPath:
    """Keyframes of a kinematic pin: times [s], shape (k,), increasing, and offsets [m],
    shape (k, 3), from the pinned points' positions at pinning time.  After the last time the
    last offset holds; before the first, the pin ramps from a zero offset at the pinning time
    (:meth:`starting_at`)."""

    times: np.ndarray
    offsets: np.ndarray

    @classmethod
    def of(cls, path, what: str = "pin path") -> "PinPath":
        if isinstance(path, (list, tuple)):  # name the row at fault (rows of a scene table)
            for k, row in enumerate(path):
                if not (isinstance(row, (list, tuple, np.ndarray)) and len(row) == 4):
                    raise SceneError(f"{what}: row {k + 1} is {row!r}: give rows [t, dx, dy, "
                                     "dz] (s, m), four numbers each")
        try:
            arr = np.asarray(path, dtype=np.float64)
        except (TypeError, ValueError):
            raise SceneError(f"{what}: give rows [t, dx, dy, dz] (s, m)") from None
        if arr.ndim != 2 or arr.shape[1] != 4 or arr.shape[0] < 1:
            raise SceneError(f"{what}: give rows [t, dx, dy, dz] (s, m), got shape "
                             f"{arr.shape}")
        if not np.all(np.isfinite(arr)):
            k = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
            raise SceneError(f"{what}: every number must be finite; row {k + 1} is "
                             f"{arr[k].tolist()}")
        if np.any(np.diff(arr[:, 0]) <= 0):
            raise SceneError(f"{what}: times must increase strictly")
        return cls(arr[:, 0].copy(), arr[:, 1:].copy())

    def starting_at(self, t0: float, what: str = "pin path") -> "PinPath":
        """This path for points pinned at time ``t0`` [s], where their offset is zero: a path
        whose first keyframe is later is ramped from a zero offset at ``t0`` (the points move
        there smoothly instead of jumping at once); one that asks for a non-zero offset at
        ``t0`` itself is refused (the points would be teleported)."""
        if self.times[0] > t0:
            return PinPath(np.concatenate([[float(t0)], self.times]),
                           np.concatenate([np.zeros((1, 3)), self.offsets]))
        off = self.offset(t0)
        past = (f" (times are absolute simulation times: the path's first keyframe, t = "
                f"{self.times[0]:g} s, is before the pinning time)") if self.times[0] < t0 else ""
        if np.any(np.abs(off) > 1e-12):
            raise SceneError(
                f"{what}: at t = {t0:g} s, when the points are pinned, it asks for an offset of "
                f"{off.round(6).tolist()} m; the points would jump there in one substep{past}.  "
                f"Offsets are from where the points are when pinned: start the path with "
                f"[{t0:g}, 0, 0, 0] (or with a later time, then it ramps from zero)")
        if past and self.times[-1] <= t0:
            import warnings

            warnings.warn(f"{what}: every keyframe (the last at t = {self.times[-1]:g} s) is "
                          f"before the pinning time t = {t0:g} s (times are absolute simulation "
                          "times): the points are held where they are", UserWarning,
                          stacklevel=3)
        return self

    def offset(self, t: float) -> np.ndarray:
        """Offset [m], shape (3,), at time t [s] (linear between keyframes)."""
        return np.array([np.interp(t, self.times, self.offsets[:, c]) for c in range(3)])


@dataclass
class Handles:
    """Per-point handle arrays read by the physical kernels (n points)."""

    gravity_scale: np.ndarray
    """Factor on gravity [-], shape (n,)."""
    point_force: np.ndarray
    """External force [N], shape (n, 3)."""
    pinned: np.ndarray
    """1 where a point is pinned, shape (n,), int8."""
    pin_anchor: np.ndarray
    """Where each pinned point was when pinned [m], shape (n, 3)."""
    pin_from: np.ndarray
    """Pin targets at the start of the current batch [m], shape (n, 3)."""
    pin_to: np.ndarray
    """Pin targets at its end [m], shape (n, 3)."""
    drag: np.ndarray
    """``[point, tx, ty, tz, k, c]``: point (-1: none) and the patch around it pulled to the
    target [m] by a spring of total stiffness k [N/m] with a damper of total coefficient
    c [N s/m] on the patch's velocity."""
    drag_weight: np.ndarray
    """Share [-] of the drag spring on each point, shape (n,): 1/m on the m points of the
    grabbed patch (they sum to 1), 0 elsewhere."""
    drag_offset: np.ndarray
    """Each grabbed point's offset [m] from the grabbed point when grabbed, shape (n, 3): it
    is pulled towards the target plus its offset, so the patch keeps its shape."""
    paths: list = field(default_factory=list)
    """``(indices, PinPath)`` of the moving pins."""

    @classmethod
    def empty(cls, n: int) -> "Handles":
        return cls(np.ones(n), np.zeros((n, 3)), np.zeros(n, dtype=np.int8), np.zeros((n, 3)),
                   np.zeros((n, 3)), np.zeros((n, 3)), np.array([-1.0, 0, 0, 0, 0, 0]),
                   np.zeros(n), np.zeros((n, 3)))

    def clear(self) -> None:
        """Drop every handle, in place (the arrays the kernels hold stay the same objects)."""
        empty = Handles.empty(len(self.pinned))
        for name in ("gravity_scale", "point_force", "pinned", "pin_anchor", "pin_from",
                     "pin_to", "drag", "drag_weight", "drag_offset"):
            getattr(self, name)[...] = getattr(empty, name)
        self.paths.clear()

    @property
    def active(self) -> bool:
        return bool(self.pinned.any() or self.point_force.any() or self.drag[0] >= 0
                    or np.any(self.gravity_scale != 1.0))

    def targets(self, t: float, out: np.ndarray) -> None:
        """Pin targets at time t [s] into ``out`` (pinned rows only)."""
        pinned = self.pinned != 0
        out[pinned] = self.pin_anchor[pinned]
        for idx, path in self.paths:
            out[idx] = self.pin_anchor[idx] + path.offset(t)

    def tuple(self):
        return (self.gravity_scale, self.point_force, self.pinned, self.pin_from, self.pin_to,
                self.drag, self.drag_weight, self.drag_offset)


HANDLE_KINDS = {"pin": "fix points, or move them along 'path'",
                "force": "a constant total 'force' [N] split over the points (released at "
                         "time 'until' [s] if given)",
                "gravity": "multiply gravity on the points by 'scale'"}
DRAG_DAMPING_RATIO = 0.7
"""The drag spring's default damping ratio [-] (Box2D's mouse joint: 5 Hz, 0.7)."""
MAX_DRAG_POINTS = 64
"""The most points a drag grabs (the nearest to the grabbed point)."""

class HandleMethods:
    """The :class:`~jellysim.simulator.Simulator`'s handle methods (physical path): they
    edit ``self.handles``, which the kernels read every step."""

    def _require_physical(self, what):
        if not self.physical:
            raise SceneError(f"{what} needs the physical path: a body with tets and a FEM "
                             "material (a scene: [material] preset = 'gelatin' or model = "
                             "'fem' with connect = 'marching' or 'delaunay'; Python: "
                             "js.physical_model(body, material))")

    def _point_indices(self, indices, what: str) -> np.ndarray:
        """Unique point indices, or a :class:`SceneError` naming ``what`` and the range."""
        n = self.model.point_count
        raw = np.asarray(indices)
        if raw.dtype == bool:  # a mask over the points, e.g. sim.state.x[:, 1] < 0.01
            if raw.shape != (n,):
                raise SceneError(f"{what}: a boolean mask must have one entry per point "
                                 f"({n}), got shape {raw.shape}")
            raw = np.flatnonzero(raw)
        elif raw.ndim > 1:  # (API trial: [[0, 1], [2, 3]] was flattened without a word)
            raise SceneError(f"{what}: point indices must be a flat list (or a boolean mask "
                             f"over the points), got an array of shape {raw.shape}")
        elif raw.size and not np.issubdtype(raw.dtype, np.integer):
            whole = raw.dtype.kind == "f" and np.all(raw == np.round(raw))
            if not whole:
                raise SceneError(f"{what}: point indices must be integers (or a boolean mask "
                                 f"over the points), got {indices!r}")
        try:
            idx = np.unique(raw.astype(np.int64).reshape(-1))
        except (TypeError, ValueError):
            raise SceneError(f"{what}: point indices must be integers, got {indices!r}") \
                from None
        if idx.size == 0:
            raise SceneError(f"{what}: no points given (select them with "
                             "jellysim.handles.select_points)")
        if idx[0] < 0 or idx[-1] >= n:
            raise SceneError(f"{what}: point index {idx[0] if idx[0] < 0 else idx[-1]} is out "
                             f"of range: the body has {n} points (0 to {n - 1})")
        return idx

    def pin(self, indices, path=None) -> None:
        """Pin points (indices into the body) where they are now; with ``path`` (rows
        ``[t, dx, dy, dz]``, s and m, or a :class:`~jellysim.handles.PinPath`) they follow
        the offsets from there, linearly between keyframes (absolute simulation times).
        Pinning points that are already pinned replaces their earlier pin and path (the
        last call wins; a scene's ``[[handle]]`` tables may not overlap instead).  A refused
        call (a bad index or path) changes nothing."""
        self._require_physical("pinning points")
        idx = self._point_indices(indices, "pin")
        if path is not None:  # checked before anything changes: a refused call pins nothing
            path = path if isinstance(path, PinPath) else PinPath.of(path)
            path = path.starting_at(float(self.state.t))
        hd = self.handles
        hd.pinned[idx] = 1
        hd.pin_anchor[idx] = self.state.x[idx]
        self.state.v[idx] = 0.0
        hd.paths = [(i, p) for i, p in hd.paths if not np.isin(i, idx).any()]
        if path is not None:
            hd.paths.append((idx, path))
            for message in path_warnings(self, idx, path):
                import warnings

                warnings.warn(message, UserWarning, stacklevel=_user_stacklevel())

    def move_pinned(self, indices, offset, *, seconds: float | None = None) -> None:
        """Move pinned points by ``offset`` [m], shape (3,), from where they are now, linearly
        over the next ``seconds`` [s] (default: one step, ``dt``): an app's handle moved frame
        by frame (API trial, session 28: that took ``pin(idx, path=[[t + dt, dx, dy, dz]])``
        each frame, which this is).  Every point must be pinned already (:meth:`pin`).  Like
        :meth:`pin` with a path, it replaces the path those points were following: the rest
        of an earlier path is dropped (to move along a path and then on, give ``pin`` one
        path with both)."""
        idx = self._point_indices(indices, "move_pinned")
        loose = idx[self.handles.pinned[idx] == 0]
        if len(loose):
            raise SceneError(f"move_pinned: {len(loose)} of the {len(idx)} points given "
                             f"{'is' if len(loose) == 1 else 'are'} not pinned (point "
                             f"{loose[0]}): pin them first, sim.pin(indices)")
        off = _vec3(offset, "move_pinned: offset [m]")
        seconds = self.dt if seconds is None else seconds
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float, np.number)) or not (
                np.isfinite(seconds) and seconds > 0):
            raise SceneError(f"move_pinned: seconds must be a time > 0 [s], got {seconds!r}")
        self.pin(idx, path=[[float(self.state.t) + float(seconds), *off]])

    def unpin(self, indices=None) -> None:
        """Release pinned points (all when ``indices`` is None)."""
        hd = self.handles
        idx = np.flatnonzero(hd.pinned) if indices is None else self._point_indices(
            indices, "unpin")
        hd.pinned[idx] = 0
        hd.paths = [(i, p) for i, p in hd.paths if not np.isin(i, idx).any()]

    def apply_force(self, indices, force, *, total: bool = True,
                    until: float | None = None) -> None:
        """Constant force [N], shape (3,), on the points (replacing an earlier one there):
        split evenly with ``total`` (default), else on each point.  ``until`` [s]: the force
        is released (set to zero on those points) at that simulated time, on the step nearest
        to it (:meth:`advance` stops there): a push, then a free wobble."""
        self._require_physical("point forces")
        if not isinstance(total, (bool, np.bool_)):
            raise SceneError(f"apply_force: total must be True (the force is split over the "
                             f"points) or False (each point gets it), got {total!r}")
        idx = self._point_indices(indices, "apply_force")
        f = _vec3(force, "apply_force: force [N]")
        release = None if until is None else release_step(until, self.dt, self.state.step,
                                                          self.state.t)
        self._say_pinned(idx, "apply_force", "force")  # (once the call is known to stand)
        drop_releases(self, idx)  # a force replaced on these points keeps no earlier release
        if release is not None:
            self.__dict__.setdefault("_releases", []).append((release, idx))
        self.handles.point_force[idx] = f / len(idx) if total else f
        for message in force_warnings(self, idx, f, total):
            import warnings

            warnings.warn(message, UserWarning, stacklevel=_user_stacklevel())

    def _advance_scheduled(self, steps: int) -> None:
        """``advance(steps)``, stopping where a timed force ends (:func:`advance_releasing`)."""
        s = self.state
        for name, a in (("x", s.x), ("v", s.v)):
            if steps and not np.all(np.isfinite(a)):  # (set by hand: not the step's doing)
                bad = int(np.sum(~np.isfinite(a).all(axis=-1)))
                what = "positions [m]" if name == "x" else "velocities [m/s]"
                raise SceneError(f"advance: sim.state.{name} holds NaN or infinite values at "
                                 f"{bad} points before the step (set by hand, or left by an "
                                 f"earlier blow-up): give finite {what}")
        if steps and len(s.v) and not self.__dict__.get("_started"):
            # (the first steps only: the velocities were given, not made by a blow-up, which
            # later steps report as one with its frames kept)
            speed = np.hypot(np.hypot(s.v[:, 0], s.v[:, 1]), s.v[:, 2])  # (no overflow)
            p = int(np.argmax(speed))
            if speed[p] * self.dt > self.runaway_distance:
                raise SceneError(
                    f"advance: sim.state.v is {speed[p]:.3g} m/s at point {p}: one "
                    f"step of dt = {self.dt:g} s would carry it past the runaway distance "
                    f"({self.runaway_distance:g} m) before any force acts; give velocities "
                    "in m/s")
        self._started = bool(steps) or self.__dict__.get("_started", False)
        advance_releasing(self, steps, lambda: self.state.step, self._advance_chunk)

    def set_gravity_scale(self, indices, scale) -> None:
        """Gravity on the points is multiplied by ``scale`` [-]: one number for all of them,
        or one per point, shape (k,), in the order of ``indices`` (a list of k distinct point
        numbers, or a mask of k points in point order; API trial, session 28: each value took
        its own call)."""
        self._require_physical("a gravity scale")
        per_point = np.ndim(scale) == 1
        if per_point:
            try:
                values = np.asarray(scale, dtype=np.float64)
            except (TypeError, ValueError):
                values = np.array([np.nan])
            raw = np.asarray(indices)
            if raw.dtype == bool and raw.shape == (self.model.point_count,):
                raw = indices = np.flatnonzero(raw)  # (a mask: its points in order)
            if raw.dtype == bool or raw.ndim != 1 or len(raw) != len(values) or len(
                    np.unique(raw)) != len(raw):
                raise SceneError(f"set_gravity_scale: {len(values)} scales need as many "
                                 f"distinct point numbers, in the same order, got indices of "
                                 f"shape {raw.shape}")
            if not np.all(np.isfinite(values)):
                raise SceneError("set_gravity_scale: every scale must be a finite number (1 = "
                                 "normal gravity, 0 = none)")
        elif isinstance(scale, bool) or not isinstance(scale, (int, float, np.number)) or not (
                np.isfinite(scale)):
            shown = repr(scale) if np.size(scale) <= 6 else f"an array of shape {np.shape(scale)}"
            raise SceneError(f"set_gravity_scale: scale must be a finite number (1 = normal "
                             f"gravity, 0 = none) or one per point, got {shown}")
        idx = self._point_indices(indices, "set_gravity_scale")
        self._say_pinned(idx, "set_gravity_scale", "gravity scale")
        if per_point:
            self.handles.gravity_scale[np.asarray(indices, dtype=np.int64)] = values
        else:
            self.handles.gravity_scale[idx] = float(scale)

    def _say_pinned(self, idx, call: str, what: str) -> None:
        """Warn when some of ``idx`` are pinned: a pinned point follows its pin, so ``what``
        does nothing there (a scene's tables say so by name: scene_handles.py)."""
        held = idx[self.handles.pinned[idx] != 0]
        if len(held):
            import warnings

            warnings.warn(f"{call}: {len(held)} of the {len(idx)} points given "
                          f"{'is' if len(held) == 1 else 'are'} pinned (point {held[0]}): a "
                          f"pinned point follows its pin, so the {what} does nothing there",
                          UserWarning, stacklevel=_user_stacklevel())

    @property
    def drag_spring(self) -> "DragSpring | None":
        """The spring :meth:`drag` pulls with now (its point, target [m], stiffness [N/m],
        damper [N s/m] and damping ratio, the grabbed patch's points), or ``None`` when
        nothing is dragged.  Physical path only (else ``None``)."""
        h = getattr(self, "handles", None)
        if h is None or h.drag[0] < 0.0:
            return None
        d = h.drag
        k, c = float(d[4]), float(d[5])
        mass = float(self.model.total_mass)
        return DragSpring(int(d[0]), d[1:4].copy(), k, c,
                          c / (2.0 * np.sqrt(k * mass)) if k > 0 and mass > 0 else 0.0,
                          np.flatnonzero(h.drag_weight > 0.0))

    def drag(self, point: int | None, target=None, stiffness: float | None = None, *,
             radius: float | None = None, damping_ratio: float = DRAG_DAMPING_RATIO) -> None:
        """Pull ``point`` and the patch around it towards ``target`` [m] with a spring of total
        ``stiffness`` [N/m] (default: strong enough to move the whole body's weight by 1 cm,
        so the body hangs on it at ~5 Hz) shared evenly by the patch's points, each pulled to
        the target plus its offset from ``point`` when grabbed (the patch keeps its shape: a
        pinch spread over its tets, not a point load that turns them inside out).  The patch:
        ``point`` and its tet neighbours, or with ``radius`` [m] every point that close to it
        (at most :data:`MAX_DRAG_POINTS`, the nearest).  The spring is damped like a mouse
        joint: a damper ``c = 2 damping_ratio sqrt(stiffness M)`` [N s/m] (M: the body's
        mass) on the patch's velocity, so the body hanging on it settles with that fraction
        of critical damping (0.7 by default, Box2D's mouse joint's; 0: undamped, it bounces
        on the cursor); the damper is implicit per point, so any ratio is stable.  Calling
        again with the same ``point`` moves the target (the mouse); ``drag(None)`` (or a
        ``target`` of ``None``) releases."""
        self._require_physical("dragging")
        h, d = self.handles, self.handles.drag
        if point is None or target is None:
            d[0] = -1.0
            h.drag_weight[:] = 0.0
            return
        if stiffness is None:
            stiffness = self.model.total_mass * float(np.linalg.norm(self.model.gravity)) / 0.01
        if isinstance(stiffness, bool) or not (isinstance(stiffness, (int, float, np.number))
                                               and np.isfinite(stiffness) and stiffness > 0):
            raise SceneError(f"drag: stiffness must be a spring constant > 0 [N/m], got "
                             f"{stiffness!r}")
        if isinstance(damping_ratio, bool) or not (
                isinstance(damping_ratio, (int, float, np.number)) and np.isfinite(damping_ratio)
                and damping_ratio >= 0):
            raise SceneError(f"drag: damping_ratio must be a number >= 0 (a fraction of "
                             f"critical damping; 0.7 by default), got {damping_ratio!r}")
        if np.size(point) != 1 or isinstance(point, bool):
            raise SceneError(f"drag: point must be one point index (its patch comes with it; "
                             f"radius= widens it), got {point!r}")
        p = int(self._point_indices(np.reshape(point, 1), "drag")[0])
        goal = _vec3(target, "drag: target [m]")
        if int(d[0]) != p or radius is not None:  # a new grab: choose the patch
            x = self.state.x
            if radius is not None:
                if isinstance(radius, bool) or not (isinstance(radius, (int, float, np.number))
                                                    and np.isfinite(radius) and radius >= 0):
                    raise SceneError(f"drag: radius must be a length >= 0 [m], got {radius!r}")
                patch = np.flatnonzero(np.linalg.norm(x - x[p], axis=1) <= radius)
            else:
                tets = self.model.fem.tets
                patch = np.unique(tets[np.any(tets == p, axis=1)])
            patch = np.union1d(patch, [p])
            if patch.size > MAX_DRAG_POINTS:
                near = np.argsort(np.linalg.norm(x[patch] - x[p], axis=1), kind="stable")
                patch = np.sort(patch[near[:MAX_DRAG_POINTS]])
            h.drag_weight[:] = 0.0
            h.drag_weight[patch] = 1.0 / patch.size
            h.drag_offset[:] = 0.0
            h.drag_offset[patch] = x[patch] - x[p]
        d[0] = float(p)
        d[1:4] = goal
        d[4] = float(stiffness)
        d[5] = drag_damping(float(stiffness), self.model.total_mass, float(damping_ratio))


class DragSpring(NamedTuple):
    """What :meth:`HandleMethods.drag` holds (``Simulator.drag_spring``)."""

    point: int
    """The grabbed point's index."""
    target: np.ndarray
    """Where it is pulled [m], shape (3,) (each patch point: to this plus its offset)."""
    stiffness: float
    """The spring's total stiffness k [N/m]."""
    damping: float
    """The damper's total coefficient c [N s/m] (``2 damping_ratio sqrt(k M)``)."""
    damping_ratio: float
    """``c / (2 sqrt(k M))`` [-], M the body's mass."""
    points: np.ndarray
    """The patch's point indices, shape (m,) (the spring is shared evenly by them)."""


def drag_damping(stiffness: float, mass: float, damping_ratio: float) -> float:
    """The drag's damper [N s/m]: ``damping_ratio`` of critical for ``mass`` [kg] on a
    spring of ``stiffness`` [N/m], ``2 zeta sqrt(k M)``."""
    return 2.0 * damping_ratio * float(np.sqrt(stiffness * mass))


def release_step(until, dt: float, step: int, t: float = 0.0) -> int:
    """The step at which a force applied now (at ``step``, time ``t`` [s]) with ``until`` [s]
    is released: the step nearest to that time (a clock set by hand counts from there); a
    :class:`SceneError` when it is not a later step."""
    if isinstance(until, bool) or not isinstance(until, (int, float, np.number)) or not (
            np.isfinite(until) and until > 0):
        raise SceneError(f"apply_force: until must be a time > 0 [s], got {until!r}")
    release = int(round(float(until) / dt)) if t == step * dt else step + int(
        round((float(until) - float(t)) / dt))
    if release <= step:
        raise SceneError(f"apply_force: until = {until:g} s falls on step {release} (dt = "
                         f"{dt:g} s, the nearest step), not after the present step {step}: the "
                         "force would never act; give a later time (at least one step on)")
    return release


def advance_releasing(sim, steps: int, step, chunk) -> None:
    """Take ``steps`` steps by ``chunk(n)``, stopping at each step where a timed force ends
    to release it (``sim._releases``: (step, rows) pairs; ``step()``: the present step); a
    release already due, as after a resume past it, is made first.  Serial and MPI alike."""
    end = step() + steps
    while True:
        for r in [r for r in getattr(sim, "_releases", ()) if r[0] <= step()]:
            sim.handles.point_force[r[1]] = 0.0
            sim._releases.remove(r)
        stop = min([r[0] for r in getattr(sim, "_releases", ()) if r[0] < end], default=end)
        if stop <= step():
            return
        chunk(stop - step())


def handle_fields(sim) -> dict | None:
    """A frame's handles as per-point fields of its ``.vtu`` (copies; None without any
    handle, handles trial: they were invisible in ParaView): ``pinned`` (1 or 0),
    ``point_force`` [N] (n, 3) and ``gravity_scale`` [-]."""
    hd = getattr(sim, "handles", None)
    if hd is None or not hd.active:
        return None
    return {"pinned": (hd.pinned != 0).astype(np.float64),
            "point_force": hd.point_force.copy(), "gravity_scale": hd.gravity_scale.copy()}


def drop_releases(sim, idx) -> None:
    """Forget pending releases of the points ``idx`` (their force is being replaced)."""
    pending = getattr(sim, "_releases", None)
    if pending:
        sim._releases = [(r, keep) for r, rows in pending
                         if (keep := np.setdiff1d(rows, idx)).size]


def _vec3(value, what: str) -> np.ndarray:
    """A 3-vector, or a :class:`SceneError` naming ``what``."""
    try:
        v = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be 3 numbers (x, y, z), got {value!r}") from None
    if not np.all(np.isfinite(v)):
        raise SceneError(f"{what} must be finite, got {value!r}")
    return v
