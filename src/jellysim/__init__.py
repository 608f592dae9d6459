"""jellysim: soft, wobbly bodies as 3D mass-spring networks.

Everything a scene file can do is reachable from here::

    import jellysim as js

    body = js.Body.from_mesh("jellysim:spot.obj", size=0.1, points=2000)  # the shipped cow
    model = js.physical_model(body, js.material("gelatin"))  # FEM tets, E = 10 kPa, masses
    sim = js.Simulator(model, dt=1 / 60,                     # symplectic substeps (auto)
                       ground=js.GroundParams(model=js.GroundModel.CONTACT))

or a whole scene as a dictionary (the TOML format, ``jellysim scene-help``):
``js.Scene.from_dict({...})``, ``js.Scene.from_file("scene.toml")``, ``js.run_scene``.

Importing the package is light: numba, scipy and mesh/render libraries load only when used.

Threading: numba's OpenMP threads spin-wait between parallel regions by default, which makes
a run 20-270x slower when another process competes for the cores.  Unless the user set them,
``GOMP_SPINCOUNT=1000`` (libgomp's idle threads spin about 10 us, then sleep),
``OMP_WAIT_POLICY=PASSIVE`` and ``KMP_BLOCKTIME=0`` (other OpenMP runtimes: sleep at once) are
set here, before numba loads its threading layer; with no thread count given, the Simulator
times its pieces on 1 and all threads and keeps the faster (a busy machine: one).  Measurements
and the choice: docs/architecture.md, "Threads".  ``JELLYSIM_THREADING=passive`` sets no spin
(threads sleep at once), ``JELLYSIM_THREADING=spin`` leaves OpenMP's defaults alone;
``OMP_NUM_THREADS`` sizes numba's pool when ``NUMBA_NUM_THREADS`` is unset
(:mod:`jellysim._threading`).

Instructions: on AMD Zen 4 the spring kernels run 1.1-1.4x faster when LLVM does not use
AVX-512 gathers; ``JELLYSIM_CPU`` (``auto``, ``native``, ``avx2``) chooses, before numba
loads (:mod:`jellysim._cpu`).
"""

from ._threading import configure as _configure_threads

_configure_threads()
from ._cpu import configure as _configure_cpu
from . import _forked  # noqa: F401  (a forked child's clear error: jellysim._forked)

_configure_cpu()
from .body import Body
from .model import Model, finalize
from .params import (GRAVITY, REPORT_DENSITY, GroundModel, GroundParams, ImplicitParams,
                     ImplicitScheme,
                     Integrator, ProvotOrder, ProvotPairs, ProvotParams)
from .simulator import Simulator
from .state import State

__version__ = "0.1.0"

_LAZY = {
    # the physical path
    "physical_model": ("physics.policy", "physical_model"),
    "material": ("presets", "material"),
    "Material": ("params", "Material"),
    "MaterialModel": ("params", "MaterialModel"),
    "select_points": ("handles", "select_points"),
    "shake_path": ("handle_paths", "shake_path"),
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
    # errors and warnings (every error is a JellysimError; the input ones are ValueErrors too)
    **{name: ("errors", name) for name in (
        "JellysimError", "ParameterError", "SceneError", "SimulationError", "MeshError",
        "BuildError", "JelloFileError", "RunInterrupted", "CheckpointError", "NothingToResume",
        "OutputError", "ResourceError", "StabilityWarning", "SolverWarning")},
}
"""Public name -> (module under ``jellysim``, attribute), imported on first access."""

__all__ = ["Body", "Model", "State", "Simulator", "finalize", "Integrator", "ProvotParams",
           "ProvotPairs", "ProvotOrder", "GroundParams", "GroundModel", "ImplicitParams",
           "ImplicitScheme",
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
