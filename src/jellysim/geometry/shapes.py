"""Procedural surface meshes: shapes that read as jello.

:func:`jelly_mould` is the classic fluted dessert mould turned out on a plate: a surface of
revolution (wide base, tapering sides, rounded top) with ``lobes`` flutes around it.  The mesh
is closed, consistently oriented (outward normals) and has no degenerate faces.
"""
from __future__ import annotations

import numpy as np

__all__ = ["jelly_mould"]


def jelly_mould(*, base_radius: float = 0.04, top_radius: float = 0.026, height: float = 0.05,
                lobes: int = 8, flute: float = 0.09, rings: int = 24,
                segments: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """A fluted jelly mould standing on ``y = 0``, centred on the y axis.

    Returns vertices [m], shape (m, 3), and faces, shape (f, 3), int64 (outward normals).

    The radius at height ``y`` (``s = y / height``) is ``r(s) = base_radius + (top_radius -
    base_radius) s^1.3``, rounded over the last 30 % of the height into a dome; around the axis
    it is modulated by ``1 + flute cos(lobes theta)`` (fading out on the dome's top).
    """
    s = np.linspace(0.0, 1.0, rings + 1)
    theta = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    side = base_radius + (top_radius - base_radius) * s**1.3
    dome = np.clip((s - 0.7) / 0.3, 0.0, 1.0)
    r = side * np.sqrt(np.clip(1.0 - dome**2, 0.0, 1.0))
    y = height * (0.7 * np.minimum(s, 0.7) / 0.7 + 0.3 * np.sin(0.5 * np.pi * dome))
    mod = 1.0 + flute * np.cos(lobes * theta)[None, :] * (1.0 - dome[:, None] ** 2)
    rr = r[:, None] * mod
    verts = np.stack([rr * np.cos(theta)[None, :], np.repeat(y[:, None], segments, 1),
                      rr * np.sin(theta)[None, :]], axis=-1)
    # the top ring (r = 0) collapses to one apex; the bottom gets a centre vertex
    ring = verts[:rings].reshape(-1, 3)
    apex = np.array([[0.0, y[-1], 0.0]])
    centre = np.array([[0.0, 0.0, 0.0]])
    vertices = np.concatenate([ring, apex, centre])
    a_id, c_id = rings * segments, rings * segments + 1
    faces = []
    j = np.arange(segments)
    jn = (j + 1) % segments
    for i in range(rings - 1):
        a, b = i * segments + j, i * segments + jn
        c, d = (i + 1) * segments + j, (i + 1) * segments + jn
        faces.append(np.stack([a, c, b], axis=1))
        faces.append(np.stack([b, c, d], axis=1))
    top = (rings - 1) * segments
    faces.append(np.stack([top + j, np.full(segments, a_id), top + jn], axis=1))
    faces.append(np.stack([j, jn, np.full(segments, c_id)], axis=1))
    faces = np.concatenate(faces).astype(np.int64)
    # orient outwards: the signed volume must be positive
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    if np.einsum("ij,ij->i", v0, np.cross(v1, v2)).sum() < 0:
        faces = faces[:, [0, 2, 1]]
    return vertices, faces
