"""Material presets for scenes: ``[material] preset = "gelatin"`` or ``"paper-2010"``.

A preset is a partial scene: its values fill every key the scene file leaves out (the scene's
own values win).  :data:`PRESETS` maps the name to that partial scene.

* ``gelatin``: density 1141 kg/m^3 (the report's figure, section 6.4) and Young's modulus
  E = 10 kPa.  Source for E: J. E. Bonavia (2025), compression tests of gelatin gels,
  arXiv:2512.20502: instantaneous moduli follow a power law in the water:gelatin ratio, from
  277 +/- 30 kPa at 2:1 down to 4.34 +/- 0.64 kPa at 20:1; the power law through those two
  points (exponent -1.8) gives 7-11 kPa at 15:1-12:1, a firm dessert gelatin.  10 kPa is
  chosen there rather than at the soft end because a spring network softer than about 5 kPa
  at 10 cm scale does not survive a 5 mm drop without a permanent set (docs/physics.md,
  limits).  Physical ground (restitution 0.3, Coulomb friction 0.6), the implicit integrator
  at dt = 1/60 s, no Provot, no damping.
* ``paper-2010``: the report's section 5.1 run: k = 2 N/m, delta = 0.8 kg/s, tau = 0.1 %, one
  all-pairs Provot loop (the report's hack of section 4.1/5.2), the mu/nu ground (mu = 0.1,
  nu = 0.2), the report's integrator at dt = 0.01 s.
"""
from __future__ import annotations

import copy

from .params import CONTACT_FRICTION, CONTACT_RESTITUTION, REPORT_DENSITY

__all__ = ["PRESETS", "GELATIN_DENSITY", "GELATIN_YOUNGS_MODULUS", "apply_preset"]

GELATIN_DENSITY = REPORT_DENSITY
"""Density of jello [kg/m^3] (report section 6.4): :data:`jellysim.params.REPORT_DENSITY`."""
GELATIN_YOUNGS_MODULUS = 1.0e4
"""Young's modulus of a firm dessert gelatin [Pa] (Bonavia 2025, see the module docstring)."""

PRESETS: dict[str, dict] = {
    "gelatin": {
        "material": {"density": GELATIN_DENSITY, "youngs_modulus": GELATIN_YOUNGS_MODULUS},
        "physics": {"damping": 0.0},
        "integrator": {"name": "implicit", "dt": 1.0 / 60.0},
        "provot": {"enabled": False},
        "ground": {"model": "contact", "restitution": CONTACT_RESTITUTION,
                   "friction": CONTACT_FRICTION},
    },
    "paper-2010": {
        "springs": {"stiffness": 2.0},
        "material": {"density": REPORT_DENSITY},
        "physics": {"damping": 0.8},
        "integrator": {"name": "paper", "dt": 0.01},
        "provot": {"enabled": True, "tau": 0.001, "loops": 1, "pairs": "all"},
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
    return out
