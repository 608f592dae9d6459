"""Geometry: point fields, spring builders, surface meshes and point-in-mesh tests.

No trimesh/meshio import at package import.
"""
from .connect import choose_radius, radius_springs
from .inside import InsideQuery, classify, inside
from .mesh import Mesh, MeshDefects, load_mesh
from .sampling import Sampling, box_field, sample_inside

__all__ = ["InsideQuery", "Mesh", "MeshDefects", "Sampling", "box_field", "choose_radius",
           "classify", "inside", "load_mesh", "radius_springs", "sample_inside"]
