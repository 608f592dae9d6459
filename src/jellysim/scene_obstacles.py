"""``[[obstacle]]`` tables of a scene: their schema and validation (see :mod:`jellysim.scene`)."""
from __future__ import annotations

from .errors import SceneError
from .params import GroundParams
from .scene_spec import REQUIRED, Spec, table_list
from .scene_spec import check_table as _table
from .physics.contact import Box, Plane, Sphere

_G = GroundParams()

__all__ = ["OBSTACLE_SCHEMA", "OBSTACLE_KEYS", "validate_obstacles", "make_obstacle"]

OBSTACLE_SCHEMA: dict[str, Spec] = {
    "kind": Spec("str", REQUIRED, "'plane', 'sphere' or 'box'.",
                 choices=("plane", "sphere", "box")),
    "point": Spec("vec3", None, "Plane: a point on it [m]."),
    "normal": Spec("vec3", None, "Plane: its outward normal (any length > 0)."),
    "center": Spec("vec3", None, "Sphere: centre [m]."),
    "radius": Spec("float", None, "Sphere: radius [m].", lambda v: v > 0, "a number > 0 (m)"),
    "lower": Spec("vec3", None, "Box: lower corner [m]."),
    "upper": Spec("vec3", None, "Box: upper corner [m]."),
    "restitution": Spec("float", _G.restitution, "Coefficient of restitution e.", lambda v: 0 <= v <= 1,
                        "a number in [0, 1]"),
    "friction": Spec("float", _G.friction, "Kinetic Coulomb friction coefficient.", lambda v: v >= 0,
                     "a number >= 0"),
    "static_friction": Spec("float", None, "Static Coulomb coefficient (default: friction).",
                            lambda v: v >= 0, "a number >= 0"),
    "slip_distance": Spec("float", _G.slip_distance, "Slip [m] over which a point's friction "
                          "falls from static to kinetic.", lambda v: v >= 0,
                          "a length >= 0 (m)"),
    "no_slip": Spec("bool", False, "A point touching it never moves along it (adhesion); "
                    "explicit integrators only."),
}
"""``[[obstacle]]`` tables: static obstacles with restitution and Coulomb friction (contact
model; used with every integrator)."""
OBSTACLE_KEYS = {"plane": ("point", "normal"), "sphere": ("center", "radius"),
                 "box": ("lower", "upper")}


def validate_obstacles(entries, name: str) -> list[dict]:
    entries = table_list(entries, name, "obstacle")
    out = []
    for k, entry in enumerate(entries, start=1):
        where = f"[[obstacle]] #{k}"
        values = _table(name, where, entry, OBSTACLE_SCHEMA)
        kind = values["kind"]
        for key in OBSTACLE_KEYS[kind]:
            if values[key] is None:
                raise SceneError(f"{name}: {where} missing value '{key}' (needed for kind "
                                 f"= {kind!r}): {OBSTACLE_SCHEMA[key].doc}")
        extra = [key for key in ("point", "normal", "center", "radius", "lower", "upper")
                 if entry.get(key) is not None and key not in OBSTACLE_KEYS[kind]]
        if extra:
            raise SceneError(f"{name}: {where} '{extra[0]}' is not used by kind = {kind!r};"
                             f" it takes {', '.join(OBSTACLE_KEYS[kind])}")
        try:
            make_obstacle(values).row()
        except ValueError as exc:
            raise SceneError(f"{name}: {where}: {exc}") from None
        out.append(values)
    return out

def make_obstacle(values: dict):
    material = {k: values[k] for k in ("restitution", "friction", "static_friction")}
    material["no_slip"] = bool(values.get("no_slip", False))  # (not in older trajectories)
    material["slip_distance"] = float(values.get("slip_distance", _G.slip_distance))
    kind = values["kind"]
    if kind == "plane":
        return Plane(point=tuple(values["point"]), normal=tuple(values["normal"]),
                     **material)
    if kind == "sphere":
        return Sphere(center=tuple(values["center"]), radius=values["radius"], **material)
    return Box(lower=tuple(values["lower"]), upper=tuple(values["upper"]), **material)
