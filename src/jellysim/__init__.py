"""jellysim: soft, wobbly bodies as 3D mass-spring networks.

Importing the package is light: numba, scipy and mesh/render libraries load only when used.

Threading: numba's OpenMP threads spin-wait between parallel regions by default, which makes
a run 20-270x slower when another process competes for the cores.  Unless the user set them,
``OMP_WAIT_POLICY=PASSIVE`` and ``KMP_BLOCKTIME=0`` are set here, before numba loads its
threading layer (measurements and the choice: docs/architecture.md, "Threads").
``JELLYSIM_THREADING=spin`` leaves OpenMP's defaults alone.
"""
import os as _os

if _os.environ.get("JELLYSIM_THREADING", "").lower() != "spin":
    _os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    _os.environ.setdefault("KMP_BLOCKTIME", "0")
from .body import Body
from .model import Model, finalize
from .params import GroundParams, Integrator, ProvotOrder, ProvotPairs, ProvotParams
from .simulator import Simulator
from .state import State

__version__ = "0.1.0"
__all__ = ["Body", "Model", "State", "Simulator", "finalize", "Integrator", "ProvotParams",
           "ProvotPairs", "ProvotOrder", "GroundParams", "__version__"]
