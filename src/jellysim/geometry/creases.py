"""Hard edges of a surface, kept hard when it is shaded smooth.

A skin shaded with one normal per vertex (the area-weighted mean of its faces') rounds every
edge: a box's corner normal is (0.58, 0.58, 0.58) and its faces shade as a soft blob, with a
zig-zag highlight along each edge (session 14's artist trial).  :func:`split_creases` gives
each vertex one copy per *smoothing group* of the faces around it: faces that meet across an
edge whose dihedral angle is below ``angle`` share the copy; across a sharper edge (a crease)
they do not.  Shading the split mesh smooth then keeps the creases and rounds the rest.
"""
from __future__ import annotations

import numpy as np

__all__ = ["CREASE_ANGLE", "split_creases"]

CREASE_ANGLE = 40.0
"""Edges whose faces' normals differ by more than this [deg] stay hard (a box's 90 deg edges,
a star's points; the subdivided skin of a smooth shape bends by a few degrees per edge)."""


def split_creases(vertices, faces, angle: float = CREASE_ANGLE) -> tuple[np.ndarray, np.ndarray]:
    """``(source, split_faces)``: the split mesh's vertex ``i`` is ``vertices[source[i]]``
    (shape (m',), int64, the original vertices first, in order, when no crease passes through
    them), and ``split_faces`` (f, 3) index it.  ``vertices`` [m] (m, 3): the surface at rest,
    where its creases are measured; ``faces`` (f, 3).  Edges of one face or of more than two
    stay hard."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        return np.arange(len(v)), f
    normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = normal / np.where(length > 0, length, 1.0)
    # each face's three edges, as (low, high) vertex pairs, with the corners they join
    a, b = f, np.roll(f, -1, axis=1)
    lo, hi = np.minimum(a, b).ravel(), np.maximum(a, b).ravel()
    face = np.repeat(np.arange(len(f)), 3)
    corner_a = (3 * face + np.tile([0, 1, 2], len(f)))  # the corner of a's vertex
    corner_b = (3 * face + np.tile([1, 2, 0], len(f)))  # the corner of b's vertex
    order = np.lexsort((hi, lo))
    key = lo[order] * len(v) + hi[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    count = np.diff(np.r_[start, len(key)])
    pair = start[count == 2]  # manifold edges: two faces
    e1, e2 = order[pair], order[pair + 1]
    smooth = np.einsum("ij,ij->i", normal[face[e1]], normal[face[e2]]) >= np.cos(
        np.radians(angle))
    e1, e2 = e1[smooth], e2[smooth]
    # corners of one vertex on the two faces of a smooth edge are one copy: (a1 ~ the corner
    # of the same vertex on face 2, which is a2 when the faces run the edge the same way,
    # else b2)
    same = (a.ravel()[e1] == a.ravel()[e2])
    c1 = np.r_[corner_a[e1], corner_b[e1]]
    c2 = np.r_[np.where(same, corner_a[e2], corner_b[e2]),
               np.where(same, corner_b[e2], corner_a[e2])]
    n = 3 * len(f)
    _, group = connected_components(coo_matrix((np.ones(len(c1)), (c1, c2)), shape=(n, n)),
                                    directed=False)
    vertex_of_corner = f.ravel()
    # number the copies: the first copy of each vertex keeps its index, further ones follow
    pairs = np.unique(np.stack([vertex_of_corner, group], axis=1), axis=0)  # (vertex, group)
    first = np.r_[True, pairs[1:, 0] != pairs[:-1, 0]]
    new_index = np.empty(len(pairs), dtype=np.int64)
    new_index[first] = pairs[first, 0]
    extra = np.flatnonzero(~first)
    new_index[extra] = len(v) + np.arange(len(extra))
    source = np.r_[np.arange(len(v)), pairs[extra, 0]]
    where = np.searchsorted(pairs[:, 0] * n + pairs[:, 1], vertex_of_corner * n + group)
    return source, new_index[where].reshape(-1, 3)
