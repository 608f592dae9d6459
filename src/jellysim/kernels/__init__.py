"""Compute kernels: plain functions over flat arrays with explicit outputs.

Backends with the same function names and signatures:

* :mod:`.numpy_backend` - the executable specification, vectorised numpy, easy to read;
* :mod:`.numba_backend` - numba ``parallel=True`` versions, race-free (every per-point sum is
  a gather in a fixed order), so results are bitwise identical for any thread count;
* :mod:`.warp_backend` - NVIDIA Warp (a GPU, or Warp's CPU device): the explicit step
  (``run_steps``) and the physical path (``physical_steps``, the twin of
  :func:`.fem_numba.physical_steps`); optional (``pip install 'jellysim[gpu]'``).

Each backend is split by concern (``forces_*``, ``provot_*``, ``contact_*``, ``implicit_*``,
``steps_*``); its functions take the records of :mod:`.records` (the backend interface: the
Simulator calls only ``run_steps``, ``implicit_steps`` and ``physical_steps``).
:func:`get_backend` returns a backend by name; a new one is a :class:`Backend` member and a
branch there (the scene's and the CLI's backend choices list the members).
"""
from __future__ import annotations

from enum import Enum

from ..errors import SceneError

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
    WARP = "warp"


WARP_INTEGRATORS = ("paper", "symplectic")
"""Integrators the Warp backend implements."""


def get_backend(name: Backend | str = Backend.NUMBA, *, device: str | None = None,
                precision: str = "float64"):
    """The kernels for ``name`` (``"numpy"``, ``"numba"`` or ``"warp"``).

    ``device`` and ``precision`` apply to ``"warp"`` only (see
    :class:`~jellysim.kernels.warp_backend.WarpBackend`): an object with ``run_steps`` and
    ``physical_steps``."""
    name = Backend(name)
    if name is Backend.WARP:
        try:
            import warp  # noqa: F401
        except ImportError:
            raise SceneError("backend 'warp' needs NVIDIA Warp, which is not installed: "
                             "pip install 'jellysim[gpu]' (or pip install warp-lang)") from None
        from .warp_backend import WarpBackend

        return WarpBackend.get(device, precision)
    if name is Backend.NUMPY:
        from . import numpy_backend as mod
    else:
        from . import numba_backend as mod
    return mod
