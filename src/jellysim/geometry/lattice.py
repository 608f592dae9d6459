"""Regular point lattices: a body whose springs join a grid's near neighbours.

A simple-cubic grid with radius springs up to ``1.8 h`` (edges, face and body diagonals: 26
neighbours) is a Bravais lattice, so it deforms affinely and the material calibration of
:mod:`jellysim.physics.material` is exact in its interior; its Poisson's ratio is 1/4 and it is
nearly isotropic (C11 : C12 : C44 = 1.21 : 0.40 : 0.40 E).  Random fields connected by a radius
are softer near their surface and sag more than the calibration predicts (docs/physics.md).
"""
from __future__ import annotations

import numpy as np

__all__ = ["grid_points", "grid_point_volumes"]


def grid_points(count: int, lower, upper) -> np.ndarray:
    """A cubic grid of about ``count`` cells filling the box ``[lower, upper]`` [m], corners
    included (so more points than ``count``: 216 cells of a cube give 7^3 = 343 points);
    spacing ``h = (volume / count)^(1/3)`` rounded so each side is a whole number of cells.
    Returns points [m], shape (n, 3), float64, x-major order."""
    lower = np.asarray(lower, dtype=np.float64).reshape(3)
    upper = np.asarray(upper, dtype=np.float64).reshape(3)
    if count < 8:
        raise ValueError(f"a grid needs at least 8 points, got {count}")
    if not np.all(upper > lower):
        raise ValueError(f"box upper corner {upper.tolist()} must exceed lower {lower.tolist()}")
    size = upper - lower
    h = (np.prod(size) / count) ** (1.0 / 3.0)
    cells = np.maximum(1, np.round(size / h).astype(int))
    axes = [np.linspace(lo, hi, c + 1) for lo, hi, c in zip(lower, upper, cells)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def grid_point_volumes(points: np.ndarray) -> np.ndarray:
    """Volume [m^3], shape (n,), each point of a full box grid (:func:`grid_points`) owns: its
    cell ``h_x h_y h_z``, halved for each axis on which it lies on a face."""
    points = np.asarray(points, dtype=np.float64)
    vol = np.ones(points.shape[0])
    for c in range(3):
        coords = np.unique(points[:, c])
        h = float(np.diff(coords).mean()) if len(coords) > 1 else 1.0
        on_face = np.isclose(points[:, c], coords[0]) | np.isclose(points[:, c], coords[-1])
        vol *= np.where(on_face, 0.5 * h, h)
    return vol


def grid_tets(points: np.ndarray) -> np.ndarray:
    """Kuhn tetrahedra (6 per cell, around each cell's main diagonal; conforming) of a full box
    grid in :func:`grid_points` order.  Returns indices, shape (6 cells, 4), int64, positively
    oriented."""
    import itertools

    points = np.asarray(points, dtype=np.float64)
    counts = [len(np.unique(points[:, c])) for c in range(3)]
    if int(np.prod(counts)) != points.shape[0]:
        raise ValueError("grid_tets needs a full box grid (grid_points)")
    idx = np.arange(points.shape[0]).reshape(counts)
    nx, ny, nz = (c - 1 for c in counts)
    tets = []
    for perm in itertools.permutations(range(3)):
        corner = [np.zeros(3, dtype=int)]
        for a in perm:
            c = corner[-1].copy()
            c[a] = 1
            corner.append(c)
        cols = [idx[c[0]:c[0] + nx, c[1]:c[1] + ny, c[2]:c[2] + nz].ravel() for c in corner]
        tets.append(np.stack(cols, axis=1))
    tets = np.concatenate(tets).astype(np.int64)
    a = points[tets[:, 0]]
    vol = np.einsum("ij,ij->i", points[tets[:, 1]] - a,
                    np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a))
    neg = vol < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    return tets
