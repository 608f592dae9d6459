"""jellysim: soft, wobbly bodies as 3D mass-spring networks.

Importing the package is light: numba, scipy and mesh/render libraries load only when used.
"""
from .body import Body
from .model import Model, finalize
from .params import GroundParams, Integrator, ProvotOrder, ProvotPairs, ProvotParams
from .simulator import Simulator
from .state import State

__version__ = "0.1.0"
__all__ = ["Body", "Model", "State", "Simulator", "finalize", "Integrator", "ProvotParams",
           "ProvotPairs", "ProvotOrder", "GroundParams", "__version__"]
