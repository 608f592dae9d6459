"""The report's marching-tetrahedra grid builder (section 4.3), split from
:mod:`jellysim.geometry.tetra` (import it from there).  Conventions: see that module."""
from __future__ import annotations

import itertools
import math

import numpy as np

from jellysim.body import Body
from jellysim.errors import BuildError
from jellysim.geometry.lattice import cell_tets
from jellysim.geometry.tetra import (DEFAULT_DENSITY, InsideFn, _as_vertices, _check_inside,
                                     _finish)


# ----------------------------------------------------------------------------------------------
# Marching-tetrahedra grid
# ----------------------------------------------------------------------------------------------
def _grid_springs(tets: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """The grid's Kuhn edges (node ids, (k, 2)) whose two ends are corners of ``tets``."""
    nx, ny, nz = shape
    strides = np.array([ny * nz, nz, 1], dtype=np.int64)
    kept = np.zeros(nx * ny * nz, dtype=bool)
    kept[tets.ravel()] = True
    sub = kept.reshape(nx, ny, nz)
    springs = []
    for d in itertools.product((0, 1), repeat=3):
        if d == (0, 0, 0):
            continue
        d = np.array(d)
        a = sub[: nx - d[0], : ny - d[1], : nz - d[2]]
        b = sub[d[0]:, d[1]:, d[2]:]
        ii, jj, kk = np.nonzero(a & b)
        src = ii * strides[0] + jj * strides[1] + kk * strides[2]
        springs.append(np.stack([src, src + int(d @ strides)], axis=1))
    return np.concatenate(springs, axis=0)


def marching_grid(vertices, faces, inside_fn: InsideFn, *, h: float,
                  density: float = DEFAULT_DENSITY, warp: bool = False) -> Body:
    """Marching-tetrahedra grid body (report section 4.3).

    The grid has ``n = ceil(extent / h)`` cubes of edge ``h`` along each axis, centred on the
    bounding box of ``vertices`` (so it covers the box, overhanging equally on both sides).
    Every cube is cut into the six Kuhn tetrahedra of :func:`~jellysim.geometry.lattice.
    cell_tets`: the report's staircase uses the same split in every cube; ``warp`` mirrors it in
    every other cube along each axis, so the mesh has no preferred diagonal (a body dropped
    straight no longer slides or rolls off along it).  Both are conforming (no T-junctions).

    * A grid node is *inside* when ``inside_fn`` says so.
    * A tet is kept when its four corners are inside (for mass, volume and skin).  With
      ``warp``, the nodes near the surface move onto it and the cut cubes' tets are kept as
      :func:`~jellysim.geometry.snap.warp_to_surface` says: the body fills the mesh instead of a
      staircase inside it (not the report's; :func:`jellysim.build.build_body`'s default).
    * Points = inside nodes that are a corner of a kept tet (warped: and the nodes moved onto
      the surface; renumbered in grid order ``i, j, k`` with ``k`` fastest).  Inside nodes in
      no kept tet would be massless and are dropped (``meta["dropped_points"]``).
    * Springs = every edge of the grid's tetrahedralization whose two end points are points:
      the report's "edges whose end points are inside", restricted to points that carry mass
      (warped: the edges of the kept tets).
      These edges join node ``(i, j, k)`` to ``(i, j, k) + d``, ``d`` in ``{0, 1}^3 \\ {0}``.

    Parameters
    ----------
    vertices, faces: the surface mesh (only its bounding box is used here).
    inside_fn: point-in-mesh test, ``(n, 3) float64 -> (n,) bool``.
    h: cube edge length [m], > 0.
    density: mass density [kg/m^3].
    warp: move the grid onto the surface (see above).
    """
    v = _as_vertices(vertices)
    nf = int(np.asarray(faces).shape[0]) if faces is not None else 0
    h = float(h)
    if not (math.isfinite(h) and h > 0):
        raise BuildError(f"h must be a positive finite length [m], got {h!r}")
    lo, hi = v.min(axis=0), v.max(axis=0)
    ext = hi - lo
    ncell = grid_cells(ext, h, warp)
    if int(np.prod(ncell + 1)) > 50_000_000:
        raise BuildError(f"h={h} gives a {tuple(int(c) for c in ncell)} grid; too many nodes")
    origin = lo - (ncell * h - ext) / 2.0
    nx, ny, nz = (int(c) + 1 for c in ncell)  # node counts

    gi, gj, gk = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    ijk = np.stack([gi.ravel(), gj.ravel(), gk.ravel()], axis=1)
    nodes = origin + ijk * h
    inside = _check_inside(inside_fn, nodes, "grid nodes")

    # cubes: base node (i, j, k) with i < nx-1 etc.; only cubes with >= 4 inside corners matter
    # (warped: >= 1, the cubes the surface cuts)
    strides = np.array([ny * nz, nz, 1], dtype=np.int64)
    ins3 = inside.reshape(nx, ny, nz)
    count = np.zeros((nx - 1, ny - 1, nz - 1), dtype=np.int8)
    for dx, dy, dz in itertools.product((0, 1), repeat=3):
        count += ins3[dx:nx - 1 + dx, dy:ny - 1 + dy, dz:nz - 1 + dz]
    ci, cj, ck = np.nonzero(count >= (1 if warp else 4))
    # warped: the mirrored split (no preferred diagonal); the staircase keeps the report's
    tets = cell_tets(np.stack([ci, cj, ck], axis=1), strides, mirrored=warp)
    if warp:
        from jellysim.geometry.snap import warp_to_surface

        nodes, tets = warp_to_surface(nodes, inside, tets, inside_fn,
                                      bounds=(v.min(axis=0), v.max(axis=0)))
    else:
        tets = tets[inside[tets].all(axis=1)]

    # warped: the tets' edges (a grid edge between two nodes on the surface may cross a
    # concavity where the tets between them were dropped)
    springs = None if warp else _grid_springs(tets, (nx, ny, nz))
    meta = {
        "builder": "marching_grid",
        "h": h,
        "grid_origin": [float(x) for x in origin],
        "grid_cells": [int(c) for c in ncell],
        "split": "kuhn6-mirrored" if warp else "kuhn6",
        "warped": bool(warp),
        "surface_vertices": int(v.shape[0]),
        "surface_faces": nf,
    }
    return _finish(nodes, tets, density, meta, springs=springs)



def fit_height(h: float, height: float) -> float:
    """The cube edge [m] near ``h`` (never larger) whose grid of cubic cells spans ``height``
    [m] but for a hair, so that the bottom and top node layers of the grid (centred on the
    bounding box) lie just inside the mesh's lowest and highest points."""
    if not height > 0:
        return h
    cells = max(1, math.ceil(height / h - 1e-9))
    cells += cells % 2  # even, as the warped grid's horizontal counts (a cube then fits)
    return height * (1.0 - 2e-6) / cells


def grid_cells(extents, h: float, warp: bool = True) -> np.ndarray:
    """Cells of :func:`marching_grid` along each axis (int64 (3,)) for a bounding box of
    ``extents`` [m] and cube edge ``h`` [m]: ``ceil(extent / h)`` (an extent within 1e-5 of
    a whole number of cells is that many: build_body may fit the grid to the box so that its
    outer nodes lie a hair inside it).  Warped, the mirrored split is symmetric under a
    reflection through the box's centre only across an even number of cells (an odd count
    puts one unmirrorable cell in the middle): so across x and z, the horizontal axes, the
    count is made even (a body dropped straight then has no preferred side to slide to)."""
    ext = np.asarray(extents, dtype=np.float64)
    ncell = np.maximum(1, np.ceil(ext / h * (1.0 - 1e-5)).astype(np.int64))
    if warp:
        ncell[[0, 2]] += ncell[[0, 2]] % 2
    return ncell


def missed_fraction(h: float, extents) -> float:
    """The fraction of a box of ``extents`` [m] (3,) that a warped grid of edge ``h`` misses
    (as :func:`marching_grid` lays it out: :func:`grid_cells`, centred): where a face lies between grid nodes with the outer node more than
    ``WARP_ALPHA_OUTSIDE`` of an edge outside and the inner one more than ``1 - WARP_ALPHA``
    inside, neither moves onto it and a layer up to 0.55 h thick on that side is lost (a
    10 x 6 x 10 cm box at h = 9.7 mm: 5.8 mm top and bottom, 20 % of its volume)."""
    from .snap import WARP_ALPHA, WARP_ALPHA_OUTSIDE

    ext = np.asarray(extents, dtype=np.float64)
    over = (grid_cells(ext, h) * h - ext) / 2.0  # each side's outer node beyond the face
    missed = (over >= WARP_ALPHA_OUTSIDE * h) & (over <= (1.0 - WARP_ALPHA) * h)
    lost = np.where(missed, 2.0 * (h - over), 0.0)
    return float(1.0 - np.prod(np.clip(1.0 - lost / np.maximum(ext, 1e-300), 0.0, 1.0)))


def aligned_edge(h: float, extents) -> float:
    """A cube edge [m] within 0.85-1.15 ``h`` whose warped grid reaches every face of a box of
    ``extents`` (:func:`missed_fraction` smallest; of equals, the nearest to ``h``): the
    candidates put one axis's outer node layers a hair inside the box (``extent / n``)."""
    ext = np.asarray(extents, dtype=np.float64)
    best = (missed_fraction(h, ext), 0.0, h)
    for e in ext[ext > 0]:
        for n in range(max(1, math.floor(e / (1.15 * h))), math.ceil(e / (0.85 * h)) + 1):
            c = e * (1.0 - 2e-6) / n
            if 0.85 * h <= c <= 1.15 * h:
                best = min(best, (missed_fraction(c, ext), abs(math.log(c / h)), c))
    return best[2]


MARCHING_FILL_WARNING = 0.8
"""A marching body whose tets hold less than this fraction of its mesh's volume, or span less
than 0.9 of its width along an axis (Suzanne's ears, the teapot's spout: 76 % at 800 points,
API trial, session 28), warns.  Warped onto the surface (the default), a 10 cm sphere fills
86 % at 400 points, 93 % at 1,000, 97 % at 3,000; Spot 88 % at 800, 94 % at 3,000 (session 8;
the report's staircase, ``snap=False``: 63-81 % and 60-74 %, session 7)."""


def marching_fill_said(name: str, h: float, fill: float, reach) -> str | None:
    """The warning for a marching body (cell ``h`` [m]) whose tets hold ``fill`` of the mesh's
    volume and span ``reach`` (3,) of its width along x, y, z, or ``None`` if it follows the
    mesh (:data:`MARCHING_FILL_WARNING`)."""
    reach = np.asarray(reach, dtype=np.float64)
    if fill >= MARCHING_FILL_WARNING and reach.min() >= 0.9:
        return None
    thin = (f" and spans {reach.min():.0%} of its width along {'xyz'[int(reach.argmin())]} "
            "(thin parts of its skin, ears or handles, have no tets: they follow the body and "
            "may cross the floor)") if reach.min() < 0.9 else ""
    return (f"{name}: the marching grid (h = {h:.3g} m) fills only {100 * fill:.0f} % of the "
            f"mesh's volume{thin}: parts thinner than about h are lost, and the physical path's "
            "mass (from the tets) is that much below density x volume; more points (a smaller "
            "h) or connect = 'delaunay' follow thin parts")
