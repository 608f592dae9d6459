"""Shared helpers of the validation examples: a calibrated grid body of gelatin."""
from __future__ import annotations

import numpy as np

from jellysim.body import Body
from jellysim.geometry.connect import radius_springs
from jellysim.geometry.lattice import grid_point_volumes
from jellysim.model import finalize
from jellysim.physics.material import calibrate_springs
from jellysim.presets import GELATIN_DENSITY, GELATIN_YOUNGS_MODULUS


def grid_body(cells, lower, upper, *, youngs_modulus=GELATIN_YOUNGS_MODULUS,
              density=GELATIN_DENSITY, gravity=(0.0, -9.8, 0.0)):
    """A box of ``cells`` (nx, ny, nz) grid cells, radius springs to 1.8 spacings, springs
    calibrated to ``youngs_modulus`` [Pa], masses from ``density`` [kg/m^3]."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    axes = [np.linspace(lo, hi, c + 1) for lo, hi, c in zip(lower, upper, cells)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    h = float(np.min((upper - lower) / np.asarray(cells)))
    body = Body(points=pts, springs=radius_springs(pts, 1.8 * h),
                volume=float(np.prod(upper - lower)), meta={"builder": "grid"})
    pv = grid_point_volumes(pts)
    body.stiffness = calibrate_springs(body, youngs_modulus, point_volume=pv)
    body.masses = density * pv
    return finalize(body, gravity=gravity)


def zero_crossing_frequency(t, u):
    """Mean frequency [Hz] from the downward zero crossings of ``u(t)``."""
    t, u = np.asarray(t), np.asarray(u)
    i = np.nonzero((u[:-1] > 0) & (u[1:] <= 0))[0]
    crossings = t[i] + u[i] / (u[i] - u[i + 1]) * (t[i + 1] - t[i])
    return 1.0 / np.diff(crossings).mean() if len(crossings) > 1 else float("nan")
