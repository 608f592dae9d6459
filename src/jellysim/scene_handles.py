"""A scene's ``[[handle]]`` tables (pins, forces, gravity scales): checked when the scene
loads, applied through the simulator's handle methods (:mod:`jellysim.handles`)."""
from __future__ import annotations

import warnings

import numpy as np

from .errors import SceneError, did_you_mean
from .handle_paths import shake_path
from .handles import HANDLE_KINDS, PinPath, select_points
from .scene_spec import table_list

__all__ = ["apply_handle_tables", "validate_handle_tables"]

_HANDLE_KEYS = {"kind", "box", "sphere", "indices", "path", "shake", "force", "until", "scale"}
_SHAKE_KEYS = {"amplitude", "frequency", "seconds", "start"}


def validate_handle_tables(entries, name: str) -> list[dict]:
    """Check ``[[handle]]`` tables of a scene: ``kind`` ('pin', 'force', 'gravity'), one
    selection (``box = [[x0, y0, z0], [x1, y1, z1]]``, ``sphere = {center = [...], radius =
    r}``, ``indices = [...]``), and ``path`` (pin, optional: rows [t, dx, dy, dz]), ``force``
    ([fx, fy, fz] N, total; ``until``: its release time [s], optional), ``scale`` (gravity
    factor)."""
    entries = table_list(entries, name, "handle")
    out = []
    for k, entry in enumerate(entries, start=1):
        where = f"{name}: [[handle]] #{k}"
        entry = {key: v for key, v in entry.items()  # (a validated table: its own notes)
                 if not key.startswith("_")}
        extra = sorted(set(entry) - _HANDLE_KEYS)
        if extra:
            hint = did_you_mean(extra[0], sorted(_HANDLE_KEYS))
            raise SceneError(f"{where}: unknown key '{extra[0]}'{hint}; allowed: "
                             + ", ".join(sorted(_HANDLE_KEYS)))
        kind = entry.get("kind")
        if kind not in HANDLE_KINDS:
            raise SceneError(f"{where} kind = {kind!r}: expected one of "
                             + "; ".join(f"'{k}' ({v})" for k, v in HANDLE_KINDS.items()))
        chosen = [key for key in ("box", "sphere", "indices") if key in entry]
        if len(chosen) != 1:
            raise SceneError(f"{where}: give exactly one selection: box = [[x0, y0, z0], "
                             "[x1, y1, z1]], sphere = {center = [x, y, z], radius = r} or "
                             "indices = [i, j, ...]")
        sphere = entry.get("sphere")
        if sphere is not None and not (isinstance(sphere, dict)
                                       and set(sphere) == {"center", "radius"}):
            raise SceneError(f"{where}: sphere must be {{center = [x, y, z], radius = r}} (m)")
        needs = {"pin": (), "force": ("force",), "gravity": ("scale",)}[kind]
        for key in needs:
            if key not in entry:
                raise SceneError(f"{where}: kind = '{kind}' needs '{key}'")
        allowed = {"pin": {"path", "shake"}, "force": {"force", "until"},
                   "gravity": {"scale"}}[kind]
        stray = [key for key in ("path", "shake", "force", "until", "scale")
                 if key in entry and key not in allowed]
        if stray:
            raise SceneError(f"{where}: '{stray[0]}' is not used by kind = '{kind}'")
        if "path" in entry and "shake" in entry:
            raise SceneError(f"{where}: give path or shake, not both (a shake is a path)")
        if "shake" in entry:
            _shake_rows(entry["shake"], where)  # (checked now; made when the run starts)
        if "path" in entry:  # a scene pins at t = 0
            PinPath.of(entry["path"], what=f"{where} path").starting_at(0.0, f"{where} path")
        if "force" in entry:
            try:
                f = np.asarray(entry["force"], dtype=np.float64).reshape(3)
            except (TypeError, ValueError):
                raise SceneError(f"{where}: force must be [fx, fy, fz] (N)") from None
            if not np.all(np.isfinite(f)):
                raise SceneError(f"{where}: force must be finite")
        until = entry.get("until")
        if until is not None and (isinstance(until, bool) or not isinstance(until, (int, float))
                                  or not (np.isfinite(until) and until > 0)):
            raise SceneError(f"{where}: until must be a time > 0 [s] (when the force is "
                             f"released), got {until!r}")
        if "scale" in entry and not (isinstance(entry["scale"], (int, float))
                                     and np.isfinite(entry["scale"])):
            raise SceneError(f"{where}: scale must be a finite number")
        out.append(dict(entry, _where=f"[[handle]] #{k}"))
    return out


def _shake_rows(shake, where: str) -> np.ndarray:
    """The keyframes of a ``shake = {amplitude = [...], frequency = f, seconds = s}`` table
    (:func:`jellysim.handle_paths.shake_path`; ``start`` optional, default 0)."""
    if not isinstance(shake, dict):
        raise SceneError(f"{where}: shake must be {{amplitude = [ax, ay, az], frequency = f, "
                         f"seconds = s}} (m, Hz, s), got {shake!r}")
    extra = sorted(set(shake) - _SHAKE_KEYS)
    if extra:
        hint = did_you_mean(extra[0], sorted(_SHAKE_KEYS))
        raise SceneError(f"{where}: shake: unknown key '{extra[0]}'{hint}; allowed: "
                         + ", ".join(sorted(_SHAKE_KEYS)))
    missing = [key for key in ("amplitude", "frequency", "seconds") if key not in shake]
    if missing:
        raise SceneError(f"{where}: shake needs '{missing[0]}' (amplitude [m], frequency "
                         "[Hz], seconds [s])")
    try:
        return shake_path(shake["amplitude"], shake["frequency"], seconds=shake["seconds"],
                          start=shake.get("start", 0.0))
    except SceneError as exc:
        raise SceneError(f"{where}: {str(exc).replace('shake_path: ', 'shake ')}") from None


def apply_handle_tables(sim, tables, springs_reason: str | None = None) -> None:
    """Apply validated ``[[handle]]`` tables to a :class:`~jellysim.simulator.Simulator`;
    points are selected at their positions when the run starts.  ``springs_reason``: why the
    scene runs its body on springs (:func:`jellysim.physics.policy.springs_reason`), said
    when the tables need the physical path."""
    if tables and springs_reason and not sim.physical:
        raise SceneError(f"[[handle]] needs the physical (FEM) path, but this body runs on "
                         f"springs: {springs_reason}")
    x = sim.state.x
    pinned_by = {}  # point -> the pin table holding it
    taken = {"force": {}, "gravity": {}}  # point -> the force / gravity table on it
    for entry in tables:
        sphere = entry.get("sphere")
        idx = select_points(x, box=entry.get("box"),
                            sphere=None if sphere is None else (sphere["center"],
                                                                sphere["radius"]),
                            indices=entry.get("indices"), what=entry["_where"])
        if entry["kind"] == "pin":
            path = (_shake_rows(entry["shake"], entry["_where"]) if "shake" in entry
                    else entry.get("path"))
            moving = path is not None
            both = [int(i) for i in idx if int(i) in pinned_by
                    and (moving or pinned_by[int(i)][1])]
            if both:  # (the later pin silently replaced the earlier on those points; two
                # fixed pins agree, so only a path makes an overlap ambiguous)
                raise SceneError(f"{entry['_where']} pins {len(both)} point(s) that "
                                 f"{pinned_by[both[0]][0]} already pins (point {both[0]}), one "
                                 "of them along a path: a point follows one pin; make the "
                                 "selections disjoint")
            pinned_by.update({int(i): (entry["_where"], moving) for i in idx})
            sim.pin(idx, path=path)
            continue
        kind = "force" if entry["kind"] == "force" else "gravity"
        both = [int(i) for i in idx if int(i) in taken[kind]]
        if both:  # (the later table silently replaced the earlier one on those points)
            what = "pushes" if kind == "force" else "scales gravity on"
            raise SceneError(f"{entry['_where']} {what} {len(both)} point(s) that "
                             f"{taken[kind][both[0]]} already does (point {both[0]}): each "
                             f"point takes one {kind} table (a later one would replace the "
                             "earlier there); make the selections disjoint, or give the "
                             "overlap its own table with the combined value")
        taken[kind].update({int(i): entry["_where"] for i in idx})
        try:
            with warnings.catch_warnings():  # (said below, naming the tables)
                warnings.filterwarnings("ignore", message=".*a pinned point follows its pin")
                if kind == "force":
                    sim.apply_force(idx, entry["force"], until=entry.get("until"))
                else:
                    sim.set_gravity_scale(idx, entry["scale"])
        except (SceneError, ValueError, TypeError) as exc:  # name the table, not the call
            msg = str(exc).removeprefix("apply_force: ").removeprefix("set_gravity_scale: ")
            raise SceneError(f"{entry['_where']} {msg}") from None
    for kind, what in (("force", "pushes"), ("gravity", "scales gravity on")):
        held = sorted(set(taken[kind]) & set(pinned_by))
        if held:
            warnings.warn(f"{taken[kind][held[0]]} {what} {len(held)} pinned point(s) "
                          f"(point {held[0]}, pinned by {pinned_by[held[0]][0]}): a pinned "
                          f"point follows its pin, so the {kind} table does nothing there",
                          UserWarning, stacklevel=2)
