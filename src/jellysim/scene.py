"""Scene files: one TOML file holds every parameter of a run.

Every key is checked against :data:`SCHEMA`; any problem raises :class:`SceneError` with one line
naming the file, the ``[section] key`` and what is allowed.  See ``docs/scene.md`` for the
format (generated from the same schema: ``jellysim scene-help``).
"""
from __future__ import annotations

import json
import math
import tomllib
import warnings
from pathlib import Path

import numpy as np

from .errors import BuildError, JellysimError, SceneError, did_you_mean
from .geometry.mesh import MESH_SUFFIXES
from .params import (MAX_ALL_PAIRS_POINTS, GroundParams, ImplicitParams, ProvotOrder, ProvotPairs,
                     ProvotParams, density_slip)
# Spec (a row of the schema) and the checks live in scene_spec, the table of keys in scene_schema
from .scene_obstacles import (OBSTACLE_KEYS, OBSTACLE_SCHEMA,  # noqa: F401 (re-exported)
                              make_obstacle, validate_obstacles)
from .scene_schema import SCHEMA
from .scene_spec import (Spec, as_toml, check_backend, check_body_file, check_given_keys,
                         check_value, given_keys, plain, grid_radius, infer_body_type,
                         missing_path, refuse_point_mass, refuse_unused_keys,
                         said_springs_ignore, say_slips, from_command_line,
                         told_from_command_line)
from .scene_spec import apply_override as _override, check_table as _table
from .scene_doc import schema_markdown as make
from .scene_handles import apply_handle_tables, validate_handle_tables
from .resources import check_body_memory
from .body import LARGE_BODY, Body, _warn_size
from .model import finalize
from .physics.policy import scene_fem_model, scene_material, springs_reason
from .simulator import Simulator
from .presets import PRESETS, apply_preset

__all__ = ["Scene", "SCHEMA", "Spec", "schema_markdown"]

REQUIRED_SECTIONS = ("body", "integrator")


def _wants_fem(params: dict) -> bool:
    mat = params["material"]
    return mat["youngs_modulus"] is not None and mat["model"] != "springs"


def schema_markdown() -> str:
    """The scene format as Markdown (docs/scene.md; :mod:`jellysim.scene_doc`)."""
    return make()


MIN_FRAME_RATE = 60.0
"""Frames per simulated second a run saves at least by default (``[output] every`` unset): a
jello's ~10 Hz wobble shows 6 frames a period, and a run at the physical path's dt = 1/60 s
saves every step whatever its length (at 30, a 1.5 s run saved 60 frames/s and a 2 s one
30: session 24's artist trial)."""


class Scene:
    """A validated scene: ``scene.params[section][key]`` with every default filled in."""

    def __init__(self, params: dict, *, text: str = "", name: str = "<scene>"):
        self.params = params
        self.text = text
        self.name = name
        self.overrides: tuple[str, ...] = ()  # the --set items this scene was loaded with
        self.given: dict = {}  # {section: keys} as written and --set (no preset): given_keys

    @classmethod
    def load(cls, path, *, overrides=()) -> "Scene":
        """Read and validate a TOML scene file (also :meth:`from_file`).  ``overrides``: what
        ``jellysim run --set`` gives, ``"section.key=value"`` strings (one string: one)."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix in MESH_SUFFIXES or suffix in (".jello", ".npz"):
            what = "a mesh" if suffix in MESH_SUFFIXES else "a body file (or a trajectory)"
            kind = "mesh" if suffix in MESH_SUFFIXES else "file"
            raise SceneError(f"{path}: {what}, not a scene (.toml): a scene names it as [body] "
                             f"type = '{kind}', path = '{path.name}' (examples/"
                             "spot_drop.toml shows one); `jellysim build` makes a body of "
                             "a mesh, `jellysim render` draws a run")
        try:
            data = path.read_bytes()
            text = data.decode("utf-8-sig")  # (a byte-order mark, as some editors save)
        except FileNotFoundError:
            raise SceneError(f"{path}: scene file not found") from None
        except UnicodeDecodeError as exc:
            line = data[:exc.start].count(b"\n") + 1
            raise SceneError(f"{path}:{line}: not UTF-8 text (byte {data[exc.start]:#04x}): save "
                             "the scene file as UTF-8") from None
        except OSError as exc:
            raise SceneError(f"{path}: cannot read the scene file ({exc})") from None
        return cls.from_text(text, name=str(path), overrides=overrides)

    @classmethod
    def from_text(cls, text: str, *, name: str = "<scene>", overrides=()) -> "Scene":
        """Parse and validate a scene from TOML ``text``; ``name`` is the file name its errors
        (:class:`~jellysim.errors.SceneError`) show; ``overrides`` as in :meth:`load`."""
        overrides = (overrides,) if isinstance(overrides, str) else overrides  # (not chars)
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{name}: not valid TOML: {exc}") from None
        for item in overrides:
            _override(raw, item, name)
        if overrides:   # the recorded text says what ran
            text += "\n# overridden:\n" + "".join(f"#   --set {item}\n" for item in overrides)
        given = given_keys(raw, SCHEMA, PRESETS, by_value=False)
        try:
            params = cls._validate(raw, name, user=given)
        except SceneError as exc:  # say when the bad value came from the command line
            raise SceneError(str(exc) + from_command_line(str(exc), overrides)) from None
        say_slips(params, given, name, overrides)
        scene = cls(params, text=text, name=name)
        scene.overrides = tuple(overrides)  # (a resume needs them again)
        scene.given = given
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
        if not isinstance(raw, dict):
            raise SceneError(f"{name}: Scene.from_dict takes a dictionary shaped like the TOML "
                             f"file ({{'body': {{...}}, 'integrator': {{...}}}}), got "
                             f"{type(raw).__name__}")
        raw = plain(raw)  # tuples, numpy arrays and numpy scalars as the TOML reader's values
        given = given_keys(raw, SCHEMA, PRESETS)
        params = cls._validate(raw, name, user=given)
        say_slips(params, given, name)   # (as from_text: a sweep's dictionaries too)
        scene = cls(params, text=as_toml(raw), name=name)
        scene.given = given
        return scene

    @staticmethod
    def _validate(raw: dict, name: str, user: dict | None = None) -> dict:
        """The scene's parameters; ``user``: its given keys (:func:`given_keys`: a file's
        written keys, a dictionary's by value; default: by value)."""
        user = given_keys(raw, SCHEMA, PRESETS) if user is None else user
        raw = infer_body_type(raw)  # path = "cow.obj" alone means type = 'mesh'
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
                hint = did_you_mean(section, SCHEMA, "[{}]")
                raise SceneError(f"{name}: unknown section [{section}]{hint}; allowed: "
                                 + ", ".join(f"[{s}]" for s in SCHEMA)
                                 + ", [[handle]], [[obstacle]]")
            if not isinstance(raw[section], dict):
                raise SceneError(f"{name}: '{section}' must be a [{section}] table")
        for section in REQUIRED_SECTIONS:
            if section not in raw:
                what = {"body": " (where the jello comes from: type = 'box', 'mesh' or 'file')",
                        "integrator": " (at least dt [s] and steps)"}.get(section, "")
                raise SceneError(f"{name}: missing section [{section}]{what}; the smallest "
                                 "whole scene is [material] preset = 'gelatin' (a 10 cm gelatin "
                                 "cube); `jellysim scene-help` lists every key, examples/ has "
                                 "whole scenes")
        for section, keys in SCHEMA.items():
            out[section] = _table(name, f"[{section}]", raw.get(section, {}), keys)
        mat, spr = out["material"], out["springs"]
        if (mat["youngs_modulus"] is None and spr["stiffness"] is None
                and out["body"]["type"] != "file"):  # a body file may carry its own (build_model)
            raise SceneError(f"{name}: give [springs] stiffness (N/m) or [material] "
                             "youngs_modulus (Pa), or [material] preset = 'gelatin'")
        if mat["youngs_modulus"] is not None and spr["stiffness"] is not None:
            if "youngs_modulus" not in user.get("material", ()):
                raise SceneError(f"{name}: [springs] stiffness is not used with [material] "
                                 f"preset = {preset!r}, whose youngs_modulus derives every "
                                 "spring's stiffness; remove [springs] stiffness (or the "
                                 "preset, to give the springs your own)")
            raise SceneError(f"{name}: [springs] stiffness and [material] youngs_modulus both "
                             "set; give one (youngs_modulus derives every spring's stiffness)")
        check_given_keys(user, raw, out, name, preset)
        if out["body"]["settle"] and not _wants_fem(out):
            raise SceneError(f"{name}: [body] settle is for the physical path (a body with "
                             "tets and a FEM material, e.g. [material] preset = 'gelatin'); "
                             "remove it")
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
        if kind == "box" and not all(u > lo for u, lo in zip(b["upper"], b["lower"])):
            raise SceneError(f"{name}: [body] upper = {b['upper']} must exceed lower = "
                             f"{b['lower']} in every coordinate")
        given = raw.get("body", {}).get("surface_samples")
        if given is not None and (kind != "mesh" or sp["connect"] not in ("delaunay", "radius")):
            raise SceneError(f"{name}: [body] surface_samples is used only by type = 'mesh' "
                             "with [springs] connect = 'delaunay' or 'radius'; remove it")
        if raw.get("body", {}).get("relax") and (kind != "mesh" or sp["connect"] != "delaunay"):
            raise SceneError(f"{name}: [body] relax is used only by type = 'mesh' with "
                             "[springs] connect = 'delaunay'; remove it")
        if raw.get("springs", {}).get("snap") is not None and (
                kind != "mesh" or sp["connect"] != "marching"):
            raise SceneError(f"{name}: [springs] snap is used only by type = 'mesh' with "
                             "connect = 'marching'; remove it")
        if kind == "box" and b["distribution"] == "grid" and (b["points"] or 8) < 8:
            raise SceneError(f"{name}: [body] points = {b['points']}: a grid box needs at "
                             "least 8 (its corners; 1000 gives 11^3 points)")
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
        """A path from the scene, relative to the scene file's directory (``jellysim:NAME``:
        a mesh shipped with the package)."""
        from .geometry.mesh import SHIPPED, shipped

        if str(path).startswith(SHIPPED):
            try:
                return shipped(path)
            except JellysimError as exc:
                raise SceneError(f"{self.name}: [body] path: {exc}") from None
        p = Path(path)
        if not p.is_absolute() and self.name not in ("<scene>", "demo"):
            p = Path(self.name).resolve().parent / p
        return p

    @property
    def surface(self):
        """The placed surface mesh of a type 'mesh' scene, or of a type 'file' body that
        carries one (vertices [m] (m, 3), faces (f, 3)), after :meth:`build_body`, else
        ``None``: the skin to carry (:attr:`surface_uv`: its faces' texture coordinates)."""
        return getattr(self, "_surface", None)

    @property
    def surface_uv(self):
        """The texture coordinates [-] (f, 3, 2) of :attr:`surface`'s faces, or ``None``."""
        return getattr(self, "_texture", (None, None))[0]

    @property
    def surface_materials(self):
        """Which material each face of :attr:`surface` uses (``Materials``), or ``None``."""
        return getattr(self, "_texture", (None, None))[1]

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
        if b["type"] == "box":  # (an absurd size first: its volume and radius overflow)
            _warn_size(float(np.max(np.subtract(b["upper"], b["lower"]))),
                       f"{self.name}: the box ([body] lower, upper)", limit=float("inf"))
            vol, r = float(np.prod(np.subtract(b["upper"], b["lower"]))), s["radius"]
            nb = min(n - 1.0, n * 4.18879 * r ** 3 / vol) if (r and vol > 0) else 24.0
            check_body_memory(n, neighbours=max(nb, 1.0), what=f"{self.name}: [body] points")
        else:
            check_body_memory(n, neighbours=s["neighbours"] or 24.0,
                              tets=s["connect"] != "radius", what=f"{self.name}: [body] points")

    def build_body(self):
        """The scene's :class:`~jellysim.body.Body` ([body] and [springs]: a box field, a mesh
        sampled and connected by :func:`jellysim.build.build_body`, or a body file), placed;
        points [m] (n, 3).  Refused before building when it cannot run (all-pairs Provot over
        too many points: :class:`SceneError`; too much memory: ``ResourceError``)."""
        b, s = self.params["body"], self.params["springs"]
        self._guard()
        if b["type"] == "file":
            from dataclasses import replace

            from .geometry.jellyfile import read_body

            path = self.resolve(b["path"])
            if not path.exists():
                raise SceneError(missing_path(self.name, b["path"], path))
            body = read_body(path)
            _warn_size(float(np.ptp(body.points, axis=0).max()), f"{self.name}: the body file "
                       f"{b['path']}", limit=30.0)  # (lessons' chains and nets span metres)
            if body.skin_vertices is None:
                return replace(body, points=self._place(body.points))
            # placed by its skin (what is drawn), as a mesh body is; the points move with it
            skin = self._place(body.skin_vertices)
            placed = body.points + (skin[0] - body.skin_vertices[0])
            self._surface, self._texture = (skin, body.skin_faces), (body.skin_uv, body.materials)
            return replace(body, points=placed, skin_vertices=skin)
        if b["type"] == "mesh":
            from dataclasses import replace

            from .build import build_body
            from .geometry.mesh import Mesh, load_mesh, outward, rotate_up

            path = self.resolve(b["path"])
            if not path.exists():
                raise SceneError(missing_path(self.name, b["path"], path))
            try:
                mesh = outward(load_mesh(path), str(path))
            except JellysimError as exc:
                raise SceneError(f"{self.name}: [body] path: {exc}") from None
            v = rotate_up(mesh.vertices, b["up"])
            if b["size"] is not None and b["size"] > LARGE_BODY:
                warnings.warn(f"{self.name}: [body] size = {b['size']:g} m: sizes are in "
                              "metres (10 cm = 0.1); a jello this large is likely a slip of "
                              "units", UserWarning, stacklevel=2)
            if b["size"] is not None:
                v = v * (b["size"] / float(np.ptp(v, axis=0).max()))
            v = self._place(v)
            placed = replace(Mesh.from_arrays(v, mesh.faces, name=str(path)), path=path)
            self._surface, self._texture = (v, np.asarray(mesh.faces)), (mesh.uv, mesh.materials)
            mat = self.params["material"]
            density = mat["density"] if mat["density"] is not None else (
                self.params["mass"]["density"])
            try:
                with warnings.catch_warnings():  # (the scene scaled it: [body] size said)
                    if b["size"] is not None:
                        warnings.filterwarnings("ignore", message=r".* m across \(its "
                                                r"coordinates are read as metres\)")
                    return build_body(placed, points=b["points"], connect=s["connect"],
                                      sampling=b["sampling"], radius=s["radius"],
                                      neighbours=s["neighbours"], h=s["h"], density=density,
                                      seed=b["seed"], surface_samples=b["surface_samples"],
                                      relax=b["relax"], snap=s["snap"] is not False, rule=b["rule"])
            except BuildError as exc:  # name the scene keys, not the call
                keys = ", ".join(f"[{t}] {k} = {json.dumps(v)}" for t, k, v in (
                    ("springs", "connect", s["connect"]), ("body", "points", b["points"]),
                    ("body", "sampling", b["sampling"]), ("springs", "h", s["h"]),
                    ("springs", "radius", s["radius"])) if v is not None)
                raise SceneError(f"{self.name}: building the body ({keys}): {exc}") from None
        try:
            return Body.box(b["lower"], b["upper"], points=b["points"],
                            distribution=b["distribution"], radius=s["radius"], seed=b["seed"],
                            name=self.name)
        except ValueError as exc:
            raise SceneError(str(exc)) from None

    def build_model(self, body=None):
        """The :class:`~jellysim.model.Model` to simulate: ``body`` (default
        :meth:`build_body`) with the scene's stiffness or material, masses [kg], damping and
        gravity; a physical (FEM) model when the material says so."""
        body = self.build_body() if body is None else body
        m, ph = self.params["mass"], self.params["physics"]
        mat = self.params["material"]
        density = mat["density"] if mat["density"] is not None else m["density"]
        slip = density_slip(m["density"]) if "density" in self.given.get("mass", ()) else None
        if slip:
            warnings.warn(f"{self.name}: [mass] density {slip}", UserWarning, stacklevel=2)
        given = self.params["springs"]["stiffness"]
        if self.params["body"]["type"] == "file" and mat["youngs_modulus"] is None:
            given = check_body_file(self.name, self.params, self.given, body, given, m)
        try:
            with told_from_command_line(self.overrides):  # (a --set value: said so)
                model = self._material_model(body)
            if model is not None:
                refuse_point_mass(self.name, self.given, m["point_mass"], density, model)
                own = None if body.masses is None else body.masses.sum()
                new = model.point_mass.sum()
                fill = (float(np.sum(model.fem.rest_volume)) / float(body.volume)  # (the same
                        if model.fem is not None and body.volume else 0.0)  # density: quiet)
                if (self.params["body"]["type"] == "file" and own is not None
                        and abs(own - new) > 1e-6 * new and abs(new / own - fill) > 1e-6):
                    warnings.warn(f"{self.name}: the body file's own masses ({own:.4g} kg) "
                                  f"are replaced by the material's: density x the tets' "
                                  f"volume ({new:.4g} kg)", UserWarning, stacklevel=2)
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
            if (mat.get("preset") == "paper-2010" and body.masses is not None
                    and self.params["body"]["type"] != "file"):
                from dataclasses import replace  # the report splits the mass evenly, whatever
                body = replace(body, masses=None)  # the builder (tets lump it by volume); a
                                                   # body file's own masses are the user's
            model = finalize(body, stiffness=given,
                             density=density if body.masses is None else None,
                             point_mass=m["point_mass"] if body.masses is None else None,
                             damping=ph["damping"], gravity=ph["gravity"])
            if model.spring_count == 0 and model.point_count > 1:
                why, fix = (("its file lists none", "give the file a springs section")
                            if self.params["body"]["type"] == "file" else
                            ("none within [springs] radius of another", "a larger radius "
                             "joins them"))
                warnings.warn(f"{self.name}: the body has no spring ({model.point_count} "
                              f"points, {why}): they fall as loose particles; {fix}",
                              UserWarning, stacklevel=2)
            return model
        except ValueError as exc:
            raise SceneError(f"{self.name}: {exc}") from None

    def material(self):
        """The scene's :class:`~jellysim.params.Material` (``None`` without youngs_modulus)."""

        return scene_material(self.params)

    def _material_model(self, body):
        """The fem model of the body (``[material] model`` 'fem', or 'auto' with tets), else
        ``None`` (the springs path; why is kept for the handles' error)."""
        self._springs_reason = springs_reason(self.params, body)
        model = scene_fem_model(self.params, body)
        if model is None:  # (calibrated springs read E and the density only)
            said_springs_ignore(self.given, self.name, self._springs_reason)
        return model

    def provot_params(self):
        p = self.params["provot"]
        return ProvotParams(enabled=p["enabled"], tau=p["tau"], loops=p["loops"],
                            pairs=ProvotPairs(p["pairs"]), order=ProvotOrder(p["order"]),
                            tolerance=p["tolerance"], velocity_update=p["velocity_update"])

    def ground_params(self, model=None):
        """The ground; an unset ``[ground] model`` is 'contact' for a ``model`` on the
        physical (tet) path (the paper rule does not hold it), else 'paper'."""
        g = self.params["ground"]
        kind = g["model"] or ("contact" if getattr(model, "fem", None) is not None else "paper")
        return GroundParams(enabled=g["enabled"], mu=g["mu"], nu=g["nu"], height=g["height"],
                            model=kind, restitution=g["restitution"],
                            friction=g["friction"], static_friction=g["static_friction"],
                            slip_distance=g["slip_distance"], no_slip=g["no_slip"])

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
        scene.given = self.given  # (as --set items: an interrupted run's command keeps them)
        scene.overrides = self.overrides + tuple(f"integrator.{k}={v}" for k, v in (
            ("backend", backend), ("device", device), ("precision", precision)) if v is not None)
        return scene

    def simulator(self, model=None, *, settle: bool = True, **overrides):
        """A :class:`~jellysim.simulator.Simulator` of the scene: its options, the initial
        velocity and the ``[[handle]]`` tables applied; with ``[body] settle`` (and
        ``settle``: a resumed run or ``inspect`` passes False) first settled at rest."""

        model = self.build_model() if model is None else model
        try:
            sim = Simulator(model, **self.simulator_kwargs(model, **overrides))
        except SceneError as exc:  # name the scene file, as the other scene errors do
            msg = str(exc)
            raise SceneError(msg if msg.startswith(f"{self.name}:") else
                             f"{self.name}: {msg}") from None
        self.prepare(sim, settle=settle)
        return sim

    def prepare(self, sim, *, settle: bool = True) -> None:
        """Set a new simulator's initial velocity and the scene's handles, then settle the
        body with them on (``[body] settle``; the velocity then set again, off the pins)."""
        velocity = np.asarray(self.params["body"]["velocity"], dtype=np.float64)
        sim.state.v[:] = velocity  # (a pin then holds its points still)
        if self.params.get("handle"):  # on the start positions (a resume too), then settled
            try:
                apply_handle_tables(sim, self.params["handle"], getattr(
                    self, "_springs_reason", None))
            except SceneError as exc:
                raise SceneError(f"{self.name}: {exc}") from None
        if settle and self.params["body"].get("settle"):
            if not sim.physical:
                raise SceneError(f"{self.name}: [body] settle is for the physical path (a body "
                                 "with tets and a FEM material, e.g. [material] preset = "
                                 "'gelatin'); remove it")
            try:
                sim.settle()
            except SceneError as exc:
                raise SceneError(f"{self.name}: [body] settle: {exc}") from None
            sim.state.v[sim.handles.pinned == 0] = velocity

    def simulator_kwargs(self, model=None, **overrides) -> dict:
        """The keyword arguments :meth:`simulator` passes to the Simulator (for ``model``)."""
        it = self.params["integrator"]

        kw = dict(dt=it["dt"], integrator=it["name"], provot=self.provot_params(),
                  ground=self.ground_params(model), backend=it["backend"],
                  threads=it["threads"],
                  device=it["device"], precision=it["precision"],
                  substeps=it["substeps"] if it["substeps"] is not None else "auto",
                  implicit=ImplicitParams(scheme=it["scheme"], theta=it["theta"],
                                          cg_tolerance=it["cg_tolerance"],
                                          max_iterations=it["cg_max_iterations"]),
                  obstacles=self.obstacles(), runaway_distance=it["runaway_distance"])
        if getattr(model, "fem", None) is not None:
            if it["name"] != "symplectic":
                raise SceneError(
                    f"{self.name}: [integrator] name = {it['name']!r}: a fem material is "
                    "integrated by symplectic substeps; set name = 'symplectic' (or [material] "
                    "model = 'springs' for the springs path)")
            written = [k for k in self.given.get("provot", ())
                       if not (k == "enabled" and not self.params["provot"]["enabled"])]
            if written:  # (any key but enabled = false: it would change nothing)
                key = written[0]
                value = self.params["provot"][key]
                raise SceneError(f"{self.name}: [provot] {key} = {json.dumps(value)}: Provot's "
                                 "strain limiting is not used by the physical (tet) path, whose "
                                 "tets keep their shape; remove it (or [material] model = "
                                 "'springs' for the springs path)")
            if self.params["ground"]["model"] == "paper" and self.params["ground"]["enabled"]:
                what = ("model = 'paper' (the report's mu/nu rule)" if "model" in
                        self.given.get("ground", ()) else "mu / nu (the report's paper rule's)")
                raise SceneError(f"{self.name}: [ground] {what} acts on the springs path "
                                 "only: this body is on the physical (tet) path and would fall "
                                 "through it; use model = 'contact' (its Coulomb coefficient is "
                                 "friction) or [material] model = 'springs'")
            kw["provot"] = self.provot_params().__class__(enabled=False)
        if it["start_acceleration"] == "zero" and "state" not in overrides and model is not None:
            state = model.state()
            state.a[:] = 0.0
            kw["state"] = state
        kw.update(overrides)
        return kw

    @property
    def steps(self) -> int:
        """Number of time steps to run (``[integrator] steps``)."""
        return int(self.params["integrator"]["steps"])

    @property
    def frame_every(self) -> int:
        """Steps between saved frames: ``[output] every``, else about 100 frames but at
        least :data:`MIN_FRAME_RATE` frames per simulated second (a smooth video)."""
        every = self.params["output"]["every"]
        if every is not None:
            return every
        smooth = max(1, math.floor(1.0 / (MIN_FRAME_RATE * float(self.params["integrator"]["dt"]))
                                   + 1e-9))
        return max(1, min(math.ceil(self.steps / 100), smooth))
