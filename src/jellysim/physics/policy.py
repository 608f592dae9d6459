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

from ..params import GRAVITY, Material, MaterialModel
from ..model import finalize
from .fem import fem_arrays

__all__ = ["physical_model", "scene_material", "scene_fem_model"]


def physical_model(body, material: Material = Material(), *, gravity=GRAVITY,
                   damping: float = 0.0, point_volume=None):
    """A :class:`~jellysim.model.Model` of ``body`` made of ``material``.

    Parameters
    ----------
    body: :class:`~jellysim.body.Body` (needs tets for ``MaterialModel.FEM``).
    material: :class:`~jellysim.params.Material`.
    gravity: [m/s^2], shape (3,).
    damping: the report's velocity damping delta [kg/s] (0 for a real material).
    point_volume: [m^3], shape (n,): volumes owned by the points (springs model only; default
        from the tets or the body volume).
    """
    from ..geometry.tetra import lump_tet_masses

    g = np.asarray(gravity, dtype=np.float64)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ValueError(f"gravity must be 3 finite numbers (x, y, z) in m/s^2, e.g. (0, -9.8, "
                         f"0) or (0, 0, 0) for none; got {gravity!r}")
    if material.model is MaterialModel.FEM:
        if body.tets is None or len(body.tets) == 0:
            raise ValueError(
                "the FEM material needs a body with tets (connect = 'delaunay', 'marching' or "
                "'tetgen', or radius bodies built with tets); use "
                "Material(model='springs') for a springs-only body")
        fem = fem_arrays(body.points, body.tets, youngs_modulus=material.youngs_modulus,
                         poisson_ratio=material.poisson_ratio,
                         damping_ratio=material.damping_ratio,
                         damping_frequency=material.damping_frequency)
        mass = lump_tet_masses(body.points, fem.tets, material.density)
        lonely = mass <= 0
        if lonely.any():
            # points in no tet (stragglers of a carved point cloud): give them the mean mass so
            # that they stay finite; only springs (if any) act on them
            warnings.warn(f"{int(lonely.sum())} of {len(mass)} points belong to no tet; they "
                          "get the mean point mass and no elastic force", stacklevel=2)
            mass[lonely] = mass[~lonely].mean()
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
                    model="springs" if mat["model"] == "springs" else "fem")


def scene_fem_model(params: dict, body):
    """The FEM model of ``body`` for scene ``params`` (``[material] model`` 'fem', or 'auto'
    and the body has tets), else ``None`` (the scene's springs path)."""
    mat = params["material"]
    material = scene_material(params)
    if material is None or mat["model"] == "springs":
        return None
    if mat["model"] == "auto" and (body.tets is None or len(body.tets) == 0
                                   or "cloud_tets" in body.meta
                                   or params["integrator"]["name"] != "symplectic"):
        # 'auto' takes the FEM path for tet bodies (tet builders, grid boxes); a radius
        # body's Delaunay tets of random points have slivers (a tiny explicit substep):
        # it stays on springs unless model = 'fem' asks for them; so does a scene that names
        # another integrator than the physical path's
        return None
    ph = params["physics"]
    return physical_model(body, material, gravity=ph["gravity"], damping=ph["damping"])
