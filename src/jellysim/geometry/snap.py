"""Snap the staircase surface of a grid body onto the surface mesh it was cut from.

The marching grid keeps the cubes' tets whose four corners are inside the mesh, so its surface
is a staircase up to one cell inside the true surface.  :func:`snap_to_surface` moves every
boundary node of the tet mesh onto the nearest point of the surface (when it is within
``reach`` cells), then undoes the moves that make a tet inverted or badly shaped (first
halving the move, then reverting it), so the body keeps the grid's well-shaped tets (what sets
an explicit integrator's time step) and gains the mesh's shape and volume.
"""
from __future__ import annotations

import numpy as np

__all__ = ["snap_to_surface"]


def snap_to_surface(points, tets, vertices, faces, h: float, *, reach: float = 0.75,
                    min_quality: float = 0.2, seed: int = 0) -> np.ndarray:
    """New positions [m], shape (n, 3), of ``points`` with the boundary nodes of ``tets`` on
    the surface ``(vertices, faces)`` where that keeps every tet's quality (normalised volume,
    :func:`~jellysim.geometry.tetra.tet_quality`) above ``min_quality`` and its orientation."""
    import trimesh
    from scipy.spatial import cKDTree

    from .tetra import boundary_faces, tet_quality, tet_signed_volumes

    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(tets, dtype=np.int64)
    v = np.asarray(vertices, dtype=np.float64)
    tm = trimesh.Trimesh(v, np.asarray(faces, dtype=np.int64), process=False, validate=False)
    spacing = h / 8.0
    count = int(min(max(float(tm.area) / spacing**2, 1000), 5_000_000))
    dense, _ = trimesh.sample.sample_surface_even(tm, count, seed=seed) if hasattr(
        trimesh.sample, "sample_surface_even") else trimesh.sample.sample_surface(tm, count)
    samples = np.concatenate([v, dense])
    bnd = np.unique(boundary_faces(t, len(p)).ravel())
    d, idx = cKDTree(samples).query(p[bnd], distance_upper_bound=reach * h)
    # nodes already within a tenth of a cell of the surface stay (the samples are only
    # h / 8 apart: snapping those would move them sideways along the surface)
    ok = np.isfinite(d) & (d > 0.1 * h)
    bnd, idx = bnd[ok], idx[ok]
    move = np.zeros_like(p)
    move[bnd] = samples[idx] - p[bnd]
    sign0 = np.sign(tet_signed_volumes(p, t))
    for _ in range(8):
        new = p + move
        vol = tet_signed_volumes(new, t)
        bad = (np.sign(vol) != sign0) | (tet_quality(new, t, vol) < min_quality)
        if not bad.any():
            break
        nodes = np.unique(t[bad].ravel())
        move[nodes] *= 0.5
    new = p + move
    vol = tet_signed_volumes(new, t)
    bad = (np.sign(vol) != sign0) | (tet_quality(new, t, vol) < min_quality)
    if bad.any():
        move[np.unique(t[bad].ravel())] = 0.0
        new = p + move
    return new
