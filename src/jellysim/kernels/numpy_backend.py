"""Numpy reference kernels: the executable specification of one time step.

Every function here has a numba twin of the same name and signature in
:mod:`jellysim.kernels.numba_backend`; tests check that they agree.  The functions live in one
module per concern (:mod:`.forces_numpy`, :mod:`.provot_numpy`, :mod:`.contact_numpy`,
:mod:`.implicit_numpy`, :mod:`.steps_numpy`) and take the records of :mod:`.records`.  Arrays
follow the Model's conventions: positions ``x`` [m] (n, 3), velocities ``v`` [m/s] (n, 3),
accelerations ``a`` [m/s^2] (n, 3), springs ``springs.ij`` (k, 2) with i < j.  The CSR fields
of :class:`~.records.SpringArrays` are unused here; the numba kernels gather through them.
``spring_scalar`` is scratch whose use is backend-specific (numpy: the per-spring scalars in
spring order; numba: untouched, each point computes its springs from its own end).
"""
from __future__ import annotations

from .contact_numpy import (CONTACT_FREE, CONTACT_RELEASED, CONTACT_STUCK, constrain_start,
                            constraint_friction, contact, contact_normals, filter_constrained,
                            finish_step)
from .forces_numpy import accelerations
from .implicit_numpy import implicit_steps, spring_frames, system_diagonal, system_matvec
from .provot_numpy import provot
from .steps_numpy import run_steps

# private helpers under their former module (kernels elsewhere may reuse them)
from .contact_numpy import _contact_geometry  # noqa: E402,F401
from .forces_numpy import _scatter  # noqa: E402,F401
from .implicit_numpy import _dot  # noqa: E402,F401
from .provot_numpy import _provot_scalar  # noqa: E402,F401


def __getattr__(name):
    """``physical_steps`` (the physical path's driver, :func:`.fem_numpy.physical_steps`),
    imported when first asked for."""
    if name == "physical_steps":
        from .fem_numpy import physical_steps

        return physical_steps
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["accelerations", "provot", "finish_step", "run_steps", "contact", "contact_normals",
           "filter_constrained", "constrain_start", "constraint_friction", "spring_frames",
           "system_matvec", "system_diagonal", "implicit_steps", "physical_steps", "CONTACT_FREE",
           "CONTACT_RELEASED", "CONTACT_STUCK"]
