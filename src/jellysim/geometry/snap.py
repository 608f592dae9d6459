"""Warp a marching grid onto the surface mesh it is cut from.

The report's marching grid keeps the tets whose four corners are inside the mesh, so its surface
is a staircase up to one cell inside the true surface (a coarse sphere's tets hold 72 % of its
volume).  :func:`warp_to_surface` is the *warping* step of isosurface stuffing (Labelle and
Shewchuk, "Isosurface stuffing: fast tetrahedral meshes with good dihedral angles", SIGGRAPH
2007), without its cut-point stencils:

1. every grid edge whose ends lie on both sides of the surface is cut where it crosses it
   (bisection with the inside test);
2. a node within ``alpha`` (inside nodes) or ``alpha_outside`` (outside nodes) of an edge's
   length of one of its cut points moves onto the nearest such point: the nodes now *on* the
   surface;
3. a tet is kept when each of its corners is inside or on the surface, its centroid is inside
   when all four are on it, and it keeps its orientation with a quality
   (:func:`~jellysim.geometry.tetra.tet_quality`) of at least ``min_quality``.

Because a node moves by less than half an edge, no kept tet is tiny (the worst tet sets the
explicit substep): a grid warped this way needs about as many substeps as the staircase while
holding 84-95 % of the mesh's volume instead of 72-89 % (BENCHMARKS.md "Building bodies",
session 7).  Where the surface crosses an edge near its middle no node moves and the staircase
stays there.
"""
from __future__ import annotations

import numpy as np

__all__ = ["warp_to_surface", "WARP_ALPHA", "WARP_ALPHA_OUTSIDE", "WARP_MIN_QUALITY"]

WARP_ALPHA = 0.45
"""An inside node moves out onto a cut point closer than this fraction of the cut edge's
length."""

WARP_ALPHA_OUTSIDE = 0.3
"""An outside node moves in onto a cut point closer than this fraction of the edge.  Moving in
shrinks its tets (moving out grows them), and small tets shorten the explicit substep: with
0.45 for both, a 3,000-point sphere filled 97 % of its volume but needed 99 substeps per frame
(the staircase 67); with 0.3 it fills 95 % with 77, and Spot (3,000 points) 91 % with 140
(the staircase snapped the old way: 84 % with 195)."""

WARP_MIN_QUALITY = 0.35
"""Warped tets below this quality are dropped (a Kuhn tet of the grid has 0.59)."""

BISECTIONS = 14
"""Bisection steps locating each cut point: within ``edge / 2^15`` of the surface."""


def warp_to_surface(nodes, inside, tets, inside_fn, *, alpha: float = WARP_ALPHA,
                    alpha_outside: float = WARP_ALPHA_OUTSIDE,
                    min_quality: float = WARP_MIN_QUALITY,
                    bounds=None) -> tuple[np.ndarray, np.ndarray]:
    """Warped node positions [m], shape (n, 3), and the kept tets, shape (t, 4) int64 (rows of
    ``tets``).

    Parameters
    ----------
    nodes: grid node positions [m], shape (n, 3).
    inside: ``inside_fn(nodes)``, shape (n,) bool.
    tets: candidate tets (indices into ``nodes``), shape (t, 4): every tet with a corner inside.
    inside_fn: point-in-mesh test, ``(m, 3) float64 -> (m,) bool``.
    bounds: the mesh's bounding box ``(lower, upper)`` [m]: cut points are kept inside it (a
        bisection ends up to ``edge / 2^15`` outside the surface: a mesh standing on y = 0
        gave a body 1e-7 m below the ground, refused by the contact's start check).
    """
    from .tetra import tet_edges, tet_quality, tet_signed_volumes

    p0 = np.asarray(nodes, dtype=np.float64)
    inside = np.asarray(inside, dtype=bool)
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    edges = tet_edges(tets, len(p0))
    cut = edges[inside[edges[:, 0]] != inside[edges[:, 1]]]
    first_in = inside[cut[:, 0]]
    a = np.where(first_in, cut[:, 0], cut[:, 1])  # the inside end
    b = np.where(first_in, cut[:, 1], cut[:, 0])  # the outside end
    pa, pb = p0[a], p0[b]
    lo, hi = np.zeros(len(a)), np.ones(len(a))
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        ins = np.asarray(inside_fn(pa + mid[:, None] * (pb - pa)), dtype=bool)
        lo, hi = np.where(ins, mid, lo), np.where(ins, hi, mid)
    s = 0.5 * (lo + hi)  # the cut point as a fraction of the way from a to b
    point = pa + s[:, None] * (pb - pa)
    if bounds is not None:
        point = np.clip(point, np.asarray(bounds[0], dtype=np.float64),
                        np.asarray(bounds[1], dtype=np.float64))
    length = np.linalg.norm(pb - pa, axis=1)
    # candidate moves: (node, distance, cut point), each node to its nearest cut point
    node = np.concatenate([a, b])
    frac = np.concatenate([s, 1.0 - s])
    dist = frac * np.concatenate([length, length])
    target = np.concatenate([point, point])
    near = frac < np.concatenate([np.full(len(a), alpha), np.full(len(b), alpha_outside)])
    node, dist, target = node[near], dist[near], target[near]
    order = np.lexsort((dist, node))
    node, target = node[order], target[order]
    first = np.unique(node, return_index=True)[1]
    p = p0.copy()
    p[node[first]] = target[first]
    on = np.zeros(len(p0), dtype=bool)
    on[node[first]] = True

    kept = tets[(inside | on)[tets].all(axis=1)]
    all_on = on[kept].all(axis=1)
    if all_on.any():
        centre_in = np.ones(len(kept), dtype=bool)
        centre_in[all_on] = np.asarray(inside_fn(p[kept[all_on]].mean(axis=1)), dtype=bool)
        kept = kept[centre_in]
    vol = tet_signed_volumes(p, kept)
    good = (np.sign(vol) == np.sign(tet_signed_volumes(p0, kept))) & (
        tet_quality(p, kept, vol) >= min_quality)
    return p, kept[good]
