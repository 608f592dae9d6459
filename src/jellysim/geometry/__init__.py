"""Geometry: point fields, spring builders, surface meshes."""
from .connect import radius_springs
from .sampling import box_field

__all__ = ["box_field", "radius_springs"]
