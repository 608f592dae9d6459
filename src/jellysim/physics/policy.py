"""One place that turns a body and a material into a simulation :class:`~jellysim.model.Model`.

``physical_model(body, material)`` is what scenes, examples and tests call:

* ``MaterialModel.FEM`` (default): Stable Neo-Hookean tets (:mod:`.fem`) with E, Poisson's
  ratio and damping from the material; masses are density x a quarter of each incident tet's
  volume (lumped); springs stay in the model for drawing but carry no force (k = 0).
* ``MaterialModel.SPRINGS``: the report's springs, each k calibrated from E
  (:func:`.material.calibrate_springs`), masses from density x each point's volume.

The body's own ``masses`` (if any) are replaced: a material *is* its density.  The body's
points are taken in metres as they are (scale a mesh body with ``build_body(..., size=)``).
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ..params import GRAVITY, Material, MaterialModel, _user_stacklevel
from ..model import finalize
from .fem import fem_arrays, scale_light_masses
from ..errors import ParameterError

__all__ = ["physical_model", "scene_material", "scene_fem_model"]


def physical_model(body, material: Material = Material(), *, gravity=GRAVITY,
                   damping: float = 0.0, point_volume=None):
    """A :class:`~jellysim.model.Model` of ``body`` made of ``material``.

    Parameters
    ----------
    body: :class:`~jellysim.body.Body` (needs tets for ``MaterialModel.FEM``).
    material: :class:`~jellysim.params.Material`, or a preset's name (``"gelatin"``).
    gravity: [m/s^2], shape (3,).
    damping: the report's velocity damping delta [kg/s] (0 for a real material).
    point_volume: [m^3], shape (n,): volumes owned by the points (springs model only; default
        from the tets or the body volume).
    """
    from ..body import Body
    from ..geometry.tetra import lump_tet_masses

    if not isinstance(body, Body):
        raise TypeError(f"physical_model takes a Body (Body.from_mesh, build_body, read_body), "
                        f"got {type(body).__name__}: pass the body itself, not finalize(body)")
    if isinstance(material, str):  # a preset's name: physical_model(body, "gelatin")
        from ..presets import material as named

        material = named(material)
    if not isinstance(material, Material):
        raise TypeError(f"physical_model: material must be a jellysim.Material (e.g. "
                        f"js.material('gelatin')) or a preset's name, got "
                        f"{type(material).__name__}")
    given = body.meta.get("density_given")
    if given is not None and not np.isclose(given, material.density, rtol=1e-9):
        warnings.warn(f"the body was built with density = {given:g} kg/m^3 but the material's is "
                      f"{material.density:g}: the physical model's masses take the material's "
                      f"(pass jellysim.material(..., density={given:g}) to keep the body's)",
                      UserWarning, stacklevel=2)
    g = np.asarray(gravity, dtype=np.float64)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ParameterError(f"gravity must be 3 finite numbers (x, y, z) in m/s^2, e.g. (0, -9.8, "
                         f"0) or (0, 0, 0) for none; got {gravity!r}")
    if material.model is MaterialModel.FEM:
        if body.tets is None or len(body.tets) == 0:
            raise ParameterError(
                "the FEM material needs a body with tets (connect = 'delaunay', 'marching' or "
                "'tetgen', or radius bodies built with tets; a point cloud: "
                "Body.from_points(points) gives it its Delaunay tets); use "
                "Material(model='springs') for a springs-only body")
        fem = fem_arrays(body.points, body.tets, youngs_modulus=material.youngs_modulus,
                         poisson_ratio=material.poisson_ratio,
                         damping_ratio=material.damping_ratio,
                         damping_frequency=material.damping_frequency)
        mass = lump_tet_masses(body.points, fem.tets, material.density)
        _say_cloud_fill(body, material.density)
        lonely = mass <= 0
        if lonely.any():
            # points in no tet (stragglers of a carved point cloud): give them the mean mass so
            # that they stay finite; only springs (if any) act on them
            warnings.warn(f"{int(lonely.sum())} of {len(mass)} points belong to no tet; they "
                          "get the mean point mass and no elastic force", stacklevel=2)
            mass[lonely] = mass[~lonely].mean()
        mass = scale_light_masses(mass, fem, material.mass_scaling)
        body = dataclasses.replace(body, masses=mass,
                                   stiffness=np.zeros(len(body.springs)))
        model = finalize(body, gravity=gravity, damping=damping)
        return dataclasses.replace(model, fem=fem)
    from .material import calibrate_springs, point_volumes

    k = calibrate_springs(body, material.youngs_modulus, point_volume=point_volume)
    if point_volume is not None:
        mass = material.density * np.asarray(point_volume, dtype=np.float64)
    else:
        mass = material.density * point_volumes(dataclasses.replace(body, masses=None))
    body = dataclasses.replace(body, masses=mass, stiffness=k)
    return finalize(body, gravity=gravity, damping=damping)


CLOUD_FILL_WARNING = 0.9
"""A radius body (random points) whose Delaunay tets fill less of its volume than this is
said to be that much lighter on the physical path (the re-trial: a 10 cm gelatin box of 30
random points weighed 0.42 kg where density x volume is 1.14, with nothing said)."""


def _say_cloud_fill(body, density: float) -> None:
    """Warn when a radius body's tets (the convex hull of its random points, carved) hold
    less than :data:`CLOUD_FILL_WARNING` of its volume: its physical mass is that much low."""
    held, volume = body.meta.get("tet_volume"), body.volume
    if "cloud_tets" not in body.meta or not held or not volume or held >= (
            CLOUD_FILL_WARNING * volume):
        return
    warnings.warn(f"the radius body's tets (the Delaunay tets of its {body.point_count:,} "
                  f"random points) fill only {100 * held / volume:.0f} % of its volume: the "
                  f"physical path's mass, density x the tets' volume ({density * held:.3g} kg), "
                  f"is that much below density x volume ({density * volume:.3g} kg); more "
                  "points fill more (93 % of a cube at 2,000, 97 % at 16,000), a grid box "
                  "(distribution = 'grid') or connect = 'marching' fills it",
                  UserWarning, stacklevel=_user_stacklevel())


def scene_material(params: dict):
    """The :class:`~jellysim.params.Material` of validated scene ``params`` (``None``
    without ``[material] youngs_modulus``)."""
    mat = params["material"]
    if mat["youngs_modulus"] is None:
        return None
    density = mat["density"] if mat["density"] is not None else params["mass"]["density"]
    return Material(density=density, youngs_modulus=mat["youngs_modulus"],
                    poisson_ratio=mat["poisson_ratio"], damping_ratio=mat["damping_ratio"],
                    damping_frequency=mat["damping_frequency"],
                    model="springs" if mat["model"] == "springs" else "fem",
                    mass_scaling=mat["mass_scaling"])


def springs_reason(params: dict, body) -> str | None:
    """Why scene ``params`` run ``body`` on springs rather than the physical (FEM) path, or
    ``None`` when it takes the FEM path (``[material] model`` 'fem', or 'auto' and the body
    has tets).  'auto' takes the FEM path for every body with tets: tet builders, grid boxes and
    radius bodies (their points' carved Delaunay tets: slivers make the substep smaller than a
    marching body's, but on springs a 2,000-point gelatin radius cube dropped 2 cm flattened,
    its centre of mass at 19.9 mm where it rests at 46, session 27's trial); a scene that
    names another integrator than the physical path's stays on springs."""
    mat = params["material"]
    if scene_material(params) is None:
        return ("the material is the report's springs ([material] preset = 'gelatin' or "
                "youngs_modulus = ... makes a physical one)")
    if mat["model"] == "springs":
        return "[material] model = 'springs'"
    if mat["model"] == "fem":
        return None
    if body.tets is None or len(body.tets) == 0:
        return ("the body has no tets (a random box field, or a body file without tets: use "
                "a mesh body with [springs] connect = 'marching' or 'delaunay', or a box with "
                "distribution = 'grid')")
    if params["integrator"]["name"] != "symplectic":
        return (f"[integrator] name = '{params['integrator']['name']}': the physical path "
                "integrates by symplectic substeps (remove name, or set [material] model = "
                "'springs' to say you want springs)")
    return None


def scene_fem_model(params: dict, body):
    """The FEM model of ``body`` for scene ``params`` (:func:`springs_reason` is ``None``),
    else ``None`` (the scene's springs path).  A tet body with a physical material that runs
    on springs only because the scene names another integrator is told so (a warning)."""
    why = springs_reason(params, body)
    if why is not None:
        if why.startswith("[integrator]"):
            warnings.warn(f"the body runs on calibrated springs, not its FEM tets: {why}",
                          UserWarning, stacklevel=3)
        return None
    ph = params["physics"]
    return physical_model(body, scene_material(params), gravity=ph["gravity"],
                          damping=ph["damping"])
