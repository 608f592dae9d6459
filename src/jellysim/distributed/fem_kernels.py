"""Numba: one substep of the physical (FEM) path on one rank's local points.

The serial driver :func:`jellysim.kernels.fem_numba.physical_steps` runs its substeps inside one
compiled call; over MPI ranks the ghost points must be refreshed between substeps, so the
distributed driver (:mod:`.fem`) calls this function once per substep.  It runs the serial
kernels unchanged (tet corner forces, per-point gather in tet order, springs, integration with
handles, contact), on every local point (the ghosts' results are incomplete and overwritten by
the exchange); the non-finite / runaway check counts the *owned* points only, after the
integration and before contact, where the serial driver counts.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..kernels.contact_numba import _status, contact
from ..kernels.fem_numba import (_integrate, _serial_min, _spring_forces, gather_tet_forces,
                                 tet_forces)

__all__ = ["local_physical_substep"]


@njit(cache=True)
def local_physical_substep(dt, frac, x, v, a, model_arrays, fem, handles, contact_arrays,
                           scratch, owned):
    """One symplectic Euler substep of ``dt`` [s] on the local points; pins at fraction
    ``frac`` of their path over the current batch; ``owned``: local indices (int64) of the
    owned points.  Arguments as :func:`jellysim.kernels.fem_numba.physical_steps`.  Returns
    the status of the owned points."""
    g, decay, q, ptr, slot = fem[8], fem[9], fem[10], fem[11], fem[12]
    springs = model_arrays[3]
    kinds, data, rest_speed, center, bound2 = (contact_arrays[0], contact_arrays[1],
                                               contact_arrays[2], contact_arrays[3],
                                               contact_arrays[4])
    tet_force, tet_j, fsum, scalar, min_j = (scratch[0], scratch[1], scratch[2], scratch[3],
                                             scratch[4])
    tet_forces(x, fem, g, decay, q, tet_force, tet_j)
    min_j[0] = _serial_min(tet_j, min_j[0])
    gather_tet_forces(tet_force, ptr, slot, fsum)
    if springs[7]:
        _spring_forces(x, springs, scalar, fsum)
    _integrate(x, v, a, fsum, model_arrays, handles, dt, frac, center, bound2)
    nonfinite = 0
    runaway = 0
    for i in range(owned.shape[0]):
        p = owned[i]
        s = x[p, 0] + x[p, 1] + x[p, 2] + v[p, 0] + v[p, 1] + v[p, 2]
        if not np.isfinite(s):
            nonfinite += 1
        rx = x[p, 0] - center[0]
        ry = x[p, 1] - center[1]
        rz = x[p, 2] - center[2]
        if rx * rx + ry * ry + rz * rz > bound2:
            runaway += 1
    if kinds.shape[0] > 0:
        contact(x, v, kinds, data, rest_speed, dt, contact_arrays[5])
    return _status(nonfinite, runaway)
