"""Texture coordinates (UVs) of a skin, carried per face corner.

A mesh file's UVs belong to its face corners: a vertex on a UV seam has one UV in each face
beside the seam.  jellysim welds the file's vertices by position (the simulated surface must
be one piece), so it keeps the UVs per corner, ``uv[f, c]`` = the UV of corner ``c`` of
face ``f``, shape (faces, 3, 2), unitless, in OBJ's convention (``vt``: origin at the bottom
left of the image, ``v`` up; trimesh reads a glTF file's UVs into it); for a file of several
materials also which one each face uses (:class:`Materials`).  Every step that changes the
faces keeps them:

* cleaning (welding, removed faces, re-oriented duplicates: :func:`align`),
* turning faces outward (corners swapped: :func:`align`),
* subdividing a coarse skin (:func:`subdivided`: each new corner interpolated linearly
  inside the face it came from, so the texture lies on the fine skin as it did on the coarse;
  a fine face keeps its parent's material).

Exports write them as a face-varying primvar (USD ``primvars:st``), separate ``vt`` indices
(OBJ), or by splitting the vertices along the seams (glTF ``TEXCOORD_0``: :func:`split_seams`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import _user_stacklevel

__all__ = ["Materials", "align", "checked", "split_seams", "subdivided", "trimesh_corner_uv"]


@dataclass(frozen=True, eq=False)
class Materials:
    """Which of a mesh file's materials each face uses (a file of several: an OBJ's
    ``usemtl`` groups, a glTF's primitives): ``index`` (f,) int64 into ``names`` (the file's
    material names).  Exports write one group per material (USD ``GeomSubset``s, OBJ
    ``usemtl`` runs, glTF primitives), so each can get its own texture."""

    index: np.ndarray
    names: tuple

    def rows(self, rows) -> "Materials":
        """The same for the faces ``rows`` (an index or mask array) of the surface."""
        return Materials(np.asarray(self.index)[rows], self.names)

    @classmethod
    def of(cls, index, names) -> "Materials | None":
        """``None`` when ``index`` is; else checked (names as strings, indices in range)."""
        if index is None:
            return None
        index, names = np.asarray(index, dtype=np.int64).reshape(-1), tuple(map(str, names))
        if index.size and (index.min() < 0 or index.max() >= len(names)):
            raise ValueError(f"material index out of range 0..{len(names) - 1}")
        return cls(index, names)


def attach_skin(body, mesh) -> None:
    """Give ``body`` the surface ``mesh`` (a :class:`~jellysim.geometry.mesh.Mesh`) as its
    skin: ``skin_vertices`` [m], ``skin_faces``, ``skin_uv``, ``skin_material`` and its names
    in ``meta["skin_material_names"]``."""
    body.skin_vertices = np.array(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    body.skin_faces = np.array(mesh.faces, dtype=np.int64).reshape(-1, 3)
    body.skin_uv, materials = mesh.uv, mesh.materials
    body.skin_material = None if materials is None else np.array(materials.index, np.int64)
    if materials is not None:
        body.meta["skin_material_names"] = list(materials.names)


def trimesh_corner_uv(trimesh, loaded, path, name: str):
    """``(uv, materials)``: the UVs of each corner of ``loaded``'s faces (f, 3, 2), or
    ``None`` when the file has none, and its faces' :class:`Materials` when it has several
    (else ``None``).  ``loaded`` is the file read as one mesh; its own UVs are not used:
    trimesh merges a file of several materials into one mesh by packing their textures into
    a new atlas and rescaling the UVs into it, and keeps one UV per seam vertex of an OBJ read in order.  So
    the file is read once more as its parts (one per material, each split along its seams, in
    the order the merged mesh has them), and their corners are taken where they are the same
    points as ``loaded``'s.  UVs that cannot be read are said (``name``: the file) and dropped,
    never a reason to refuse the file."""
    import warnings

    has_uv = getattr(loaded.visual, "uv", None) is not None or (
        path.suffix.lower() == ".obj" and b"\nvt " in path.read_bytes())
    if not has_uv:
        return None, None
    try:
        with warnings.catch_warnings():  # (trimesh's texture code's NaN medians)
            warnings.simplefilter("ignore", RuntimeWarning)
            uv, why, materials = _corner_uv(trimesh, loaded, path)
    except Exception as exc:  # noqa: BLE001 (trimesh raises many types; the geometry was read)
        uv, why, materials = None, f"{type(exc).__name__}: {exc}", None
    if uv is None:
        warnings.warn(f"{name}: its texture coordinates could not be read ({why}): the skin "
                      "and its exports carry none", UserWarning, stacklevel=_user_stacklevel())
    return uv, materials


def _corner_uv(trimesh, loaded, path):
    """``(uv or None, why not, Materials or None)``: see :func:`trimesh_corner_uv`."""
    split = trimesh.load(str(path), process=False)
    parts = split.dump() if isinstance(split, trimesh.Scene) else [split]
    uvs = [getattr(getattr(g, "visual", None), "uv", None) for g in parts]
    if not parts or any(u is None for u in uvs):
        return None, "some of its faces have none", None
    if any(np.shape(u) != (len(g.vertices), 2) for g, u in zip(parts, uvs)):
        return None, "not one per vertex", None
    corners = np.concatenate([np.asarray(g.vertices)[np.asarray(g.faces)] for g in parts])
    if corners.shape != (len(loaded.faces), 3, 3) or not np.array_equal(
            corners, np.asarray(loaded.vertices)[np.asarray(loaded.faces)]):
        return None, "its faces, read by material, could not be matched to its surface", None
    uv = np.concatenate([np.asarray(u, dtype=np.float64)[np.asarray(g.faces, dtype=np.int64)]
                         for g, u in zip(parts, uvs)])
    if not np.all(np.isfinite(uv)):
        return None, "some are not finite numbers", None
    if len(parts) == 1:
        return uv, "", None
    names = [str(getattr(getattr(g.visual, "material", None), "name", None)
                 or g.metadata.get("name") or f"material_{k}") for k, g in enumerate(parts)]
    names = [n if names.count(n) == 1 else f"{n}_{k}" for k, n in enumerate(names)]
    index = np.repeat(np.arange(len(parts)), [len(g.faces) for g in parts])
    return uv, "", Materials.of(index, names)


def checked(uv, faces: int) -> np.ndarray | None:
    """``uv`` as per-corner UVs of ``faces`` faces ((faces, 3, 2) float64), or ``None`` when
    absent, of another shape or not finite (a file's UVs are never a reason to refuse it)."""
    if uv is None:
        return None
    uv = np.asarray(uv, dtype=np.float64)
    return uv if uv.shape == (faces, 3, 2) and np.all(np.isfinite(uv)) else None


def align(old_faces: np.ndarray, uv: np.ndarray | None, new_faces: np.ndarray):
    """``uv`` (f, 3, 2) of ``old_faces`` re-ordered to the corners of ``new_faces``: the same
    faces, row by row, with their corners permuted (a face turned, a duplicate re-oriented).
    Each face's three vertex indices must be distinct.  ``None`` stays ``None``."""
    if uv is None:
        return None
    old, new = np.asarray(old_faces), np.asarray(new_faces)
    out = np.empty_like(uv)
    for c in range(3):
        for j in range(3):
            same = old[:, j] == new[:, c]
            out[same, c] = uv[same, j]
    return out


def subdivided(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, fine_vertices,
               fine_faces, parent) -> np.ndarray:
    """Per-corner UVs of a subdivided skin: corner ``c`` of fine face ``k`` (made from face
    ``parent[k]`` of ``vertices``/``faces``) gets the UV interpolated at its barycentric
    coordinates in that face (exact for midpoint subdivision, where the new vertices lie in
    the parent's plane)."""
    tri = vertices[faces[parent]]                      # (k, 3, 3) the parents' corners
    q = np.asarray(fine_vertices)[np.asarray(fine_faces)]      # (k, 3, 3) the fine corners
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    det = d11 * d22 - d12 * d12
    det = np.where(det > 0.0, det, 1.0)
    w = q - tri[:, None, 0]
    r1, r2 = (w * e1[:, None]).sum(2), (w * e2[:, None]).sum(2)
    b1 = (d22[:, None] * r1 - d12[:, None] * r2) / det[:, None]
    b2 = (d11[:, None] * r2 - d12[:, None] * r1) / det[:, None]
    b0 = 1.0 - b1 - b2
    p = uv[parent]                                     # (k, 3, 2) the parents' corner UVs
    return (b0[..., None] * p[:, None, 0] + b1[..., None] * p[:, None, 1]
            + b2[..., None] * p[:, None, 2])


def split_seams(faces: np.ndarray, uv: np.ndarray):
    """One vertex per (skin vertex, UV) pair, for formats with one UV per vertex (glTF).

    Returns ``(vertex, vertex_uv, faces)``: ``vertex`` (n,) the skin vertex each new vertex
    copies, in the skin's order (a vertex on no seam keeps its place relative to the others),
    ``vertex_uv`` (n, 2) float32 and the faces (f, 3) over the new vertices."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1)
    key = np.column_stack([f.astype(np.float64), np.asarray(uv, np.float32).reshape(-1, 2)])
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    return (uniq[:, 0].astype(np.int64), uniq[:, 1:].astype(np.float32),
            inverse.reshape(-1, 3).astype(np.int64))
