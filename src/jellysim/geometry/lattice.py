"""Regular point lattices: a body whose springs join a grid's near neighbours.

A simple-cubic grid with radius springs up to ``1.8 h`` (edges, face and body diagonals: 26
neighbours) is a Bravais lattice, so it deforms affinely and the material calibration of
:mod:`jellysim.physics.material` is exact in its interior; its Poisson's ratio is 1/4 and it is
nearly isotropic (C11 : C12 : C44 = 1.21 : 0.40 : 0.40 E).  Random fields connected by a radius
are softer near their surface and sag more than the calibration predicts (docs/physics.md).
"""
from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["grid_points", "grid_point_volumes", "grid_radius", "grid_tets", "cell_tets",
           "kuhn_offsets"]


def grid_points(count: int, lower, upper) -> np.ndarray:
    """A cubic grid of about ``count`` cells filling the box ``[lower, upper]`` [m], corners
    included (so more points than ``count``: 216 cells of a cube give 7^3 = 343 points);
    spacing ``h = (volume / count)^(1/3)`` rounded so each side is a whole number of cells.
    Returns points [m], shape (n, 3), float64, x-major order."""
    lower = np.asarray(lower, dtype=np.float64).reshape(3)
    upper = np.asarray(upper, dtype=np.float64).reshape(3)
    if isinstance(count, (float, np.floating)) and float(count).is_integer():
        count = int(count)  # (1e3: a whole number)
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 8:
        raise ParameterError(f"a grid box needs a whole number of points >= 8, got {count!r} "
                             "(for a grid, points "
                             "counts the cells: N cells give about (N^(1/3) + 1)^3 points)")
    if not np.all(upper > lower):
        raise ParameterError(f"box upper corner {upper.tolist()} must exceed lower {lower.tolist()}")
    size = upper - lower
    h = (np.prod(size) / count) ** (1.0 / 3.0)
    cells = np.maximum(1, np.round(size / h).astype(int))
    axes = [np.linspace(lo, hi, c + 1) for lo, hi, c in zip(lower, upper, cells)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def grid_radius(count: int, lower, upper) -> float:
    """1.8 spacings [m] of the grid :func:`grid_points` lays in the box: a spring radius
    reaching each point's nearest, face-diagonal and body-diagonal neighbours (26)."""
    size = np.asarray(upper, dtype=np.float64).reshape(3) - np.asarray(
        lower, dtype=np.float64).reshape(3)
    with np.errstate(over="ignore", invalid="ignore"):  # (an absurd box: refused later)
        h = (np.prod(size) / count) ** (1.0 / 3.0)
        return float(1.8 * np.max(size / np.maximum(1, np.round(size / h))))


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


def kuhn_offsets() -> np.ndarray:
    """The 6 Kuhn tets of the unit cube as corner bit-vectors, shape (6, 4, 3), int64: tet
    ``p`` walks from corner 000 to 111 adding the unit vectors in the order of permutation
    ``p`` (the report's marching-tetrahedra split, around the cube's main diagonal)."""
    import itertools

    out = []
    for perm in itertools.permutations(range(3)):
        c = np.zeros(3, dtype=np.int64)
        path = [c.copy()]
        for axis in perm:
            c[axis] = 1
            path.append(c.copy())
        out.append(path)
    return np.array(out, dtype=np.int64)


def cell_tets(cells: np.ndarray, strides, *, mirrored: bool = True) -> np.ndarray:
    """The six Kuhn tets of each grid cell: node ids, shape (6 c, 4), int64, cell by cell
    (orientation mixed: callers orient).

    ``cells``: base node indices (i, j, k) of the cells, shape (c, 3); ``strides``: node id of
    (i, j, k) = i s0 + j s1 + k s2.  With ``mirrored`` (the default) every cell's split is
    reflected along each axis on which its index is odd: reflections keep a shared square
    face's diagonal, so the triangulation stays conforming, and the mesh has no preferred
    diagonal.  The plain split (every cell around the same diagonal, ``mirrored=False``, the
    report's) is anisotropic: a 5 cm gelatin cube dropped flat 10 cm slid 34 mm along
    (-1, 0, -1) and a 6 cm ball rolled 9 cm away after landing; mirrored, 0.0 mm and 6-8 mm
    (a ball rolls on any asymmetry left; docs/physics.md section 0, session 8).
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    loc = kuhn_offsets()[None]  # (1, 6, 4, 3)
    if mirrored:
        loc = np.where((cells % 2).astype(bool)[:, None, None, :], 1 - loc, loc)
    pos = cells[:, None, None, :] + loc
    return (pos @ np.asarray(strides, dtype=np.int64)).reshape(-1, 4)


def grid_tets(points: np.ndarray, *, mirrored: bool = True) -> np.ndarray:
    """Kuhn tetrahedra (6 per cell, :func:`cell_tets`, mirrored by default; conforming) of a
    full box grid in :func:`grid_points` order.  Returns indices, shape (6 cells, 4), int64,
    positively oriented."""
    points = np.asarray(points, dtype=np.float64)
    counts = [len(np.unique(points[:, c])) for c in range(3)]
    if int(np.prod(counts)) != points.shape[0]:
        raise ParameterError("grid_tets needs a full box grid (grid_points)")
    nx, ny, nz = (c - 1 for c in counts)
    cells = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"),
                     axis=-1).reshape(-1, 3)
    tets = cell_tets(cells, (counts[1] * counts[2], counts[2], 1), mirrored=mirrored)
    a = points[tets[:, 0]]
    vol = np.einsum("ij,ij->i", points[tets[:, 1]] - a,
                    np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a))
    neg = vol < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    return tets
