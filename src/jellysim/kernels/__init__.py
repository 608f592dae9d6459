"""Compute kernels: plain functions over flat arrays with explicit outputs.

Two backends with the same function names and signatures:

* :mod:`.numpy_backend` - the executable specification, vectorised numpy, easy to read;
* :mod:`.numba_backend` - numba ``parallel=True`` versions, race-free (every per-point sum is
  a gather in a fixed order), so results are bitwise identical for any thread count.

Each backend is split by concern (``forces_*``, ``provot_*``, ``contact_*``, ``implicit_*``,
``steps_*``); its functions take the records of :mod:`.records` (the backend interface: the
Simulator calls only ``run_steps`` and ``implicit_steps``).  :func:`get_backend` returns a
backend by name.
"""
from __future__ import annotations

from enum import Enum

__all__ = ["Backend", "get_backend", "STATUS_OK", "STATUS_NONFINITE", "STATUS_RUNAWAY"]

STATUS_OK = 0
STATUS_NONFINITE = 1
"""A position, velocity or acceleration became NaN or infinite."""
STATUS_RUNAWAY = 2
"""A point flew farther than the runaway bound from the body's starting centre."""

INTEGRATOR_CODES = {"paper": 0, "symplectic": 1}


class Backend(str, Enum):
    NUMPY = "numpy"
    NUMBA = "numba"


def get_backend(name: Backend | str = Backend.NUMBA):
    """The kernel module for ``name`` (``"numpy"`` or ``"numba"``)."""
    name = Backend(name)
    if name is Backend.NUMPY:
        from . import numpy_backend as mod
    else:
        from . import numba_backend as mod
    return mod
