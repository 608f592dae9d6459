"""Numba kernels: same names, signatures and results as :mod:`.numpy_backend` (the spec).

This module gathers the backend's public functions from its parts (one module per concern):
:mod:`.forces_numba` (report eq. 1), :mod:`.provot_numba` (strain limiting),
:mod:`.contact_numba` (the report's ground, obstacles, contact constraints),
:mod:`.implicit_numba` (theta-method, BDF2, conjugate gradients) and :mod:`.steps_numba`
(the explicit drivers); their arguments are the records of :mod:`.records`.

Parallel loops run over *points*, never over springs with a scatter-add (that would race):
each point sums the forces and Provot requests of all its springs, each computed from its own
end (:mod:`.spring_sums_numba`: the springs it is the first point of, then the ones it is the
second point of, in one list per point whose other ends, rest lengths and stiffnesses are
stored in list order, so the loop reads contiguously and vectorises).  Nothing
is written per spring.  Each point's sum is taken in an order fixed by the compiled code, so
the result is bitwise identical for any number of threads.  Floating-point
reductions across threads (like the largest Provot correction) are taken from per-point arrays
in a serial loop, also order-fixed.  ``cache=True``: a second process loads the compiled code.
"""
from __future__ import annotations

from .contact_numba import (constrain_start, constraint_friction, contact, contact_normals,
                            filter_constrained, finish_step)
from .forces_numba import accelerations
from .implicit_numba import implicit_steps, spring_frames, system_diagonal, system_matvec
from .provot_numba import provot
from .steps_numba import run_steps

# private helpers under their former module (kernels elsewhere may reuse them)
from ._numba_opts import OPTS as _opts  # noqa: E402,F401
from .contact_numba import _contact_point, _ground_and_check, _status  # noqa: E402,F401
from .implicit_numba import _copy, _dot  # noqa: E402,F401
from .provot_numba import _provot_c, _provot_c_inv, _serial_max  # noqa: E402,F401


def __getattr__(name):
    """``physical_steps`` (the physical path's driver, :func:`.fem_numba.physical_steps`),
    imported when first asked for: a springs run does not load the tet kernels."""
    if name == "physical_steps":
        from .fem_numba import physical_steps

        return physical_steps
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["accelerations", "provot", "finish_step", "run_steps", "contact", "contact_normals",
           "filter_constrained", "constrain_start", "constraint_friction", "spring_frames",
           "system_matvec", "system_diagonal", "implicit_steps", "physical_steps"]
