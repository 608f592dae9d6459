"""Scene files: one TOML file holds every parameter of a run.

Every key is checked against :data:`SCHEMA`; any problem raises :class:`SceneError` with one line
naming the file, the ``[section] key`` and what is allowed.  See ``docs/scene.md`` for the
format (generated from the same schema: ``jellysim scene-help``).
"""
from __future__ import annotations

import difflib
import math
import tomllib
from pathlib import Path

import numpy as np

from .errors import JellysimError, SceneError
from .params import (GRAVITY, MAX_ALL_PAIRS_POINTS, REPORT_DENSITY, GroundParams, ImplicitParams,
                     ProvotOrder, ProvotPairs, ProvotParams)
# Spec (one row of the schema) and the checks live in scene_spec; SCHEMA stays here
from .scene_obstacles import (OBSTACLE_KEYS, OBSTACLE_SCHEMA,  # noqa: F401 (re-exported)
                              make_obstacle, validate_obstacles)
from .scene_spec import (REQUIRED, Spec, _nonneg, _pos, as_toml, check_backend, check_value,
                         grid_radius, missing_path, refuse_unused_keys)
from .scene_spec import apply_override as _override
from .scene_spec import check_table as _table
from .scene_doc import schema_markdown as make
from .handles import apply_handle_tables, validate_handle_tables
from .resources import check_body_memory
from .body import Body
from .model import finalize
from .physics.policy import scene_fem_model, scene_material, springs_reason
from .simulator import Simulator
from .presets import PRESETS, apply_preset

__all__ = ["Scene", "SCHEMA", "Spec", "schema_markdown"]

_P, _G, _I = ProvotParams(), GroundParams(), ImplicitParams()
"""Defaults come from the option dataclasses (:mod:`jellysim.params`), the one source."""

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
        "surface_samples": Spec("bool", None, "Type 'mesh', connect 'delaunay' or 'radius': "
                                "also put points on the surface (sharp edges, faces) a spacing "
                                "apart, so the body's surface lies on the mesh (default: on for "
                                "'delaunay', off for 'radius', the report's ways: mesh vertices "
                                "only / exactly `points` inside).  A physical radius body wants "
                                "it on: without flat faces it rests on its lowest points."),
        "relax": Spec("int", None, "Type 'mesh', connect 'delaunay': Lloyd passes of the "
                      "sampled interior points before the tetrahedralization (default 10 with "
                      "surface samples, 0 without; 0 is the report's random points).  Relaxed "
                      "points make far fewer flat tets: fewer substeps and far fewer inverted "
                      "tets on hard drops (docs/physics.md section 0).", lambda v: v >= 0,
                      "an integer >= 0"),
        "size": Spec("float", None, "Type 'mesh': scale the mesh so its largest extent is this "
                     "[m].", lambda v: v > 0, "a number > 0 (m)"),
        "base": Spec("vec3", None, "Types 'mesh'/'file': move the body so the bottom centre of "
                     "its bounding box is here [m]."),
        "distribution": Spec("str", "edge", "Random field: 'uniform' or the report's "
                             "edge-favouring (1 + cos(2 pi u)) / 2; or 'grid': a cubic lattice "
                             "of about that many cells, corners included (216: 7^3 points).",
                             choices=("uniform", "edge", "grid")),
        "lower": Spec("vec3", [0.0, 0.0, 0.0], "Lower box corner [m]."),
        "upper": Spec("vec3", [1.0, 1.0, 1.0], "Upper box corner [m]."),
        "seed": Spec("int", 0, "Random seed (same seed, same points).", lambda v: v >= 0,
                     "an integer >= 0"),
        "velocity": Spec("vec3", [0.0, 0.0, 0.0], "Initial velocity of every point [m/s]."),
    },
    "springs": {
        "connect": Spec("str", "radius", "Spring builder: 'radius' (report: implicit); for "
                        "type 'mesh' also 'marching', 'delaunay', 'tetgen'.",
                        choices=("radius", "marching", "delaunay", "tetgen")),
        "radius": _pos("Connection radius r [m]: every pair closer than r gets a spring "
                       "(type 'box': required, but 1.8 spacings for a grid; type 'mesh': "
                       "default from neighbours).", None,
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
                       "gelatin: Stable Neo-Hookean tets, physical ground, symplectic substeps) "
                       "or 'paper-2010' (the report's "
                       "constants and hacks).", choices=("gelatin", "paper-2010")),
        "density": _pos("Density [kg/m^3]; point masses = density x the volume each point "
                        "owns (overrides [mass] density).", None, " (kg/m^3)"),
        "youngs_modulus": _pos("Young's modulus E [Pa] of a physical material: Stable "
                               "Neo-Hookean tets (model 'fem') or calibrated springs (model "
                               "'springs'), docs/physics.md.", None, " (Pa)"),
        "model": Spec("str", "auto", "Physical material model: 'fem' (tets that resist "
                      "inversion and keep volume; needs a tet body), 'springs' (the report's "
                      "springs, each k derived from E) or 'auto' (fem when the body has tets).",
                      choices=("auto", "fem", "springs")),
        "poisson_ratio": Spec("float", 0.48, "Poisson's ratio nu of the fem model (gelatin: "
                              "nearly incompressible).", lambda v: -0.5 < v < 0.5,
                              "a number in (-0.5, 0.5)"),
        "damping_ratio": Spec("float", 0.0, "Fem model: fraction of critical damping zeta of a "
                              "vibration at damping_frequency (a standard linear solid).",
                              lambda v: 0 <= v < 1, "a number in [0, 1)"),
        "damping_frequency": _pos("Fem model: frequency [Hz] at which the damping ratio "
                                  "holds (the loss peak).", 5.0, " (Hz)"),
    },
    "mass": {
        "density": _pos("Density [kg/m^3]; total mass = density x volume, split evenly.",
                        REPORT_DENSITY, " (kg/m^3)"),
        "point_mass": Spec("float", None, "Mass of every point [kg] (overrides density).",
                           lambda v: v > 0, "a number > 0 (kg)"),
    },
    "physics": {
        "damping": _nonneg("Velocity damping delta [kg/s] (report eq. 1).", 0.0, " (kg/s)"),
        "gravity": Spec("vec3", list(GRAVITY), "Gravitational acceleration [m/s^2]."),
    },
    "integrator": {
        "name": Spec("str", "symplectic", "'paper' (report order: x, v, then a), "
                     "'symplectic' (semi-implicit Euler) or 'implicit' (theta-method with a "
                     "conjugate-gradient solve, stiff-stable).",
                     choices=("paper", "symplectic", "implicit")),
        "dt": _pos("Time step [s].", unit=" (s)"),
        "steps": Spec("int", REQUIRED, "Number of time steps.", lambda v: v >= 1,
                      "an integer >= 1"),
        "backend": Spec("str", "numba", "Kernels: 'numba', 'numpy' (reference) or 'warp' "
                        "(NVIDIA Warp: a GPU, else Warp's CPU device; integrators 'paper' and "
                        "'symplectic'; pip install 'jellysim[gpu]').",
                        choices=("numba", "numpy", "warp")),
        "device": Spec("str", "auto", "Warp device: 'auto' (a GPU when present, else the "
                       "CPU), 'cpu', 'cuda' or 'cuda:N' (backend = 'warp' only)."),
        "precision": Spec("str", "float64", "'float64' or 'float32': Warp arithmetic "
                          "(float64: bitwise the numba backend's on the CPU device); numba's "
                          "explicit step stores x, v, a in float32 and sums in float64.",
                          choices=("float64", "float32")),
        "threads": Spec("int", None, "Numba threads (default: by problem size).",
                        lambda v: v >= 1, "an integer >= 1"),
        "substeps": Spec("int", None, "Steps of dt / substeps per step (default: what the "
                         "stability estimate needs for 'symplectic'; 1 otherwise).",
                         lambda v: v >= 1, "an integer >= 1"),
        "start_acceleration": Spec("str", "forces", "Accelerations at t = 0: 'forces' (from "
                                   "the forces at rest: gravity) or 'zero' (the report's "
                                   "code: a = 0 until the first force evaluation).",
                                   choices=("forces", "zero")),
        "scheme": Spec("str", _I.scheme, "Implicit: 'theta' (one step, see theta) or 'bdf2' "
                       "(two-step, second order: keeps a frame-rate wobble, 0.90 of its "
                       "energy per period at 2.8 Hz and dt = 1/60 s; less robust through "
                       "impacts).",
                       choices=("theta", "bdf2")),
        "theta": Spec("float", _I.theta, "Implicit: 1 = backward Euler (robust, damps), 0.5 = "
                      "midpoint (no damping of linear vibrations).", lambda v: 0.5 <= v <= 1,
                      "a number in [0.5, 1]"),
        "cg_tolerance": _pos("Implicit: relative residual at which CG stops.", _I.cg_tolerance),
        "cg_max_iterations": Spec("int", _I.max_iterations, "Implicit: CG iterations per step at most.",
                                  lambda v: v >= 1, "an integer >= 1"),
    },
    "provot": {
        "enabled": Spec("bool", _P.enabled, "Provot strain limiting on/off."),
        "tau": Spec("float", _P.tau, "Tolerance as a fraction of rest length (0.001 = 0.1 %).",
                    lambda v: 0 < v < 1, "a number in (0, 1)"),
        "loops": Spec("int", _P.loops, "Passes per step (report: 5).", lambda v: v >= 1,
                      "an integer >= 1"),
        "pairs": Spec("str", _P.pairs.value, "'springs' or 'all' (the report's O(n^2) hack).",
                      choices=("springs", "all")),
        "order": Spec("str", _P.order.value, "'jacobi' (parallel, averaged) or 'gauss-seidel'.",
                      choices=("jacobi", "gauss-seidel")),
        "tolerance": _nonneg("Stop the loops once the largest correction is below this [m].",
                             _P.tolerance, " (m)"),
        "velocity_update": Spec("bool", _P.velocity_update, "Add the correction / dt to the velocity."),
    },
    "ground": {
        "enabled": Spec("bool", _G.enabled, "The report's ground plane on/off."),
        "model": Spec("str", _G.model.value, "'paper': the report's mu/nu rule (eqs. 2, 3); "
                      "'contact': non-penetration, restitution, Coulomb friction.",
                      choices=("paper", "contact")),
        "height": Spec("float", _G.height, "Height of the plane y = height [m]."),
        "mu": Spec("float", _G.mu, "Factor on x/z velocity of a point on the ground.",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "nu": Spec("float", _G.nu, "Fraction of y acceleration removed on the ground.",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "restitution": Spec("float", _G.restitution, "Contact: coefficient of restitution e.",
                            lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "friction": _nonneg("Contact: kinetic Coulomb friction coefficient.", _G.friction),
        "static_friction": Spec("float", None, "Contact: static Coulomb coefficient "
                                "(default: friction).", lambda v: v >= 0, "a number >= 0"),
    },
    "output": {
        "every": Spec("int", None, "Steps between saved frames (default: about 100 frames).",
                      lambda v: v >= 1, "an integer >= 1"),
        "vtu": Spec("bool", True, "Write the ParaView series body.pvd + one .vtu per frame."),
        "checkpoint_every": Spec("int", None, "Steps between checkpoints (checkpoint.npz, for "
                                 "'jellysim run --resume'), taken at the next saved frame; "
                                 "0: only when interrupted; default: at a frame once a "
                                 "minute of wall-clock time has passed.",
                                 lambda v: v >= 0, "an integer >= 0"),
    },
}
REQUIRED_SECTIONS = ("body", "integrator")


def _wants_fem(params: dict) -> bool:
    mat = params["material"]
    return mat["youngs_modulus"] is not None and mat["model"] != "springs"


def schema_markdown() -> str:
    """The scene format as Markdown (docs/scene.md; :mod:`jellysim.scene_doc`)."""

    return make()


class Scene:
    """A validated scene: ``scene.params[section][key]`` with every default filled in."""

    def __init__(self, params: dict, *, text: str = "", name: str = "<scene>"):
        self.params = params
        self.text = text
        self.name = name
        self.overrides: tuple[str, ...] = ()  # the --set items this scene was loaded with

    @classmethod
    def load(cls, path, *, overrides=()) -> "Scene":
        """Read and validate a TOML scene file (also :meth:`from_file`).  ``overrides``:
        ``"section.key=value"`` strings (TOML values) applied over the file's values."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise SceneError(f"{path}: scene file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise SceneError(f"{path}: cannot read the scene file ({exc})") from None
        return cls.from_text(text, name=str(path), overrides=overrides)

    @classmethod
    def from_text(cls, text: str, *, name: str = "<scene>", overrides=()) -> "Scene":
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{name}: not valid TOML: {exc}") from None
        for item in overrides:
            _override(raw, item, name)
        if overrides:   # the recorded text says what ran
            text += "\n# overridden on the command line:\n" + "".join(
                f"#   --set {item}\n" for item in overrides)
        try:
            params = cls._validate(raw, name)
        except SceneError as exc:  # say when the bad value came from the command line
            msg = str(exc)
            given = [item for item in overrides
                     if item.partition("=")[0].strip().rpartition(".")[2] in msg]
            if given:
                msg += " (given on the command line: " + ", ".join(
                    f"--set {item}" for item in given) + ")"
            raise SceneError(msg) from None
        scene = cls(params, text=text, name=name)
        scene.overrides = tuple(overrides)  # (a resume needs them again)
        return scene

    @classmethod
    def from_file(cls, path, *, overrides=()) -> "Scene":
        """Read and validate a TOML scene file (the same as :meth:`load`)."""
        return cls.load(path, overrides=overrides)

    @classmethod
    def from_dict(cls, raw: dict, *, name: str = "<scene>") -> "Scene":
        """A scene from a dictionary shaped like the TOML file: ``{"body": {...},
        "springs": {...}, "integrator": {...}, "obstacle": [{...}, ...]}`` (keys and defaults:
        ``jellysim scene-help``).  Relative paths are relative to the current directory;
        errors name ``name``.  The scene's text (recorded in a run's trajectory) is the
        dictionary written as TOML."""
        return cls(cls._validate(raw, name), text=as_toml(raw), name=name)

    @staticmethod
    def _validate(raw: dict, name: str) -> dict:
        preset = raw.get("material", {}).get("preset") if isinstance(
            raw.get("material"), dict) else None
        if preset is not None:
            if not isinstance(preset, str) or preset not in PRESETS:
                raise SceneError(f"{name}: [material] preset = {preset!r}: unknown choice; "
                                 "expected one of " + ", ".join(repr(p) for p in PRESETS))
            raw = apply_preset(raw, preset)
        out: dict[str, dict] = {}
        raw = dict(raw)
        obstacles = Scene._validate_obstacles(raw.pop("obstacle", []), name)

        handles = validate_handle_tables(raw.pop("handle", []), name)
        for section in raw:
            if section not in SCHEMA:
                near = difflib.get_close_matches(section, SCHEMA, n=1)
                hint = f" (did you mean [{near[0]}]?)" if near else ""
                raise SceneError(f"{name}: unknown section [{section}]{hint}; allowed: "
                                 + ", ".join(f"[{s}]" for s in SCHEMA)
                                 + ", [[handle]], [[obstacle]]")
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
        check_backend(it["backend"], it["name"], it["device"], it["precision"], where=name,
                      physical=_wants_fem(out))
        b, sp = out["body"], out["springs"]
        kind = b["type"]
        given = raw.get("body", {}).get("surface_samples")
        if given is not None and (kind != "mesh" or sp["connect"] not in ("delaunay", "radius")):
            raise SceneError(f"{name}: [body] surface_samples is used only by type = 'mesh' "
                             "with [springs] connect = 'delaunay' or 'radius'; remove it")
        if raw.get("body", {}).get("relax") and (kind != "mesh" or sp["connect"] != "delaunay"):
            raise SceneError(f"{name}: [body] relax is used only by type = 'mesh' with "
                             "[springs] connect = 'delaunay'; remove it")
        if kind == "box" and sp["radius"] is None and b["distribution"] == "grid":
            sp["radius"] = grid_radius(b["points"], b["lower"], b["upper"])  # 1.8 spacings
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
        refuse_unused_keys(raw, kind, name, SCHEMA)  # e.g. [body] size for type = 'file'
        if not all(u > lo for u, lo in zip(b["upper"], b["lower"])):
            raise SceneError(f"{name}: [body] upper = {b['upper']} must exceed lower = "
                             f"{b['lower']} in every coordinate")
        out["obstacle"] = obstacles
        out["handle"] = handles
        return out

    _validate_obstacles = staticmethod(validate_obstacles)
    _obstacle = staticmethod(make_obstacle)

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

    def _guard(self) -> None:
        """Refuse before building what cannot run: all-pairs Provot above its point limit,
        and bodies whose memory estimate exceeds the limit (:mod:`jellysim.resources`)."""

        b, s, p = self.params["body"], self.params["springs"], self.params["provot"]
        if b["type"] == "file":
            return
        n = b["points"] if b["points"] is not None else 2000
        if p["enabled"] and p["pairs"] == "all" and n > MAX_ALL_PAIRS_POINTS:
            raise SceneError(f"{self.name}: [provot] pairs = 'all' is O(n^2) and limited to "
                             f"{MAX_ALL_PAIRS_POINTS} points; [body] points = {n}. Use pairs = "
                             "'springs' (and a stiffer material) or fewer points.")
        if b["type"] == "box":
            vol = float(np.prod(np.subtract(b["upper"], b["lower"])))
            r = s["radius"]
            nb = min(n - 1.0, n * 4.18879 * r ** 3 / vol) if (r and vol > 0) else 24.0
            check_body_memory(n, neighbours=max(nb, 1.0), what=f"{self.name}: [body] points")
        else:
            check_body_memory(n, neighbours=s["neighbours"] or 24.0,
                              tets=s["connect"] != "radius", what=f"{self.name}: [body] points")

    def build_body(self):
        from .geometry.connect import radius_springs
        from .geometry.sampling import box_field

        b, s = self.params["body"], self.params["springs"]
        self._guard()
        if b["type"] == "file":
            from dataclasses import replace

            from .geometry.jellyfile import read_body

            path = self.resolve(b["path"])
            if not path.exists():
                raise SceneError(missing_path(self.name, b["path"], path))
            body = read_body(path)
            return replace(body, points=self._place(body.points))
        if b["type"] == "mesh":
            from .build import build_body
            from .geometry.mesh import Mesh, load_mesh

            path = self.resolve(b["path"])
            if not path.exists():
                raise SceneError(missing_path(self.name, b["path"], path))
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
                              surface_samples=b["surface_samples"], relax=b["relax"])
        if b["distribution"] == "grid":
            from .geometry.lattice import grid_points

            points = grid_points(b["points"], b["lower"], b["upper"])
        else:
            points = box_field(b["points"], b["lower"], b["upper"],
                               distribution=b["distribution"], seed=b["seed"])
        meta = {"builder": "box", "distribution": b["distribution"], "seed": b["seed"],
                "connect": "radius", "radius": s["radius"]}
        if b["distribution"] == "grid":  # the lattice's own Kuhn tets (well shaped)
            from .geometry.lattice import grid_tets

            tets = grid_tets(points)
        else:
            from .build import _radius_tets

            # Delaunay tets of the points (a box is convex: nothing to carve), for
            # [material] model = 'fem'; the springs stay the radius springs
            points, tets, tet_info = _radius_tets(points, None, seed=b["seed"], name=self.name)
            meta.update(tet_volume=tet_info["tet_volume"], cloud_tets=tet_info)
        springs = radius_springs(points, s["radius"])
        volume = float(np.prod(np.subtract(b["upper"], b["lower"])))
        return Body(points=points, springs=springs, tets=tets, volume=volume, meta=meta)

    def build_model(self, body=None):
        body = self.build_body() if body is None else body
        m, ph = self.params["mass"], self.params["physics"]
        mat = self.params["material"]
        density = mat["density"] if mat["density"] is not None else m["density"]
        try:
            model = self._material_model(body)
            if model is not None:
                return model
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
                            density=density if body.masses is None else None,
                            point_mass=m["point_mass"] if body.masses is None else None,
                            damping=ph["damping"], gravity=ph["gravity"])
        except ValueError as exc:
            raise SceneError(f"{self.name}: {exc}") from None

    def material(self):
        """The scene's :class:`~jellysim.params.Material` (``None`` without youngs_modulus)."""

        return scene_material(self.params)

    def _material_model(self, body):
        """The fem model of the body (``[material] model`` 'fem', or 'auto' with tets), else
        ``None`` (the springs path; why is kept for the handles' error)."""
        self._springs_reason = springs_reason(self.params, body)
        return scene_fem_model(self.params, body)

    def provot_params(self):
        p = self.params["provot"]
        return ProvotParams(enabled=p["enabled"], tau=p["tau"], loops=p["loops"],
                            pairs=ProvotPairs(p["pairs"]), order=ProvotOrder(p["order"]),
                            tolerance=p["tolerance"], velocity_update=p["velocity_update"])

    def ground_params(self):
        g = self.params["ground"]
        return GroundParams(enabled=g["enabled"], mu=g["mu"], nu=g["nu"], height=g["height"],
                            model=g["model"], restitution=g["restitution"],
                            friction=g["friction"], static_friction=g["static_friction"])

    def with_backend(self, backend: str | None = None, device: str | None = None,
                     precision: str | None = None) -> "Scene":
        """This scene with ``[integrator] backend / device / precision`` overridden where
        given (the command line's ``--backend``), checked like a scene file's."""
        it = dict(self.params["integrator"])
        for key, value in (("backend", backend), ("device", device),
                           ("precision", precision)):
            if value is not None:
                it[key] = check_value(self.name, "integrator", key, SCHEMA["integrator"][key],
                                      value)
        check_backend(it["backend"], it["name"], it["device"], it["precision"], where=self.name,
                      physical=_wants_fem(self.params))
        scene = Scene({**self.params, "integrator": it}, text=self.text, name=self.name)
        scene.overrides = self.overrides
        return scene

    def simulator(self, model=None, **overrides):
        """A :class:`~jellysim.simulator.Simulator` of the scene: its options, the initial
        velocity and the ``[[handle]]`` tables applied."""

        model = self.build_model() if model is None else model
        try:
            sim = Simulator(model, **self.simulator_kwargs(model, **overrides))
        except SceneError as exc:  # name the scene file, as the other scene errors do
            msg = str(exc)
            raise SceneError(msg if msg.startswith(f"{self.name}:") else
                             f"{self.name}: {msg}") from None
        self.prepare(sim)
        return sim

    def prepare(self, sim) -> None:
        """Set the scene's initial velocity and handles on a new simulator."""
        sim.state.v[:] = np.asarray(self.params["body"]["velocity"], dtype=np.float64)
        if self.params.get("handle"):
            try:
                apply_handle_tables(sim, self.params["handle"], getattr(
                    self, "_springs_reason", None))
            except SceneError as exc:
                raise SceneError(f"{self.name}: {exc}") from None

    def simulator_kwargs(self, model=None, **overrides) -> dict:
        """The keyword arguments :meth:`simulator` passes to the Simulator (for ``model``)."""
        it = self.params["integrator"]

        kw = dict(dt=it["dt"], integrator=it["name"], provot=self.provot_params(),
                  ground=self.ground_params(), backend=it["backend"], threads=it["threads"],
                  device=it["device"], precision=it["precision"],
                  substeps=it["substeps"] if it["substeps"] is not None else "auto",
                  implicit=ImplicitParams(scheme=it["scheme"], theta=it["theta"],
                                          cg_tolerance=it["cg_tolerance"],
                                          max_iterations=it["cg_max_iterations"]),
                  obstacles=self.obstacles())
        if getattr(model, "fem", None) is not None:
            if it["name"] != "symplectic":
                raise SceneError(
                    f"{self.name}: [integrator] name = {it['name']!r}: a fem material is "
                    "integrated by symplectic substeps; set name = 'symplectic' (or [material] "
                    "model = 'springs' for the springs path)")
            kw["provot"] = self.provot_params().__class__(enabled=False)
        if it["start_acceleration"] == "zero" and "state" not in overrides and model is not None:
            state = model.state()
            state.a[:] = 0.0
            kw["state"] = state
        kw.update(overrides)
        return kw

    @property
    def steps(self) -> int:
        return int(self.params["integrator"]["steps"])

    @property
    def frame_every(self) -> int:
        every = self.params["output"]["every"]
        return every if every is not None else max(1, math.ceil(self.steps / 100))
