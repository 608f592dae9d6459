"""Geometry: surface meshes and point-in-mesh tests (no trimesh/meshio import at package import)."""
from jellysim.geometry.inside import InsideQuery, classify, inside
from jellysim.geometry.mesh import Mesh, MeshDefects, load_mesh

__all__ = ["InsideQuery", "Mesh", "MeshDefects", "classify", "inside", "load_mesh"]
