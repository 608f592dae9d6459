"""Scene files: one TOML file holds every parameter of a run.

Every key is checked against :data:`SCHEMA`; any problem raises :class:`SceneError` with one line
naming the file, the ``[section] key`` and what is allowed.  See ``docs/scene.md`` for the
format (generated from the same schema: ``jellysim scene-help``).
"""
from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import SceneError

__all__ = ["Scene", "SCHEMA", "Spec", "schema_markdown"]

REQUIRED = object()


@dataclass(frozen=True)
class Spec:
    kind: str
    """``float``, ``int``, ``bool``, ``str``, ``vec3`` or ``path``."""
    default: Any
    doc: str
    check: Callable[[Any], bool] | None = None
    allowed: str = ""
    """Words for the allowed range, used in error messages."""
    choices: tuple[str, ...] = ()


def _pos(doc, default=REQUIRED, unit=""):
    return Spec("float", default, doc, lambda v: v > 0, f"a number > 0{unit}")


def _nonneg(doc, default, unit=""):
    return Spec("float", default, doc, lambda v: v >= 0, f"a number >= 0{unit}")


SCHEMA: dict[str, dict[str, Spec]] = {
    "body": {
        "type": Spec("str", "box", "Where the body comes from: 'box' (a random field), 'mesh' "
                     "(points inside a surface mesh file) or 'file' (a .jello/.npz body).",
                     choices=("box", "mesh", "file")),
        "path": Spec("str", None, "Mesh or body file (type 'mesh' / 'file'), relative to the "
                     "scene file.", allowed="a file name"),
        "points": Spec("int", None, "Number of points: of the random field (type 'box', "
                       "required) or sampled inside the mesh (type 'mesh', default 2000).",
                       lambda v: v >= 2, "an integer >= 2"),
        "sampling": Spec("str", "uniform", "Type 'mesh': how points are placed inside.",
                         choices=("uniform", "edge", "grid", "poisson")),
        "surface_samples": Spec("bool", True, "Type 'mesh', connect 'delaunay': also put points "
                                "on the surface (sharp edges, faces) a spacing apart, so the "
                                "body's surface lies on the mesh; false is the report's way "
                                "(the mesh's vertices only)."),
        "size": Spec("float", None, "Type 'mesh': scale the mesh so its largest extent is this "
                     "[m].", lambda v: v > 0, "a number > 0 (m)"),
        "base": Spec("vec3", None, "Types 'mesh'/'file': move the body so the bottom centre of "
                     "its bounding box is here [m]."),
        "distribution": Spec("str", "edge", "Random field: 'uniform' or the report's "
                             "edge-favouring (1 + cos(2 pi u)) / 2; or 'grid': a cubic lattice "
                             "of about that many points (use radius = 1.8 spacings).",
                             choices=("uniform", "edge", "grid")),
        "lower": Spec("vec3", [0.0, 0.0, 0.0], "Lower box corner [m]."),
        "upper": Spec("vec3", [1.0, 1.0, 1.0], "Upper box corner [m]."),
        "seed": Spec("int", 0, "Random seed (same seed, same points).", lambda v: v >= 0,
                     "an integer >= 0"),
    },
    "springs": {
        "connect": Spec("str", "radius", "Spring builder: 'radius' (report: implicit); for "
                        "type 'mesh' also 'marching', 'delaunay', 'tetgen'.",
                        choices=("radius", "marching", "delaunay", "tetgen")),
        "radius": _pos("Connection radius r [m]: every pair closer than r gets a spring "
                       "(required for type 'box'; type 'mesh': default from neighbours).", None,
                       unit=" (m)"),
        "neighbours": _pos("Type 'mesh', radius not given: target mean springs per point.",
                           24.0),
        "h": _pos("Type 'mesh', connect 'marching': cube edge [m] (default from points).", None,
                  unit=" (m)"),
        "stiffness": Spec("float", None, "Spring stiffness k [N/m] (paper mode; give this or "
                          "[material] youngs_modulus).", lambda v: v > 0, "a number > 0 (N/m)"),
    },
    "material": {
        "preset": Spec("str", None, "Preset filling every key not given: 'gelatin' (real "
                       "gelatin, physical ground, implicit) or 'paper-2010' (the report's "
                       "constants and hacks).", choices=("gelatin", "paper-2010")),
        "density": _pos("Density [kg/m^3]; point masses = density x the volume each point "
                        "owns (overrides [mass] density).", None, " (kg/m^3)"),
        "youngs_modulus": _pos("Young's modulus E [Pa]: every spring's stiffness is derived so "
                               "the network's modulus is E (docs/physics.md).", None, " (Pa)"),
    },
    "mass": {
        "density": _pos("Density [kg/m^3]; total mass = density x volume, split evenly.",
                        1141.0, " (kg/m^3)"),
        "point_mass": Spec("float", None, "Mass of every point [kg] (overrides density).",
                           lambda v: v > 0, "a number > 0 (kg)"),
    },
    "physics": {
        "damping": _nonneg("Velocity damping delta [kg/s] (report eq. 1).", 0.0, " (kg/s)"),
        "gravity": Spec("vec3", [0.0, -9.8, 0.0], "Gravitational acceleration [m/s^2]."),
    },
    "integrator": {
        "name": Spec("str", "symplectic", "'paper' (report order: x, v, then a), "
                     "'symplectic' (semi-implicit Euler) or 'implicit' (theta-method with a "
                     "conjugate-gradient solve, stiff-stable).",
                     choices=("paper", "symplectic", "implicit")),
        "dt": _pos("Time step [s].", unit=" (s)"),
        "steps": Spec("int", REQUIRED, "Number of time steps.", lambda v: v >= 1,
                      "an integer >= 1"),
        "backend": Spec("str", "numba", "Kernels: 'numba' or 'numpy' (reference).",
                        choices=("numba", "numpy")),
        "threads": Spec("int", None, "Numba threads (default: by problem size).",
                        lambda v: v >= 1, "an integer >= 1"),
        "substeps": Spec("int", 1, "Steps of dt / substeps per step.", lambda v: v >= 1,
                         "an integer >= 1"),
        "scheme": Spec("str", "theta", "Implicit: 'theta' (one step, see theta) or 'bdf2' "
                       "(two-step, second order: keeps a frame-rate wobble, 0.90 of its "
                       "energy per period at 2.8 Hz and dt = 1/60 s; less robust through "
                       "impacts).",
                       choices=("theta", "bdf2")),
        "theta": Spec("float", 1.0, "Implicit: 1 = backward Euler (robust, damps), 0.5 = "
                      "midpoint (no damping of linear vibrations).", lambda v: 0.5 <= v <= 1,
                      "a number in [0.5, 1]"),
        "cg_tolerance": _pos("Implicit: relative residual at which CG stops.", 1e-3),
        "cg_max_iterations": Spec("int", 300, "Implicit: CG iterations per step at most.",
                                  lambda v: v >= 1, "an integer >= 1"),
    },
    "provot": {
        "enabled": Spec("bool", True, "Provot strain limiting on/off."),
        "tau": Spec("float", 0.001, "Tolerance as a fraction of rest length (0.001 = 0.1 %).",
                    lambda v: 0 < v < 1, "a number in (0, 1)"),
        "loops": Spec("int", 5, "Passes per step (report: 5).", lambda v: v >= 1,
                      "an integer >= 1"),
        "pairs": Spec("str", "springs", "'springs' or 'all' (the report's O(n^2) hack).",
                      choices=("springs", "all")),
        "order": Spec("str", "jacobi", "'jacobi' (parallel, averaged) or 'gauss-seidel'.",
                      choices=("jacobi", "gauss-seidel")),
        "tolerance": _nonneg("Stop the loops once the largest correction is below this [m].",
                             0.0, " (m)"),
        "velocity_update": Spec("bool", True, "Add the correction / dt to the velocity."),
    },
    "ground": {
        "enabled": Spec("bool", True, "The report's ground plane on/off."),
        "model": Spec("str", "paper", "'paper': the report's mu/nu rule (eqs. 2, 3); "
                      "'contact': non-penetration, restitution, Coulomb friction.",
                      choices=("paper", "contact")),
        "height": Spec("float", 0.0, "Height of the plane y = height [m]."),
        "mu": Spec("float", 0.1, "Factor on x/z velocity of a point on the ground.",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "nu": Spec("float", 0.2, "Fraction of y acceleration removed on the ground.",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "restitution": Spec("float", 0.3, "Contact: coefficient of restitution e.",
                            lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "friction": _nonneg("Contact: kinetic Coulomb friction coefficient.", 0.6),
        "static_friction": Spec("float", None, "Contact: static Coulomb coefficient "
                                "(default: friction).", lambda v: v >= 0, "a number >= 0"),
    },
    "output": {
        "every": Spec("int", None, "Steps between saved frames (default: about 100 frames).",
                      lambda v: v >= 1, "an integer >= 1"),
        "vtu": Spec("bool", True, "Write the ParaView series body.pvd + one .vtu per frame."),
    },
}
REQUIRED_SECTIONS = ("body", "springs", "integrator")

OBSTACLE_SCHEMA: dict[str, Spec] = {
    "kind": Spec("str", REQUIRED, "'plane', 'sphere' or 'box'.",
                 choices=("plane", "sphere", "box")),
    "point": Spec("vec3", None, "Plane: a point on it [m]."),
    "normal": Spec("vec3", None, "Plane: its outward normal (any length > 0)."),
    "center": Spec("vec3", None, "Sphere: centre [m]."),
    "radius": Spec("float", None, "Sphere: radius [m].", lambda v: v > 0, "a number > 0 (m)"),
    "lower": Spec("vec3", None, "Box: lower corner [m]."),
    "upper": Spec("vec3", None, "Box: upper corner [m]."),
    "restitution": Spec("float", 0.3, "Coefficient of restitution e.", lambda v: 0 <= v <= 1,
                        "a number in [0, 1]"),
    "friction": Spec("float", 0.6, "Kinetic Coulomb friction coefficient.", lambda v: v >= 0,
                     "a number >= 0"),
    "static_friction": Spec("float", None, "Static Coulomb coefficient (default: friction).",
                            lambda v: v >= 0, "a number >= 0"),
}
"""``[[obstacle]]`` tables: static obstacles with restitution and Coulomb friction (contact
model; used with every integrator)."""
OBSTACLE_KEYS = {"plane": ("point", "normal"), "sphere": ("center", "radius"),
                 "box": ("lower", "upper")}


def schema_markdown() -> str:
    """The scene format as a Markdown table (for docs/scene.md)."""
    lines = []
    for section, keys in SCHEMA.items():
        lines += [f"### `[{section}]`", "", "| key | type | default | allowed | meaning |",
                  "|---|---|---|---|---|"]
        for key, spec in keys.items():
            default = "**required**" if spec.default is REQUIRED else f"`{spec.default!r}`"
            allowed = spec.allowed or (", ".join(f"`{c}`" for c in spec.choices))
            lines.append(f"| `{key}` | {spec.kind} | {default} | {allowed} | {spec.doc} |")
        lines.append("")
    lines += ["### `[[obstacle]]` (any number)", "",
              "Static obstacles with restitution and Coulomb friction.  A plane takes `point` "
              "and `normal`, a sphere `center` and `radius`, a box `lower` and `upper`.", "",
              "| key | type | default | allowed | meaning |", "|---|---|---|---|---|"]
    for key, spec in OBSTACLE_SCHEMA.items():
        default = "**required**" if spec.default is REQUIRED else f"`{spec.default!r}`"
        allowed = spec.allowed or (", ".join(f"`{c}`" for c in spec.choices))
        lines.append(f"| `{key}` | {spec.kind} | {default} | {allowed} | {spec.doc} |")
    return "\n".join(lines)


def _check(name: str, section: str, key: str, spec: Spec, value: Any) -> Any:
    label = section if section.startswith("[") else f"[{section}]"
    where = f"{name}: {label} {key}"
    kind = spec.kind

    def fail(problem: str, allowed: str) -> SceneError:
        return SceneError(f"{where} = {value!r}: {problem}; expected {allowed}")

    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail("wrong type", spec.allowed or "a number")
        value = float(value)
        if not math.isfinite(value):
            raise fail("not a finite number", spec.allowed or "a finite number")
    elif kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise fail("wrong type", spec.allowed or "an integer")
    elif kind == "bool":
        if not isinstance(value, bool):
            raise fail("wrong type", "true or false")
    elif kind == "str":
        if not isinstance(value, str):
            raise fail("wrong type", spec.allowed or
                       "one of " + ", ".join(repr(c) for c in spec.choices))
        if spec.choices and value not in spec.choices:
            raise fail("unknown choice", "one of " + ", ".join(repr(c) for c in spec.choices))
    elif kind == "vec3":
        ok = (isinstance(value, list) and len(value) == 3 and all(
            isinstance(c, (int, float)) and not isinstance(c, bool) for c in value))
        if not ok:
            raise fail("wrong type", "a list of three numbers, e.g. [0.0, -9.8, 0.0]")
        value = [float(c) for c in value]
        if not all(math.isfinite(c) for c in value):
            raise fail("not finite", "three finite numbers")
    if spec.check is not None and not spec.check(value):
        raise fail("out of range", spec.allowed)
    return value


def _table(name: str, label: str, given: dict, keys: dict[str, Spec]) -> dict:
    """One table checked against ``keys``: unknown keys, missing required values and each
    value (:func:`_check`); defaults filled in.  ``label`` names it (``[section]``)."""
    for key in given:
        if key not in keys:
            near = difflib.get_close_matches(key, keys, n=1)
            hint = f" (did you mean '{near[0]}'?)" if near else ""
            raise SceneError(f"{name}: {label} unknown key '{key}'{hint}; allowed: "
                             + ", ".join(keys))
    values = {}
    for key, spec in keys.items():
        if key in given and given[key] is None and spec.default is None:
            values[key] = None  # "not set" (only reachable from Python dicts)
        elif key in given:
            values[key] = _check(name, label, key, spec, given[key])
        elif spec.default is REQUIRED:
            raise SceneError(f"{name}: {label} missing value '{key}': {spec.doc} "
                             f"Expected {spec.allowed or spec.kind}.")
        else:
            values[key] = spec.default
    return values


class Scene:
    """A validated scene: ``scene.params[section][key]`` with every default filled in."""

    def __init__(self, params: dict, *, text: str = "", name: str = "<scene>"):
        self.params = params
        self.text = text
        self.name = name

    @classmethod
    def load(cls, path) -> "Scene":
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise SceneError(f"{path}: scene file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise SceneError(f"{path}: cannot read the scene file ({exc})") from None
        return cls.from_text(text, name=str(path))

    @classmethod
    def from_text(cls, text: str, *, name: str = "<scene>") -> "Scene":
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{name}: not valid TOML: {exc}") from None
        return cls(cls._validate(raw, name), text=text, name=name)

    @classmethod
    def from_dict(cls, raw: dict, *, name: str = "<scene>") -> "Scene":
        return cls(cls._validate(raw, name), name=name)

    @staticmethod
    def _validate(raw: dict, name: str) -> dict:
        preset = raw.get("material", {}).get("preset") if isinstance(
            raw.get("material"), dict) else None
        if preset is not None:
            from .presets import PRESETS, apply_preset

            if preset not in PRESETS:
                raise SceneError(f"{name}: [material] preset = {preset!r}: unknown choice; "
                                 "expected one of " + ", ".join(repr(p) for p in PRESETS))
            raw = apply_preset(raw, preset)
        out: dict[str, dict] = {}
        raw = dict(raw)
        obstacles = Scene._validate_obstacles(raw.pop("obstacle", []), name)
        for section in raw:
            if section not in SCHEMA:
                near = difflib.get_close_matches(section, SCHEMA, n=1)
                hint = f" (did you mean [{near[0]}]?)" if near else ""
                raise SceneError(f"{name}: unknown section [{section}]{hint}; allowed: "
                                 + ", ".join(f"[{s}]" for s in SCHEMA))
            if not isinstance(raw[section], dict):
                raise SceneError(f"{name}: '{section}' must be a [{section}] table")
        for section in REQUIRED_SECTIONS:
            if section not in raw:
                raise SceneError(f"{name}: missing section [{section}]")
        for section, keys in SCHEMA.items():
            out[section] = _table(name, f"[{section}]", raw.get(section, {}), keys)
        mat, spr = out["material"], out["springs"]
        if mat["youngs_modulus"] is None and spr["stiffness"] is None:
            raise SceneError(f"{name}: give [springs] stiffness (N/m) or [material] "
                             "youngs_modulus (Pa), or [material] preset = 'gelatin'")
        if mat["youngs_modulus"] is not None and spr["stiffness"] is not None:
            raise SceneError(f"{name}: [springs] stiffness and [material] youngs_modulus both "
                             "set; give one (youngs_modulus derives every spring's stiffness)")
        it = out["integrator"]
        if it["name"] == "implicit" and out["provot"]["enabled"] and "provot" in raw and (
                "enabled" in raw["provot"]):
            raise SceneError(f"{name}: [provot] enabled = true is not used by the implicit "
                             "integrator; set it to false")
        if it["name"] == "implicit":
            out["provot"]["enabled"] = False
        b, sp = out["body"], out["springs"]
        kind = b["type"]
        if kind == "box":
            for key, sec in (("points", b), ("radius", sp)):
                if sec[key] is None:
                    section = "body" if sec is b else "springs"
                    raise SceneError(f"{name}: [{section}] missing value '{key}' (needed for "
                                     f"[body] type = 'box')")
            if sp["connect"] != "radius":
                raise SceneError(f"{name}: [springs] connect = {sp['connect']!r}: box bodies "
                                 "use 'radius'; the tet builders need type = 'mesh'")
        else:
            if b["path"] is None:
                raise SceneError(f"{name}: [body] missing value 'path' (needed for type = "
                                 f"{kind!r}): the {'mesh' if kind == 'mesh' else 'body'} file")
            if kind == "mesh" and b["points"] is None:
                b["points"] = 2000
            if "surface_samples" in raw.get("body", {}) and (
                    kind != "mesh" or sp["connect"] != "delaunay"):
                raise SceneError(f"{name}: [body] surface_samples is used only by type = 'mesh' "
                                 "with [springs] connect = 'delaunay'; remove it")
            if kind == "file" and b["size"] is not None:
                raise SceneError(f"{name}: [body] size is not used for type = 'file' (a body "
                                 "file has its own units); use base to place it")
        if not all(u > lo for u, lo in zip(b["upper"], b["lower"])):
            raise SceneError(f"{name}: [body] upper = {b['upper']} must exceed lower = "
                             f"{b['lower']} in every coordinate")
        out["obstacle"] = obstacles
        return out

    @staticmethod
    def _validate_obstacles(entries, name: str) -> list[dict]:
        if isinstance(entries, dict):
            entries = [entries]
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise SceneError(f"{name}: obstacles are tables: write [[obstacle]] (double "
                             "brackets) before each one")
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
                     if key in entry and key not in OBSTACLE_KEYS[kind]]
            if extra:
                raise SceneError(f"{name}: {where} '{extra[0]}' is not used by kind = {kind!r};"
                                 f" it takes {', '.join(OBSTACLE_KEYS[kind])}")
            try:
                Scene._obstacle(values).row()
            except ValueError as exc:
                raise SceneError(f"{name}: {where}: {exc}") from None
            out.append(values)
        return out

    @staticmethod
    def _obstacle(values: dict):
        from .physics.contact import Box, Plane, Sphere

        material = {k: values[k] for k in ("restitution", "friction", "static_friction")}
        kind = values["kind"]
        if kind == "plane":
            return Plane(point=tuple(values["point"]), normal=tuple(values["normal"]),
                         **material)
        if kind == "sphere":
            return Sphere(center=tuple(values["center"]), radius=values["radius"], **material)
        return Box(lower=tuple(values["lower"]), upper=tuple(values["upper"]), **material)

    def obstacles(self) -> tuple:
        """The scene's static obstacles (:mod:`jellysim.physics.contact` objects)."""
        return tuple(self._obstacle(v) for v in self.params.get("obstacle", []))

    # -- building ---------------------------------------------------------------------------
    def resolve(self, path: str) -> Path:
        """A path from the scene, relative to the scene file's directory."""
        p = Path(path)
        if not p.is_absolute() and self.name not in ("<scene>", "demo"):
            p = Path(self.name).resolve().parent / p
        return p

    @property
    def surface(self):
        """The placed surface mesh of a type 'mesh' scene (vertices [m] (m, 3), faces
        (f, 3)) after :meth:`build_body`, else ``None``: the skin to carry."""
        return getattr(self, "_surface", None)

    def _place(self, points: np.ndarray) -> np.ndarray:
        b = self.params["body"]
        if b["base"] is None:
            return points
        lo, hi = points.min(axis=0), points.max(axis=0)
        bottom = np.array([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])])
        return points + (np.asarray(b["base"]) - bottom)

    def build_body(self):
        from .body import Body
        from .errors import JellysimError
        from .geometry.connect import radius_springs
        from .geometry.sampling import box_field

        b, s = self.params["body"], self.params["springs"]
        if b["type"] == "file":
            from dataclasses import replace

            from .geometry.jellyfile import read_body

            body = read_body(self.resolve(b["path"]))
            return replace(body, points=self._place(body.points))
        if b["type"] == "mesh":
            from .build import build_body
            from .geometry.mesh import Mesh, load_mesh

            path = self.resolve(b["path"])
            try:
                mesh = load_mesh(path)
            except JellysimError as exc:
                raise SceneError(f"{self.name}: [body] path: {exc}") from None
            v = np.asarray(mesh.vertices, dtype=np.float64)
            if b["size"] is not None:
                v = v * (b["size"] / float(np.ptp(v, axis=0).max()))
            v = self._place(v)
            placed = Mesh.from_arrays(v, mesh.faces, name=str(path))
            self._surface = (v, np.asarray(mesh.faces))
            mat = self.params["material"]
            density = mat["density"] if mat["density"] is not None else (
                self.params["mass"]["density"])
            return build_body(placed, points=b["points"], connect=s["connect"],
                              sampling=b["sampling"], radius=s["radius"],
                              neighbours=s["neighbours"], h=s["h"], density=density,
                              seed=b["seed"],
                              surface_samples=(b["surface_samples"] if s["connect"] == "delaunay"
                                               else None))
        if b["distribution"] == "grid":
            from .geometry.lattice import grid_points

            points = grid_points(b["points"], b["lower"], b["upper"])
        else:
            points = box_field(b["points"], b["lower"], b["upper"],
                               distribution=b["distribution"], seed=b["seed"])
        from .build import _radius_tets

        # tets for the tetrahedral elasticity: Delaunay of the points (a box is convex: nothing
        # to carve); the springs stay the radius springs
        points, tets, tet_info = _radius_tets(points, None, seed=b["seed"], name=self.name)
        springs = radius_springs(points, s["radius"])
        volume = float(np.prod(np.subtract(b["upper"], b["lower"])))
        return Body(points=points, springs=springs, tets=tets, volume=volume,
                    meta={"builder": "box", "distribution": b["distribution"],
                          "seed": b["seed"], "connect": "radius", "radius": s["radius"],
                          "tet_volume": tet_info["tet_volume"], "cloud_tets": tet_info})

    def build_model(self, body=None):
        from .model import finalize

        body = self.build_body() if body is None else body
        m, ph = self.params["mass"], self.params["physics"]
        mat = self.params["material"]
        density = mat["density"] if mat["density"] is not None else m["density"]
        try:
            if mat["youngs_modulus"] is not None:
                from dataclasses import replace

                from .physics.material import calibrate_springs, point_masses

                masses, pv = body.masses, None
                if body.meta.get("distribution") == "grid" and body.meta.get("connect") == "radius":
                    from .geometry.lattice import grid_point_volumes

                    pv = grid_point_volumes(body.points)
                if masses is None and m["point_mass"] is None:
                    masses = density * pv if pv is not None else point_masses(body, density)
                body = replace(body, stiffness=calibrate_springs(
                    body, mat["youngs_modulus"], point_volume=pv), masses=masses)
            return finalize(body, stiffness=self.params["springs"]["stiffness"],
                            density=density, point_mass=m["point_mass"],
                            damping=ph["damping"], gravity=ph["gravity"])
        except ValueError as exc:
            raise SceneError(f"{self.name}: {exc}") from None

    def provot_params(self):
        from .params import ProvotOrder, ProvotPairs, ProvotParams

        p = self.params["provot"]
        return ProvotParams(enabled=p["enabled"], tau=p["tau"], loops=p["loops"],
                            pairs=ProvotPairs(p["pairs"]), order=ProvotOrder(p["order"]),
                            tolerance=p["tolerance"], velocity_update=p["velocity_update"])

    def ground_params(self):
        from .params import GroundParams

        g = self.params["ground"]
        return GroundParams(enabled=g["enabled"], mu=g["mu"], nu=g["nu"], height=g["height"],
                            model=g["model"], restitution=g["restitution"],
                            friction=g["friction"], static_friction=g["static_friction"])

    def simulator(self, model=None, **overrides):
        from .simulator import Simulator

        model = self.build_model() if model is None else model
        it = self.params["integrator"]
        from .params import ImplicitParams

        kw = dict(dt=it["dt"], integrator=it["name"], provot=self.provot_params(),
                  ground=self.ground_params(), backend=it["backend"], threads=it["threads"],
                  substeps=it["substeps"],
                  implicit=ImplicitParams(scheme=it["scheme"], theta=it["theta"],
                                          tolerance=it["cg_tolerance"],
                                          max_iterations=it["cg_max_iterations"]),
                  obstacles=self.obstacles())
        kw.update(overrides)
        return Simulator(model, **kw)

    @property
    def steps(self) -> int:
        return int(self.params["integrator"]["steps"])

    @property
    def frame_every(self) -> int:
        every = self.params["output"]["every"]
        return every if every is not None else max(1, math.ceil(self.steps / 100))
