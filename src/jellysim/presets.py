"""Material presets for scenes: ``[material] preset = "gelatin"`` or ``"paper-2010"``.

A preset is a partial scene: its values fill every key the scene file leaves out (the scene's
own values win).  :data:`PRESETS` maps the name to that partial scene.

* ``gelatin``: density 1141 kg/m^3 (the report's figure, section 6.4) and Young's modulus
  E = 5 kPa.  Source for E: Bonavia (2025), "Material properties of gelatin as a function of
  water-to-gelatin ratio", arXiv:2512.20502: compression tests give instantaneous moduli from
  277 kPa (2:1 water:gelatin) down to 4.34 +/- 0.64 kPa (20:1, the softest sample).  A dessert
  is made at about 30-40:1 water:gelatin (one 7 g envelope to 240 ml of liquid), so its E is at
  or below the soft end of that range; 5 kPa is the soft end rounded.  Physical ground
  (restitution 0.3, Coulomb friction 0.6), the implicit integrator at dt = 1/60 s, no Provot.
* ``paper-2010``: the report's section 5.1 run: k = 2 N/m, delta = 0.8 kg/s, tau = 0.1 %, one
  all-pairs Provot loop (the report's hack of section 4.1/5.2), the mu/nu ground (mu = 0.1,
  nu = 0.2), the report's integrator at dt = 0.01 s.
"""
from __future__ import annotations

import copy

__all__ = ["PRESETS", "GELATIN_DENSITY", "GELATIN_YOUNGS_MODULUS", "apply_preset"]

GELATIN_DENSITY = 1141.0
"""Density of jello [kg/m^3] (report section 6.4)."""
GELATIN_YOUNGS_MODULUS = 5.0e3
"""Young's modulus of dessert gelatin [Pa] (Bonavia 2025, see the module docstring)."""

PRESETS: dict[str, dict] = {
    "gelatin": {
        "material": {"density": GELATIN_DENSITY, "youngs_modulus": GELATIN_YOUNGS_MODULUS},
        "physics": {"damping": 0.0},
        "integrator": {"name": "implicit", "dt": 1.0 / 60.0},
        "provot": {"enabled": False},
        "ground": {"model": "contact", "restitution": 0.3, "friction": 0.6},
    },
    "paper-2010": {
        "springs": {"stiffness": 2.0},
        "material": {"density": 1141.0},
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
