"""Material presets for scenes: ``[material] preset = "gelatin"`` or ``"paper-2010"``.

A preset is a partial scene: its values fill every key the scene file leaves out (the scene's
own values win).  :data:`PRESETS` maps the name to that partial scene.

* ``gelatin``: density 1141 kg/m^3 (the figure for Jello the report found, section 6.4, where it
  says its program's density did not match it) and Young's modulus E = 10 kPa. Source for E: J.
  E. Bonavia (2025), compression tests of gelatin gels, arXiv:2512.20502: instantaneous moduli
  follow a power law in the water:gelatin ratio, from 277 +/- 30 kPa at 2:1 down to 4.34 +/-
  0.64 kPa at 20:1; the power law through those two points (exponent -1.8) gives 7-11 kPa at
  15:1-12:1, a firm dessert gelatin. 10 kPa is chosen there rather than at the soft end because
  a spring network softer than about 5 kPa at 10 cm scale does not survive a 5 mm drop without a
  permanent set (docs/physics.md, limits). Poisson's ratio 0.48 (gelatin is nearly
  incompressible, ~0.5; 0.48 is the lowest value at which a 5 kPa ball dropped 50 cm inverts no
  tet at a frame's end; the cube's sag locks 9 % below nu = 0.3's with the mirrored split,
  docs/physics.md), material damping ratio 0.02 at 5 Hz (loss factor tan d = 0.04: set gelatin
  gels are "true gels", storage modulus far above the loss modulus and both nearly independent
  of frequency; the figure is our estimate for a dessert gel, not a measurement of ours),
  physical ground (restitution 0.3, Coulomb friction 0.6), the physical path: Stable Neo-Hookean
  tets for tet bodies, symplectic substeps at dt = 1/60 s per frame, 180 frames (3 s) unless
  ``steps`` is given, no Provot, no report damping; ``[material] preset = "gelatin"`` alone is a
  whole scene (the 10 cm cube resting on the plate). A mesh body gets ``connect = "marching"``
  and a box (the default type) ``distribution = "grid"`` (a 10 cm cube of 1000 cells,
  :data:`GELATIN_BOX`, unless its corners or points are given), both carrying tets, unless the
  scene names its springs (``connect``, ``radius`` or ``neighbours``) or a random distribution.
* ``paper-2010``: the report's section 5.1 run: the body's mass split evenly over its points
  (the report gives no masses: an even split is our reading; whatever the builder: tet
  builders otherwise lump it by tet volume; a body file's own masses and spring stiffnesses
  are the user's and are kept, the latter said), k = 2 N/m, delta = 0.8 kg/s, tau = 0.1 %, one
  all-pairs Provot loop (the report's hack of section 4.1/5.2), the mu/nu ground (mu = 0.1, nu =
  0.2), the report's integrator at dt = 0.01 s, and the report's step as we read it (section 4.1,
  checked to 1e-12 m by ``tests/test_paper_step.py``): Provot visits the points in order and
  corrects each pair in place at once (``order = "gauss-seidel"``: "we iterate over every point
  ... and for each of its neighbors, we do Provot correction"; each pair once, from its
  lower-numbered point: visiting every pair from both ends, another reading of that sentence,
  ends 100 steps of the paper cube up to 1.26 m elsewhere, session 12's trial), moves positions
  only
  (``velocity_update = false``: the report says nothing of velocities) and the accelerations
  start at zero (``start_acceleration = "zero"``: the report's step computes them after the
  first move).
"""
from __future__ import annotations

import copy

from .errors import did_you_mean, ParameterError
from .params import CONTACT_FRICTION, CONTACT_RESTITUTION, REPORT_DENSITY, Material

__all__ = ["PRESETS", "GELATIN_DENSITY", "GELATIN_YOUNGS_MODULUS", "GELATIN_POISSON_RATIO",
           "GELATIN_DAMPING_RATIO", "GELATIN_BOX", "GELATIN_BOX_POINTS", "apply_preset",
           "gelatin", "material"]

GELATIN_DENSITY = REPORT_DENSITY
"""Density of jello [kg/m^3] (report section 6.4): :data:`jellysim.params.REPORT_DENSITY`."""
GELATIN_YOUNGS_MODULUS = 1.0e4
"""Young's modulus of a firm dessert gelatin [Pa] (Bonavia 2025, see the module docstring)."""

GELATIN_POISSON_RATIO = 0.48
"""Poisson's ratio of the gelatin preset [-] (see the module docstring)."""
GELATIN_DAMPING_RATIO = 0.02
"""Damping ratio of the gelatin preset at 5 Hz [-] (loss factor 0.04)."""
GELATIN_BOX = ((0.0, 0.0, 0.0), (0.1, 0.1, 0.1))
"""Corners [m] of a ``[body] type = "box"`` (the default type) under the gelatin preset when
the scene gives neither ``lower`` nor ``upper`` (nor springs, nor a random distribution): a
10 cm grid cube."""
GELATIN_BOX_POINTS = 1000
"""Its default ``points`` (cells: 11^3 points), as :meth:`jellysim.Body.box`."""

PRESETS: dict[str, dict] = {
    "gelatin": {
        "material": {"density": GELATIN_DENSITY, "youngs_modulus": GELATIN_YOUNGS_MODULUS,
                     "poisson_ratio": GELATIN_POISSON_RATIO,
                     "damping_ratio": GELATIN_DAMPING_RATIO, "damping_frequency": 5.0},
        "physics": {"damping": 0.0},
        "integrator": {"name": "symplectic", "dt": 1.0 / 60.0, "steps": 180},
        "provot": {"enabled": False},
        "ground": {"model": "contact", "restitution": CONTACT_RESTITUTION,
                   "friction": CONTACT_FRICTION},
        "body": {},
    },
    "paper-2010": {
        "springs": {"stiffness": 2.0},
        "material": {"density": REPORT_DENSITY},
        "physics": {"damping": 0.8},
        "integrator": {"name": "paper", "dt": 0.01, "start_acceleration": "zero"},
        "provot": {"enabled": True, "tau": 0.001, "loops": 1, "pairs": "all",
                   "order": "gauss-seidel", "velocity_update": False},
        "ground": {"model": "paper", "mu": 0.1, "nu": 0.2},
    },
}


def apply_preset(raw: dict, name: str) -> dict:
    """``raw`` (a parsed scene) with the preset's values under it (``raw`` wins)."""
    out = copy.deepcopy(PRESETS[name])
    for section, keys in raw.items():
        if isinstance(keys, dict) and isinstance(out.get(section), dict):
            out[section].update(keys)
        else:
            out[section] = keys
    body, springs = out.get("body"), out.get("springs", {})
    if (name != "gelatin" or not isinstance(body, dict) or not isinstance(springs, dict)
            or {"connect", "radius", "neighbours"} & set(springs)):
        return out
    if body.get("type") == "mesh":
        # a gelatin mesh body gets tets (the physical path), not the report's radius springs
        out.setdefault("springs", {})["connect"] = "marching"
    elif body.get("type", "box") == "box" and body.get("distribution", "grid") == "grid":
        # a gelatin box is a grid of cubic cells with its own tets (the physical path) and,
        # unless its corners are given, a dessert-sized 10 cm cube on the ground (the
        # report's unit cube [0, 1]^3 m of gelatin would slump by half its height)
        body["distribution"] = "grid"
        body.setdefault("points", GELATIN_BOX_POINTS)
        if "lower" not in body and "upper" not in body:
            body["lower"], body["upper"] = list(GELATIN_BOX[0]), list(GELATIN_BOX[1])
    return out


def gelatin(**changes):
    """The gelatin preset as a :class:`~jellysim.params.Material` (keyword changes win)."""

    import dataclasses

    values = dict(density=GELATIN_DENSITY, youngs_modulus=GELATIN_YOUNGS_MODULUS,
                  poisson_ratio=GELATIN_POISSON_RATIO, damping_ratio=GELATIN_DAMPING_RATIO,
                  damping_frequency=5.0)
    known = {f.name for f in dataclasses.fields(Material)}
    unknown = sorted(set(changes) - known)
    if unknown:
        hints = [f"{k!r}" + did_you_mean(k, sorted(known), "{!r}") for k in unknown]
        raise ParameterError(f"unknown material parameter {', '.join(hints)}; the parameters are "
                         + ", ".join(sorted(known)))
    values.update(changes)
    return Material(**values)


def material(name: str = "gelatin", **changes):
    """A named material preset as a :class:`~jellysim.params.Material` (``"gelatin"``);
    keyword changes win (e.g. ``material("gelatin", youngs_modulus=5e3)``)."""
    if name != "gelatin":
        raise ParameterError(f"unknown material {name!r}; available: 'gelatin' (the paper-2010 "
                         "preset is a springs-only scene preset, not a material)")
    return gelatin(**changes)
