"""jellysim: soft, wobbly bodies as 3D mass-spring networks.

Everything a scene file can do is reachable from here::

    import jellysim as js

    body = js.Body.from_mesh("cow.obj", size=0.1, points=2000)     # [m]; masses at 1141 kg/m^3
    k = js.calibrate_springs(body, 1.0e4)                           # N/m per spring, E = 10 kPa
    model = js.finalize(body, stiffness=k)
    sim = js.Simulator(model, dt=1 / 60, integrator="implicit",
                       ground=js.GroundParams(model=js.GroundModel.CONTACT))

or a whole scene as a dictionary (the TOML format, ``jellysim scene-help``):
``js.Scene.from_dict({...})``, ``js.Scene.from_file("scene.toml")``, ``js.run_scene``.

Importing the package is light: numba, scipy and mesh/render libraries load only when used;
the names below other than the core data types are imported on first access (PEP 562).
"""
from .body import Body
from .model import Model, finalize
from .params import (GRAVITY, REPORT_DENSITY, GroundModel, GroundParams, ImplicitParams,
                     Integrator, ProvotOrder, ProvotPairs, ProvotParams)
from .simulator import Simulator
from .state import State

__version__ = "0.1.0"

_LAZY = {
    # building bodies
    "build_body": ("build", "build_body"),
    "body_stats": ("build", "body_stats"),
    "load_mesh": ("geometry.mesh", "load_mesh"),
    "read_body": ("geometry.jellyfile", "read_body"),
    "write_body": ("geometry.jellyfile", "write_body"),
    "box_field": ("geometry.sampling", "box_field"),
    "radius_springs": ("geometry.connect", "radius_springs"),
    # material
    "calibrate_springs": ("physics.material", "calibrate_springs"),
    "network_youngs_modulus": ("physics.material", "network_youngs_modulus"),
    "point_masses": ("physics.material", "point_masses"),
    "PRESETS": ("presets", "PRESETS"),
    "apply_preset": ("presets", "apply_preset"),
    # obstacles (contact with restitution and Coulomb friction)
    "Plane": ("physics.contact", "Plane"),
    "Sphere": ("physics.contact", "Sphere"),
    "Box": ("physics.contact", "Box"),
    # scenes, runs and their outputs
    "Scene": ("scene", "Scene"),
    "run_scene": ("runner", "run_scene"),
    "load_trajectory": ("io.trajectory", "load_trajectory"),
    "Trajectory": ("io.trajectory", "Trajectory"),
    "Skin": ("skin", "Skin"),
    "JellysimError": ("errors", "JellysimError"),
}
"""Public name -> (module under ``jellysim``, attribute), imported on first access."""

__all__ = ["Body", "Model", "State", "Simulator", "finalize", "Integrator", "ProvotParams",
           "ProvotPairs", "ProvotOrder", "GroundParams", "GroundModel", "ImplicitParams",
           "REPORT_DENSITY", "GRAVITY", "__version__", *_LAZY]


_SUBMODULES = {"build", "presets", "scene", "runner", "geometry", "physics", "io", "skin",
               "render", "demo", "errors", "stability", "kernels"}


def __getattr__(name: str):
    import importlib

    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'jellysim' has no attribute '{name}'") from None
    value = getattr(importlib.import_module(f".{module}", __name__), attr)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
