"""The building blocks of the scene format (:mod:`jellysim.scene`): one :class:`Spec` per key,
and the checks that turn a parsed TOML table into validated values with one-line errors.

The table of keys itself, ``SCHEMA``, lives in :mod:`jellysim.scene_schema`: a new key is one row
``"key": Spec(kind, default, doc, check, allowed, choices)`` in its section there.
"""
from __future__ import annotations

import math
import tomllib
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .errors import SceneError, did_you_mean
from .kernels import WARP_INTEGRATORS
from .params import _user_stacklevel

__all__ = ["REQUIRED", "Spec", "as_toml", "missing_path", "check_table", "check_value", "plain",
           "apply_override", "check_backend", "grid_radius", "check_body_file"]

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


def plain(value: Any) -> Any:
    """A Python dictionary of scene values with tuples and numpy arrays turned into lists and
    numpy scalars into Python numbers (what the TOML reader would have given)."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value[()]) if value.ndim == 0 else [plain(v) for v in value]
    if isinstance(value, np.floating) and value.dtype.itemsize < 8:
        return float(str(value))  # float32(0.05) is 0.05, not 0.05000000074505806
    if isinstance(value, np.generic):
        return value.item()
    return value


_UNITS = ("m", "kg", "s", "N", "Pa", "N/m", "kg/m^3", "m/s", "Hz")
_PREFIXES = {"k": 1e3, "M": 1e6, "G": 1e9, "m": 1e-3, "u": 1e-6, "\u00b5": 1e-6}


def _plain_number(value) -> str:
    """``"; write 10000 (SI units ...)"`` for text such as ``'10kPa'``, ``'5 cm'``, ``'2 kg'``
    or ``'0.02'`` (a number with its unit, or quoted: sweep trial, session 30), else ``""``."""
    import re

    m = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*", value) \
        if isinstance(value, str) else None
    if m is None:
        return ""
    number, suffix = float(m.group(1)), m.group(2)
    if suffix in _UNITS or not suffix:
        factor = 1.0
    elif suffix == "cm":
        factor = 1e-2
    elif suffix[:1] in _PREFIXES and suffix[1:] in _UNITS:
        factor = _PREFIXES[suffix[:1]]
    else:
        return ""
    return f"; write {number * factor:g} (SI units: m, kg, s, Pa; no suffix)"


def check_value(name: str, section: str, key: str, spec: Spec, value: Any) -> Any:
    label = section if section.startswith("[") else f"[{section}]"
    where = f"{name}: {label} {key}"
    kind = spec.kind

    def fail(problem: str, allowed: str) -> SceneError:
        return SceneError(f"{where} = {value!r}: {problem}; expected {allowed}")

    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail("wrong type", (spec.allowed or "a number") + _plain_number(value))
        value = float(value)
        if not math.isfinite(value):
            raise fail("not a finite number", spec.allowed or "a finite number")
    elif kind == "int":
        if isinstance(value, str) and value in spec.choices:  # ('auto': the default's choice)
            return spec.default
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
            if value.strip().lower() not in spec.choices:  # (any case: as in Python)
                raise fail("unknown choice", "one of " + ", ".join(repr(c) for c in
                                                                  spec.choices))
            value = value.strip().lower()
    elif kind == "vec3":
        ok = (isinstance(value, list) and len(value) == 3 and all(
            isinstance(c, (int, float)) and not isinstance(c, bool) for c in value))
        if not ok:
            raise fail("wrong type", "a list of three numbers [x, y, z], e.g. " + (
                "[0.0, -9.8, 0.0] (m/s^2, y up)" if key == "gravity" else "[0.0, 0.1, 0.0]"))
        value = [float(c) for c in value]
        if not all(math.isfinite(c) for c in value):
            raise fail("not finite", "three finite numbers")
    if spec.check is not None and not spec.check(value):
        raise fail("out of range", spec.allowed)
    return value


def _other_section(key: str, label: str) -> str:
    """`` (it is a key of [springs])`` when ``key`` belongs to other sections of the scene."""
    from .scene_schema import SCHEMA

    homes = [f"[{sec}]" for sec, keys in SCHEMA.items() if key in keys and f"[{sec}]" != label]
    return f" (it is a key of {' and '.join(homes)})" if homes else ""


def table_list(entries, name: str, what: str) -> list[dict]:
    """A scene's array of tables ``[[what]]`` as a list of dicts (one table given as
    ``[what]`` is taken as a list of one); anything else is a :class:`SceneError`."""
    if isinstance(entries, dict):
        entries = [entries]
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise SceneError(f"{name}: {what}s are tables: write [[{what}]] (double brackets) "
                         "before each one")
    return entries


def check_table(name: str, label: str, given: dict, keys: dict[str, Spec]) -> dict:
    """One table checked against ``keys``: unknown keys, missing required values and each
    value (:func:`check_value`); defaults filled in.  ``label`` names it (``[section]``)."""
    for key in given:
        if key not in keys:
            hint = did_you_mean(key, keys) or _other_section(key, label)
            raise SceneError(f"{name}: {label} unknown key '{key}'{hint}; allowed: "
                             + ", ".join(keys))
    values = {}
    for key, spec in keys.items():
        if key in given and given[key] is None and spec.default is None:
            values[key] = None  # "not set" (only reachable from Python dicts)
        elif key in given:
            values[key] = check_value(name, label, key, spec, given[key])
        elif spec.default is REQUIRED:
            hint = (" (jellysim run --steps N gives it on the command line)"
                    if (label, key) == ("[integrator]", "steps") else "")
            raise SceneError(f"{name}: {label} missing value '{key}': {spec.doc} "
                             f"Expected {spec.allowed or spec.kind}{hint}.")
        else:
            values[key] = spec.default
    return values


def apply_override(raw: dict, item: str, name: str) -> None:
    """Apply one ``section.key=value`` (TOML value) to a parsed scene, in place; a list of
    tables (``[[obstacle]]``, ``[[handle]]``) is addressed as ``section.N.key=value``, N
    counting its tables from 1 as they stand in the file (and a key of an inline table there
    as ``section.N.key.inner=value``, e.g. ``handle.1.shake.frequency=2``)."""
    where, sep, value = item.partition("=")
    section, dot, key = where.strip().partition(".")
    if not (sep and dot and section and key):
        raise SceneError(f"{name}: --set {item!r}: expected SECTION.KEY=VALUE, e.g. "
                         "body.points=500")
    try:
        parsed = tomllib.loads(f"v = {value.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value.strip()      # a bare word: a string (e.g. integrator.name=implicit)
    number, dot2, inner = key.partition(".")
    if section in ("obstacle", "handle") and not isinstance(raw.get(section), list):
        raise SceneError(f"{name}: --set {item!r}: the scene has no [[{section}]] table to "
                         f"set a key of (add one to the file)")
    table = raw.setdefault(section, {})
    if isinstance(table, list):
        if not (dot2 and inner and number.isdigit()):
            raise SceneError(f"{name}: --set {item!r}: [[{section}]] is a list of tables: "
                             f"address one by its number, {section}.N.key=value (N from 1, "
                             f"as they stand in the file), e.g. {section}.1.{key}={value}")
        if not 1 <= int(number) <= len(table):
            raise SceneError(f"{name}: --set {item!r}: the scene has {len(table)} "
                             f"[[{section}]] table(s); N runs from 1 to {len(table)}")
        entry = table[int(number) - 1]
        head, dot3, rest = inner.partition(".")
        if dot3 and isinstance(entry.get(head), dict):  # an inline table's key (resonance
            entry[head] = dict(entry[head], **{rest: parsed})  # trial: shake.frequency)
        else:
            entry[inner] = parsed
        return
    table[key] = parsed


def check_backend(backend: str, integrator: str, device: str = "auto",
                  precision: str = "float64", *, where: str = "", physical: bool = False) -> None:
    """Refuse combinations the backends do not implement (a :class:`SceneError` naming the
    ``[integrator]`` keys).  ``physical``: the scene asks for the FEM material (which every
    backend implements)."""

    at = f"{where}: " if where else ""
    if not isinstance(precision, str) or precision not in ("float64", "float32"):
        raise SceneError(f"{at}precision must be 'float64' or 'float32', got {precision!r}")
    if backend == "warp" and integrator not in WARP_INTEGRATORS:
        raise SceneError(
            f"{at}[integrator] backend = 'warp' supports integrators "
            f"{' and '.join(WARP_INTEGRATORS)}; name = {integrator!r} is not implemented on "
            "Warp: use backend = 'numba' (the default) or an explicit integrator")
    if backend != "warp" and device not in ("auto", "", None):
        raise SceneError(f"{at}[integrator] device = {device!r}: devices apply to backend = "
                         f"'warp' only (backend = {backend!r} runs on the CPU)")
    if precision == "float32" and backend == "numba" and physical:
        raise SceneError(f"{at}[integrator] precision = 'float32' on backend = 'numba' applies "
                         "to spring bodies; the physical (FEM) path computes in float64: use "
                         "precision = 'float64' (or [material] model = 'springs')")
    if precision == "float32" and (backend not in ("numba", "warp") or integrator == "implicit"):
        raise SceneError(
            f"{at}[integrator] precision = 'float32' applies to backend = 'warp' and to "
            f"backend = 'numba' with an explicit integrator (paper, symplectic); backend = "
            f"{backend!r} with name = {integrator!r} computes in float64: use precision = "
            "'float64'")


def as_toml(raw: dict) -> str:
    """A scene dictionary (tables of numbers, strings, booleans and lists; arrays of tables)
    as TOML text.  JSON's literals are TOML's for these values."""
    import json

    lines = []
    for section, table in raw.items():
        tables = table if isinstance(table, list) else [table]
        for t in tables:
            lines.append(f"[[{section}]]" if isinstance(table, list) else f"[{section}]")
            lines += [f"{k} = {json.dumps(v)}" for k, v in t.items() if v is not None]
            lines.append("")
    return "\n".join(lines)


def missing_path(name: str, given: str, path) -> str:
    """The message for a scene's ``[body] path`` that does not exist (where relative paths
    are read from)."""
    from pathlib import Path

    where = ("relative paths are read from the scene file's folder, "
             f"{Path(name).resolve().parent}" if not Path(given).is_absolute()
             and name not in ("<scene>", "demo") else "")
    return (f"{name}: [body] path = {given!r}: file not found ({path})"
            + (f"; {where}" if where else ""))


def grid_radius(points, lower, upper) -> float | None:
    """1.8 spacings [m] of the grid :func:`jellysim.geometry.lattice.grid_points` lays in the
    box (its nearest, face-diagonal and body-diagonal neighbours), or ``None`` when the box or
    the count is not valid (its own checks say why)."""
    from .geometry.lattice import grid_radius as radius

    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    if points is None or points < 8 or lo.shape != (3,) or not np.all(hi > lo):
        return None
    return radius(points, lo, hi)


UNUSED_BY_TYPE = {
    "file": {"body": ("size", "points", "lower", "upper", "distribution", "sampling", "up",
                      "rule"),
             "springs": ("connect", "radius", "neighbours", "h")},
    "box": {"body": ("path", "size", "sampling", "base", "up", "rule"),
            "springs": ("neighbours", "h")},
    "mesh": {"body": ("lower", "upper", "distribution"), "springs": ()},
}
"""Keys a ``[body] type`` does not read: given in a scene, they are refused rather than
silently ignored (a body file has its own points, springs and units; a box has no mesh)."""


BODY_FILE_SUFFIXES = (".jello", ".npz")


def infer_body_type(raw: dict) -> dict:
    """``raw`` with ``[body] type`` filled in when it names a ``path`` but no type: ``'file'``
    for a body file (.jello, .npz), else ``'mesh'`` (a scene saying only ``path = "cow.obj"``
    means the mesh, not the default box, whose keys would refuse the path)."""
    body = raw.get("body")
    if not isinstance(body, dict) or "type" in body or not isinstance(body.get("path"), str):
        return raw
    suffix = "." + body["path"].rsplit(".", 1)[-1].lower() if "." in body["path"] else ""
    kind = "file" if suffix in BODY_FILE_SUFFIXES else "mesh"
    return {**raw, "body": {**body, "type": kind}}


def refuse_unused_keys(raw: dict, kind: str, name: str, schema: dict) -> None:
    """A :class:`SceneError` for the first key of ``raw`` (the scene as written, with its
    preset) that ``[body] type = kind`` would ignore, given a value other than its default
    (``schema[section][key].default``: a scene's validated parameters, which hold every key,
    can be read back)."""
    why = {"file": "a body file has its own points, springs and units; use base to place it",
           "box": "a box body is made of [body] points, lower and upper",
           "mesh": "a mesh body fills the mesh; use size and base to scale and place it"}[kind]
    for section, keys in UNUSED_BY_TYPE[kind].items():
        given = raw.get(section, {})
        for key in keys:
            if isinstance(given, dict) and given.get(key) is not None and (
                    given[key] != schema[section][key].default):
                raise SceneError(f"{name}: [{section}] {key} is not used for [body] type = "
                                 f"{kind!r} ({why}); remove it")


PAPER_GROUND_KEYS = ("mu", "nu")
CONTACT_GROUND_KEYS = ("restitution", "friction", "static_friction", "slip_distance",
                       "no_slip")


def check_given_keys(user: dict, preset_raw: dict, out: dict, name: str, preset) -> None:
    """Refuse keys the scene would silently ignore, and settle ``[ground] model``.

    ``user``: the sections and keys as written (and ``--set``), before any preset;
    ``preset_raw``: the same with the preset under it; ``out``: the validated parameters,
    whose ``[ground] model`` is set here: as written; else as the other ground keys given
    imply (``mu``/``nu``: 'paper'; ``restitution``/``friction``/...: 'contact'); else the
    preset's; else ``None``, which the body's path settles (:meth:`Scene.ground_params`)."""
    ground = user.get("ground", set())
    paper = [k for k in PAPER_GROUND_KEYS if k in ground]
    contact = [k for k in CONTACT_GROUND_KEYS if k in ground]
    if paper and contact:
        raise SceneError(f"{name}: [ground] {', '.join(paper)} (the paper ground's rule) and "
                         f"{', '.join(contact)} (the contact ground's) both given; keep one "
                         "model's keys")
    model = (out["ground"]["model"] if "model" in ground else
             preset_raw.get("ground", {}).get("model") if preset is not None else None)
    if model is None:
        model = "paper" if paper else "contact" if contact else None
    if model == "contact" and paper:
        raise SceneError(f"{name}: [ground] {', '.join(paper)} is the report's paper ground's "
                         "(model = 'paper'); the contact ground's Coulomb coefficient is "
                         "[ground] friction (and its bounce restitution)")
    if model == "paper" and contact:
        raise SceneError(f"{name}: [ground] {', '.join(contact)} is used by the contact ground "
                         "only; set [ground] model = 'contact' (the paper ground's rule has "
                         "mu and nu)")
    out["ground"]["model"] = model
    integrator = out.get("integrator", {}).get("name")
    if "nu" in ground and out["ground"]["nu"] != 0 and integrator not in (None, "paper"):
        import warnings

        warnings.warn(f"{name}: [ground] nu = {out['ground']['nu']:g} acts in the report's step "
                      f"only (integrator 'paper', which reuses the stored acceleration); the "
                      f"{integrator} integrator computes it afresh from the forces, so nu "
                      "changes nothing here (mu still acts)", stacklevel=3)
    _said_unused(user, out, name)
    if "density" in user.get("mass", set()) and out["material"]["density"] is not None:
        source = (f", from the preset {preset!r}" if "density" not in user.get("material", set())
                  else "")
        raise SceneError(f"{name}: [mass] density is not used: [material] density "
                         f"({out['material']['density']:g} kg/m^3{source}) sets the body's "
                         "mass; set [material] density instead")


IMPLICIT_KEYS = ("scheme", "theta", "cg_tolerance", "cg_max_iterations")
"""``[integrator]`` keys read by ``name = "implicit"`` only."""


def _said_unused(user: dict, out: dict, name: str) -> None:
    """Warn of keys the scene gives that its run will not read: the implicit integrator's
    with another integrator, the ground's with the ground off (session 13's hostile trial:
    each ran bitwise as without it, silently)."""
    import warnings

    integrator = out.get("integrator", {}).get("name")
    idle = [k for k in IMPLICIT_KEYS if k in user.get("integrator", set())]
    if idle and integrator != "implicit":
        warnings.warn(f"{name}: [integrator] {', '.join(idle)} apply to name = 'implicit' only; "
                      f"the {integrator} integrator ignores them", UserWarning, stacklevel=4)
    ground = [k for k in sorted(user.get("ground", set())) if k != "enabled"]
    if ground and not out.get("ground", {}).get("enabled", True):
        warnings.warn(f"{name}: [ground] {', '.join(ground)} given, but the ground is off "
                      "(enabled = false): they do nothing", UserWarning, stacklevel=4)


def said_springs_ignore(given: dict, name: str, reason: str | None) -> None:
    """Warn of the tet material's keys given to a body that runs on springs (they are read by
    the physical path only)."""
    import warnings

    idle = [k for k in ("poisson_ratio", "damping_ratio", "damping_frequency", "mass_scaling")
            if k in given.get("material", ())]
    if idle:
        warnings.warn(f"{name}: [material] {', '.join(idle)} "
                      f"{'acts' if len(idle) == 1 else 'act'} on the physical (tet) path "
                      f"only; this body runs on springs ({reason or 'no tets'}), which ignore "
                      f"{'it' if len(idle) == 1 else 'them'}", UserWarning, stacklevel=4)


def given_keys(raw: dict, schema: dict, presets: dict, by_value: bool = True) -> dict:
    """``{section: set of keys}`` of a scene (tables only): with ``by_value = False`` (a
    scene file and its ``--set`` items: what the user wrote) every key present; else those
    whose value differs from what the key would be without it: its preset's value where the
    scene's preset sets it, else the schema's default (so a scene's own full parameters, read
    back by ``Scene.from_dict``, give nothing)."""
    if not by_value:
        return {s: set(v) for s, v in raw.items() if isinstance(v, dict)}
    material = raw.get("material")
    preset = presets.get(material.get("preset")) if isinstance(material, dict) and isinstance(
        material.get("preset"), str) else None
    out = {}
    for section, table in raw.items():
        if not isinstance(table, dict):
            continue
        base = (preset or {}).get(section, {})
        specs = schema.get(section, {})
        out[section] = {k for k, v in table.items()
                        if k not in base and k not in specs
                        or v != (base[k] if k in base else specs[k].default)}
    return out


def refuse_point_mass(name: str, given: dict, point_mass, density: float, model) -> None:
    """A scene's ``[mass] point_mass`` on the physical (FEM) path, where the tets' lumped
    masses would silently win (session 16's researcher trial): refused, with the fix."""
    if "point_mass" in given.get("mass", ()):
        raise SceneError(
            f"{name}: [mass] point_mass = {point_mass:g} kg is not used: the physical (FEM) "
            f"path gives each point density x a quarter of its tets' volume ([material] "
            f"density = {density:g} kg/m^3, {model.point_mass.sum():.4g} kg in all); remove "
            "[mass] point_mass and set [material] density to change the mass (or [material] "
            "model = 'springs' for equal point masses)")


def check_body_file(name, params, given, body, stiffness, mass):
    """A ``[body] type = 'file'`` body's own stiffnesses and masses against the scene's
    (``params``; ``given``: the keys the user wrote; ``name``: the scene's): the stiffness
    to use (``None``: the file's).  A value the user wrote that the file's data would silently
    override is refused; a preset's default gives way to the file's data (said)."""
    import warnings

    path = params["body"]["path"]
    if body.stiffness is not None and stiffness is not None:
        if "stiffness" in given.get("springs", ()):
            raise SceneError(f"{name}: [springs] stiffness = {stiffness:g}, but the "
                             f"body file {path} gives every spring its own stiffness; "
                             "remove [springs] stiffness to use the file's")
        warnings.warn(f"{name}: the body file {path} gives every spring its own "
                      f"stiffness, used instead of the preset's [springs] stiffness = "
                      f"{stiffness:g} N/m", UserWarning, stacklevel=_user_stacklevel())
        stiffness = None
    if body.stiffness is None and stiffness is None:
        raise SceneError(f"{name}: the body file {path} has no spring stiffness; "
                         "give [springs] stiffness (N/m) or [material] youngs_modulus "
                         "(Pa), or [material] preset = 'gelatin'")
    written = [k for k in ("point_mass", "density") if k in given.get("mass", ())]
    if body.masses is not None and written:
        raise SceneError(f"{name}: [mass] {written[0]} = {mass[written[0]]:g}, but the "
                         f"body file {path} gives every point its own mass; remove [mass] "
                         f"{written[0]} to use the file's (or the mass column of the file "
                         "to use it)")
    preset = params.get("material", {}).get("preset")
    if body.masses is not None and not written and preset:
        warnings.warn(f"{name}: the body file {path} gives every point its own mass "
                      f"({body.masses.sum():.4g} kg in all), used instead of the "
                      f"{preset!r} preset's masses (remove the file's mass column for "
                      "the preset's)", UserWarning, stacklevel=_user_stacklevel())
    if body.masses is None and body.volume is None and mass["point_mass"] is None:
        raise SceneError(f"{name}: the body file {path} has no masses and no volume: "
                         "give [mass] point_mass (kg) in the scene, or a mass column or a "
                         "volume line in the file (docs/jello-format.md)")
    return stiffness


def from_command_line(msg: str, overrides) -> str:
    """`` (given as an override: --set ...)`` for the ``--set`` items (``overrides=`` in
    Python) whose key or section ``msg`` names, or ``""`` (sweep trial, session 30: "given on
    the command line" misled a Python user)."""
    given = [item for item in overrides  # (its key, or its section, named)
             if item.partition("=")[0].strip().rpartition(".")[2] in msg
             or f"[{item.partition('.')[0].strip()}]" in msg]
    return (" (given as an override: " + ", ".join(f"--set {item}" for item in given)
            + ")") if given else ""


@contextmanager
def told_from_command_line(overrides):
    """The warnings of the block, each with :func:`from_command_line`'s note when it names a
    ``--set`` item (a no-op without ``overrides``)."""
    import warnings

    if not overrides:
        yield
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    for w in caught:
        warnings.warn(str(w.message) + from_command_line(str(w.message), overrides),
                      w.category, stacklevel=_user_stacklevel())


def say_slips(params: dict, given: dict, name: str, overrides=()) -> None:
    """Warn of values that are valid but likely mean something else (a teacher's trial,
    session 25): a time step given in milliseconds, a friction coefficient given as a
    percent, a ground restitution set for a jello body, whose bounce it hardly changes, and
    the report's per-point drag on a jello body (it depends on the resolution).  A value
    from ``overrides`` (``--set``) is said to come from there, as errors say (teacher trial,
    session 28: the warning named the scene file, which does not hold it)."""
    import warnings

    if overrides:
        with told_from_command_line(overrides):
            say_slips(params, given, name)
        return

    dt = (params.get("integrator") or {}).get("dt")
    if dt is not None and dt > 0.1:
        warnings.warn(f"{name}: [integrator] dt = {dt:g} s: time steps are in seconds (one "
                      f"frame at 60 frames/s is 1/60 = 0.0167 s; {dt:g} ms would be "
                      f"{dt / 1000:g})", UserWarning, stacklevel=_user_stacklevel())
    ground = params.get("ground") or {}
    for key in ("friction", "static_friction"):
        mu = ground.get(key)
        if key in given.get("ground", ()) and mu is not None and mu > 2.0:
            warnings.warn(f"{name}: [ground] {key} = {mu:g} is a coefficient, mu = friction "
                          "force / normal force (wood on wood about 0.3, rubber on concrete "
                          f"about 1), not a percent ({mu:g} % would be {mu / 100:g})",
                          UserWarning, stacklevel=_user_stacklevel())
    mat = params.get("material") or {}
    jello = mat.get("youngs_modulus") is not None and mat.get("model") != "springs"
    if jello and "restitution" in given.get("ground", ()) and ground.get("enabled", True):
        warnings.warn(f"{name}: [ground] restitution = {ground['restitution']:g} sets how each "
                      "point of the jello rebounds from the ground; how high the jello itself "
                      "bounces is set by its elasticity and its damping ([material] "
                      "damping_ratio), hardly by e (measured: docs/physics.md, \"Bounce and "
                      "restitution\")", UserWarning, stacklevel=_user_stacklevel())
    if jello and "damping" in given.get("physics", ()) and (params.get("physics") or {}).get(
            "damping"):
        warnings.warn(f"{name}: [physics] damping = {params['physics']['damping']:g} kg/s is the "
                      "report's drag on every point (a body of n points and mass M slows at "
                      "n delta / M per second): the same value damps a finer body more; for a "
                      "damping that is the material's, the same at any resolution, set "
                      "[material] damping_ratio", UserWarning, stacklevel=_user_stacklevel())
