"""Volumetric bodies from a closed surface: tetrahedral builders (report section 4.3).

Three builders turn a surface mesh into a :class:`~jellysim.body.Body` whose springs are the
edges of tetrahedra:

:func:`marching_grid`
    The report's "marching tetrahedron" connection: a grid of cubes of edge ``h`` over the mesh's
    bounding box, every cube split into the same six Kuhn (Freudenthal) tetrahedra along its main
    diagonal, which makes neighbouring cubes' tetrahedra share whole faces.
:func:`delaunay_body`
    The report's Delaunay connection of a given point cloud (Qhull through
    :class:`scipy.spatial.Delaunay`), after removing near-duplicate points and breaking the
    co-sphericity of grid inputs, then carved to the mesh and cleaned of slivers.
:func:`tetgen_body`
    A constrained (boundary-conforming) tetrahedralization of the surface itself with TetGen
    (optional dependency ``tetgen``, extra ``jellysim[mesh]``).  Exact volume, closed meshes only.

The inside test is a parameter everywhere (``inside_fn(points (n, 3) float64) -> (n,) bool``)
so any point-in-mesh implementation can be plugged in.

Conventions shared by all builders (SI units):

* ``Body.tets`` is positively oriented: every tet ``(a, b, c, d)`` has
  ``det(b - a, c - a, d - a) > 0``.
* ``Body.points`` holds only points that are a corner of at least one kept tet, renumbered in
  their original order.  A point that belongs to no kept tet would get no mass, so it is dropped
  together with its springs (the count is recorded in ``meta["dropped_points"]``).
* ``Body.springs`` (k, 2) int64, rows ``i < j``, unique, sorted lexicographically;
  ``Body.rest_length`` is ``None`` (the rest distance) and ``Body.stiffness`` ``None``.
* ``Body.masses`` = :func:`lump_tet_masses` (density x tet volume, a quarter to each corner);
  ``Body.volume`` = sum of kept tet volumes [m^3].
* ``Body.triangles`` = the boundary faces of the kept tets (faces used by exactly one kept
  tet), oriented outward: a skin for rendering and collisions.
* ``Body.meta`` records the builder name and its parameters.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from jellysim.body import Body
from jellysim.errors import BuildError
from jellysim.params import REPORT_DENSITY

__all__ = [
    "marching_grid",
    "delaunay_body",
    "cloud_tets",
    "tetgen_body",
    "lump_tet_masses",
    "tet_signed_volumes",
    "tet_quality",
    "orient_tets",
    "tet_edges",
    "boundary_faces",
    "surface_defects",
    "DEFAULT_DENSITY",
    "DEFAULT_MIN_QUALITY",
]

InsideFn = Callable[[np.ndarray], np.ndarray]

#: Default mass density [kg/m^3]: the report's figure for jello (section 6.4).
DEFAULT_DENSITY = REPORT_DENSITY

#: Default sliver threshold of :func:`delaunay_body` on :func:`tet_quality` (1 = regular tet).
DEFAULT_MIN_QUALITY = 0.05

SLIVER_VOLUME_BUDGET = 0.002
""":func:`delaunay_body` step 6: the thin tets dropped hold at most this fraction of the tet
volume."""

#: Default near-duplicate distance of :func:`delaunay_body`, as a fraction of the median
#: nearest-neighbour distance of the input points.
DEFAULT_EPSILON_FRACTION = 1e-2

#: Jitter amplitude of :func:`delaunay_body`, as a fraction of epsilon.
JITTER_FRACTION = 1e-3

# Outward faces of a positively oriented tet (a, b, c, d) = (0, 1, 2, 3).
_TET_FACES = np.array([[1, 2, 3], [0, 2, 1], [0, 1, 3], [0, 3, 2]], dtype=np.int64)
_TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)


# ----------------------------------------------------------------------------------------------
# Tet-mesh utilities
# ----------------------------------------------------------------------------------------------
def tet_signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed tet volumes [m^3], shape (t,): ``det(b - a, c - a, d - a) / 6``."""
    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(tets, dtype=np.int64)
    a = p[t[:, 0]]
    u = p[t[:, 1]] - a
    v = p[t[:, 2]] - a
    w = p[t[:, 3]] - a
    return np.einsum("ij,ij->i", u, np.cross(v, w)) / 6.0


def tet_quality(points: np.ndarray, tets: np.ndarray,
                volumes: np.ndarray | None = None) -> np.ndarray:
    """Normalized volume quality, shape (t,): ``6 sqrt(2) |V| / l_rms^3``.

    ``l_rms`` is the root mean square of the six edge lengths.  The measure is 1 for a regular
    tetrahedron, tends to 0 for every kind of degenerate tet (needles, caps, slivers), and is
    scale invariant.  ``volumes`` (signed or not) may be passed when already known.
    """
    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(tets, dtype=np.int64)
    a = p[t[:, 0]]
    u = p[t[:, 1]] - a
    v = p[t[:, 2]] - a
    w = p[t[:, 3]] - a
    if volumes is None:
        volumes = np.einsum("ij,ij->i", u, np.cross(v, w)) / 6.0
    vol = np.abs(volumes)
    l2 = np.zeros(t.shape[0])
    for e in (u, v, w, v - u, w - u, w - v):
        l2 += np.einsum("ij,ij->i", e, e)
    l2 /= 6.0
    with np.errstate(divide="ignore", invalid="ignore"):
        q = 6.0 * math.sqrt(2.0) * vol / (l2 * np.sqrt(l2))
    return np.where(l2 > 0, q, 0.0)


def orient_tets(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Copy of ``tets`` with the last two corners swapped wherever the signed volume is negative."""
    t = np.array(tets, dtype=np.int64, copy=True).reshape(-1, 4)
    neg = tet_signed_volumes(points, t) < 0
    t[neg, 2], t[neg, 3] = t[neg, 3], t[neg, 2].copy()
    return t


def _unique_rows_sorted(rows: np.ndarray, n: int, return_counts: bool = False):
    """Unique rows (each row already sorted ascending) of small non-negative ints < n.

    Rows are packed into one int64 key when that fits, else ``np.unique(axis=0)`` is used.
    Returns (unique rows sorted lexicographically, index of first occurrence[, counts]).
    """
    m = rows.shape[1]
    if rows.shape[0] == 0:
        empty = np.empty((0, m), dtype=np.int64)
        out = (empty, np.empty(0, dtype=np.int64))
        return out + (np.empty(0, dtype=np.int64),) if return_counts else out
    if n > 0 and float(n) ** m < 2.0**62:
        key = rows[:, 0].astype(np.int64)
        for c in range(1, m):
            key = key * n + rows[:, c]
        res = np.unique(key, return_index=True, return_counts=return_counts)
        uniq = rows[res[1]]
    else:
        res = np.unique(rows, axis=0, return_index=True, return_counts=return_counts)
        uniq = res[0]
    return (uniq.astype(np.int64), res[1]) + ((res[2],) if return_counts else ())


def tet_edges(tets: np.ndarray, n_points: int | None = None) -> np.ndarray:
    """Unique edges of ``tets``: shape (k, 2) int64, rows ``i < j``, sorted lexicographically."""
    t = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    n = int(t.max()) + 1 if n_points is None and t.size else int(n_points or 0)
    a, b = t[:, _TET_EDGES[:, 0]].ravel(), t[:, _TET_EDGES[:, 1]].ravel()
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    if n > 0 and float(n) ** 2 < 2.0**62:
        key = np.sort(lo * n + hi)  # plain sort: faster than np.unique's argsort
        key = key[np.concatenate(([True], key[1:] != key[:-1]))[:len(key)]]  # (none: none)
        return np.stack([key // n, key % n], axis=1)
    return _unique_rows_sorted(np.stack([lo, hi], axis=1), n)[0]


def boundary_faces(tets: np.ndarray, n_points: int | None = None) -> np.ndarray:
    """Faces used by exactly one tet, shape (f, 3) int64.

    For positively oriented tets (see :func:`orient_tets`) the faces are oriented outward
    (right-hand rule normal points away from the tet they bound).
    """
    t = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    n = int(t.max()) + 1 if n_points is None and t.size else int(n_points or 0)
    faces = t[:, _TET_FACES].reshape(-1, 3)
    sf = np.sort(faces, axis=1)
    if n > 0 and float(n) ** 3 < 2.0**62:
        key = (sf[:, 0] * n + sf[:, 1]) * n + sf[:, 2]
        sk = np.sort(key)
        differs = sk[1:] != sk[:-1]
        once = np.concatenate(([True], differs)) & np.concatenate((differs, [True]))
        single = sk[once]
        if single.size == 0:
            return np.empty((0, 3), dtype=np.int64)
        pos = np.minimum(np.searchsorted(single, key), single.size - 1)
        return faces[single[pos] == key]
    _, first, counts = _unique_rows_sorted(sf, n, return_counts=True)
    return faces[np.sort(first[counts == 1])]


def _density(density) -> float:
    d = float(density)
    if not (math.isfinite(d) and d > 0):
        raise BuildError(f"density must be a positive finite number [kg/m^3], got {density!r}")
    return d


def lump_tet_masses(points: np.ndarray, tets: np.ndarray, density: float) -> np.ndarray:
    """Lumped point masses [kg], shape (n,), float64.

    Each tet's mass ``density * |volume|`` is split equally among its four corners, so the
    total is ``density * sum(|tet volumes|)``; points in no tet get 0.

    Parameters
    ----------
    points: rest positions [m], shape (n, 3).
    tets: tetrahedra, shape (t, 4), indices into ``points``.
    density: mass density [kg/m^3], > 0.
    """
    density = _density(density)
    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    vol = np.abs(tet_signed_volumes(p, t))
    w = np.repeat(density * vol / 4.0, 4)
    return np.bincount(t.ravel(), weights=w, minlength=p.shape[0]).astype(np.float64)


def _compact(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keep only points used by ``tets`` (order preserved); return (points, tets, old ids)."""
    used = np.zeros(points.shape[0], dtype=bool)
    used[tets.ravel()] = True
    old = np.flatnonzero(used)
    new_id = np.full(points.shape[0], -1, dtype=np.int64)
    new_id[old] = np.arange(old.size, dtype=np.int64)
    return points[old], new_id[tets], old


def _finish(points: np.ndarray, tets: np.ndarray, density: float, meta: dict,
            springs: np.ndarray | None = None, signed_volumes: np.ndarray | None = None) -> Body:
    """Assemble the Body of a tet mesh: orient, drop unused points, masses, skin, springs.

    ``springs`` (indices into ``points``) overrides the default "edges of the tets"; springs
    touching a dropped point are discarded.
    """
    density = _density(density)
    points = np.ascontiguousarray(points, dtype=np.float64)
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    if tets.shape[0] == 0:
        raise BuildError(
            f"{meta.get('builder', 'builder')}: no tetrahedron was kept - the resolution is too "
            "coarse for the shape (more points; for connect = 'marching' a smaller cube edge "
            "h / --h than the shape's thickness), or the inside test rejects everything"
        )
    n_in = points.shape[0]
    sv = tet_signed_volumes(points, tets) if signed_volumes is None else signed_volumes
    neg = sv < 0
    if neg.any():
        tets = tets.copy()
        tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    vol = np.abs(sv)
    pts, tets, old = _compact(points, tets)
    n = pts.shape[0]
    if springs is None:
        springs = tet_edges(tets, n)
    else:
        new_id = np.full(n_in, -1, dtype=np.int64)
        new_id[old] = np.arange(n, dtype=np.int64)
        s = new_id[np.asarray(springs, dtype=np.int64).reshape(-1, 2)]
        s = np.sort(s[(s >= 0).all(axis=1)], axis=1)
        springs = _unique_rows_sorted(s, n)[0]
    meta = dict(meta)
    meta.update(density=float(density), dropped_points=int(n_in - n))
    return Body(
        points=pts,
        springs=np.ascontiguousarray(springs, dtype=np.int64).reshape(-1, 2),
        rest_length=None,
        stiffness=None,
        masses=np.bincount(tets.ravel(), weights=np.repeat(float(density) * vol / 4.0, 4),
                           minlength=n).astype(np.float64),
        tets=tets,
        triangles=boundary_faces(tets, n),
        volume=float(vol.sum()),
        meta=meta,
    )


def _check_inside(inside_fn: InsideFn, pts: np.ndarray, what: str) -> np.ndarray:
    res = np.asarray(inside_fn(pts))
    if res.shape != (pts.shape[0],):
        raise BuildError(
            f"inside_fn must return a boolean array of shape ({pts.shape[0]},) for the {what}, "
            f"got shape {res.shape}"
        )
    return res.astype(bool)


def _as_vertices(vertices) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise BuildError(f"vertices must have shape (n, 3) with n > 0, got {v.shape}")
    if not np.isfinite(v).all():
        raise BuildError("vertices contain NaN or infinite coordinates")
    return v


def _as_faces(faces, n_vertices: int) -> np.ndarray:
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
        raise BuildError(f"faces must have shape (f, 3) with f > 0, got {f.shape}")
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= n_vertices:
        raise BuildError(f"faces reference vertices outside 0..{n_vertices - 1}")
    return f


# ----------------------------------------------------------------------------------------------
# Delaunay
# ----------------------------------------------------------------------------------------------
def _default_epsilon(tree, pts: np.ndarray) -> float:
    d, _ = tree.query(pts, k=2)
    nn = d[:, 1]
    nn = nn[np.isfinite(nn) & (nn > 0)]
    if nn.size:
        return DEFAULT_EPSILON_FRACTION * float(np.median(nn))
    return 0.0


def _carve(p: np.ndarray, tets: np.ndarray, inside_fn: InsideFn, vertices, faces) -> np.ndarray:
    """Mask of tets whose centroid ``inside_fn`` accepts, with fewer calls of ``inside_fn``.

    A tet lies in the ball around its centroid through its farthest corner (radius ``rad``).
    Each point ``k`` has a lower bound ``L_k`` on its distance to the surface (distance to the
    nearest triangle centre minus the largest triangle radius); the centroid is then at least
    ``L_k - rad`` from the surface.  When ``max_k L_k > 2 rad`` the ball cannot reach the
    surface, every point of the tet is on the same side of it, and the tet's status is its
    first corner's.  Only the corners of such tets and the centroids of the others are tested.
    This equals testing every centroid for any inside test that is constant away from the
    surface (winding number, parity); without a usable surface every centroid is tested.
    """
    from scipy.spatial import cKDTree

    cent = p[tets].mean(axis=1)
    try:
        v = _as_vertices(vertices)
        f = _as_faces(faces, v.shape[0])
    except BuildError:
        return _check_inside(inside_fn, cent, "tet centroids")
    tri = v[f]
    tc = tri.mean(axis=1)
    tr = float(np.sqrt(((tri - tc[:, None]) ** 2).sum(axis=2)).max())
    rad = np.sqrt(((p[tets] - cent[:, None]) ** 2).sum(axis=2)).max(axis=1)
    used = np.unique(tets)
    lower = np.full(p.shape[0], -np.inf)
    lower[used] = cKDTree(tc).query(p[used])[0] - tr
    far = lower[tets].max(axis=1) > 2.0 * rad * (1 + 1e-9) + 1e-12 * (1 + np.abs(cent).max())
    out = np.empty(tets.shape[0], dtype=bool)
    near = ~far
    out[near] = _check_inside(inside_fn, cent[near], "tet centroids")
    if far.any():
        corner = tets[far, 0]
        ids, inv = np.unique(corner, return_inverse=True)
        out[far] = _check_inside(inside_fn, p[ids], "tet corners")[inv]
    return out


def delaunay_body(points, vertices, faces, inside_fn: InsideFn, *, epsilon: float | None = None,
                  min_quality: float = DEFAULT_MIN_QUALITY, seed: int = 0,
                  density: float = DEFAULT_DENSITY, target_quality: float | None = None,
                  target_volume: float = SLIVER_VOLUME_BUDGET) -> Body:
    """Delaunay body of a point cloud inside a surface (report section 4.3).

    Steps, in order:

    1. **Near duplicates.**  Two points closer than ``epsilon`` would make needle and sliver
       tets.  For every pair at distance ``<= epsilon`` (``cKDTree.query_pairs``) the point
       with the higher index is removed, so no two surviving points are within ``epsilon``.
       Default ``epsilon`` = ``1e-2`` x the median nearest-neighbour distance of the (distinct)
       input points; exact duplicates are always removed.
    2. **Co-sphericity.**  Grid-like inputs put many points on one circumsphere (the report's
       second degenerate case).  Qhull is run on a copy jittered by a seeded uniform offset of
       amplitude ``1e-3 * epsilon`` per coordinate (``seed``), which makes the Delaunay choice
       unique; the body keeps the original, un-jittered positions.
    3. ``scipy.spatial.Delaunay`` (Qhull).
    4. **Slivers.**  Tets with :func:`tet_quality` ``< min_quality`` (default 0.05; 1 is a
       regular tet, 0 a flat one) are dropped; flat tets (quality 0) always are.
    5. **Carving.**  Tets whose centroid is outside (``inside_fn``) are dropped.  (A tet with
       its centroid inside may still poke out of a concave surface; use a finer point set near
       the surface or :func:`tetgen_body` for a boundary-conforming mesh.)
    6. **More slivers** (with ``target_quality``): the carved tets below ``target_quality``
       are dropped, worst first, as long as together they hold at most ``target_volume`` of
       the body's tet volume (a relaxed point set has a handful of thin interior tets, which
       go; a mesh whose dense surface makes many flat tets keeps them: dropping them would
       hollow the body).
    7. Points in no kept tet are dropped and the rest renumbered; springs = unique edges of the
       kept tets.  ``meta["dropped_points"]`` counts every input point not in the body
       (near duplicates included).

    Parameters
    ----------
    points: candidate points [m], shape (n, 3) (e.g. sampled inside the mesh, plus its vertices).
    vertices, faces: the surface the inside test describes; used to skip the inside test for
        tets far from it (see :func:`_carve`), or ``None``.
    inside_fn: point-in-mesh test, ``(n, 3) float64 -> (n,) bool``.
    epsilon: near-duplicate distance [m], >= 0; ``None`` for the default above.
    min_quality: sliver threshold on :func:`tet_quality`, in [0, 1).
    seed: seed of the co-sphericity jitter.
    density: mass density [kg/m^3].
    target_quality, target_volume: step 6 (``None``: no step 6); ``target_volume`` is a
        fraction of the tet volume.
    """
    from scipy.spatial import Delaunay, QhullError, cKDTree

    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise BuildError(f"points must have shape (n, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise BuildError("points contain NaN or infinite coordinates")
    if not (0.0 <= float(min_quality) < 1.0):
        raise BuildError(f"min_quality must be in [0, 1), got {min_quality!r}")
    n_in = p.shape[0]
    if n_in < 4:
        raise BuildError(f"delaunay_body needs at least 4 points, got {n_in}")

    tree = cKDTree(p)
    if epsilon is None:
        eps = _default_epsilon(tree, p)
    else:
        eps = float(epsilon)
        if not (math.isfinite(eps) and eps >= 0):
            raise BuildError(f"epsilon must be a finite length >= 0 [m], got {epsilon!r}")
    pairs = tree.query_pairs(eps, output_type="ndarray")
    keep = np.ones(n_in, dtype=bool)
    if pairs.size:
        keep[pairs.max(axis=1)] = False
    p = p[keep]
    if p.shape[0] < 4:
        raise BuildError(f"only {p.shape[0]} points remain after removing near duplicates")

    diag = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    amp = JITTER_FRACTION * eps if eps > 0 else 1e-9 * diag
    rng = np.random.default_rng(seed)
    jittered = p + rng.uniform(-amp, amp, size=p.shape)
    try:
        simplices = Delaunay(jittered).simplices.astype(np.int64)
    except QhullError as exc:  # all points coplanar etc.
        raise BuildError(f"Qhull could not tetrahedralize the points: {exc}") from exc
    n_delaunay = simplices.shape[0]

    sv = tet_signed_volumes(p, simplices)
    q = tet_quality(p, simplices, sv)
    good = (q >= float(min_quality)) & (q > 0)
    simplices, sv = simplices[good], sv[good]
    n_slivers = n_delaunay - simplices.shape[0]
    carve = _carve(p, simplices, inside_fn, vertices, faces)
    simplices, sv = simplices[carve], sv[carve]
    n_thin = 0
    if target_quality is not None:
        q = q[good][carve]
        order = np.argsort(q, kind="stable")
        order = order[q[order] < float(target_quality)]
        within = np.cumsum(np.abs(sv[order])) <= float(target_volume) * np.abs(sv).sum()
        thin = order[:int(np.argmin(within)) if not within.all() else len(order)]
        n_thin = int(thin.size)
        kept = np.ones(len(simplices), dtype=bool)
        kept[thin] = False
        simplices, sv = simplices[kept], sv[kept]

    f = np.asarray(faces) if faces is not None else np.empty((0, 3))
    meta = {
        "builder": "delaunay",
        "epsilon": float(eps),
        "epsilon_default": epsilon is None,
        "min_quality": float(min_quality),
        "seed": int(seed),
        "jitter_amplitude": float(amp),
        "input_points": int(n_in),
        "near_duplicates_removed": int(n_in - p.shape[0]),
        "delaunay_tets": int(n_delaunay),
        "slivers_removed": int(n_slivers),
        "target_quality": None if target_quality is None else float(target_quality),
        "thin_removed": n_thin,
        "outside_removed": int(n_delaunay - n_slivers - simplices.shape[0]),
        "surface_vertices": int(np.asarray(vertices).shape[0]) if vertices is not None else 0,
        "surface_faces": int(f.shape[0]),
    }
    body = _finish(p, simplices, density, meta, signed_volumes=sv)
    body.meta["dropped_points"] = int(n_in - body.points.shape[0])
    return body


# ----------------------------------------------------------------------------------------------
# Tets over a given point cloud (radius bodies)
# ----------------------------------------------------------------------------------------------
#: :func:`cloud_tets`: a point left in no tet gets back its best Delaunay tet (centroid inside)
#: if that tet's :func:`tet_quality` is at least this; else the point is an orphan.
ORPHAN_MIN_QUALITY = 0.01


def cloud_tets(points, inside_fn: InsideFn | None = None, vertices=None, faces=None, *,
               min_quality: float = DEFAULT_MIN_QUALITY,
               orphan_min_quality: float = ORPHAN_MIN_QUALITY,
               seed: int = 0) -> tuple[np.ndarray, np.ndarray, dict]:
    """Tetrahedra over a point cloud whose points must all stay (a radius body's).

    The same steps as :func:`delaunay_body` without removing points: Qhull Delaunay of a copy
    jittered by ``1e-3`` x (``1e-2`` x the median nearest-neighbour distance) (co-sphericity
    of grid inputs), tets with :func:`tet_quality` ``< min_quality`` dropped as slivers, tets
    whose centroid ``inside_fn`` rejects dropped (carving; ``inside_fn=None``: no carving, for
    convex regions such as a box, where no Delaunay tet of inside points pokes out).

    Dropping slivers can leave a point (mostly on the cloud's convex hull) in no tet: it would
    get no elastic force from the tets.  Each such point gets back the best-quality tet among
    its own Delaunay tets that passed the carving, when that quality is at least
    ``orphan_min_quality`` (a few such tets are flatter than ``min_quality`` but still shaped
    well enough).  Points still in no tet are the *orphans*, returned as a mask so the caller
    can drop them (:func:`jellysim.build.build_body` does, before it builds the springs).

    Parameters
    ----------
    points: the cloud [m], shape (n, 3), n >= 4, not all in a plane.
    inside_fn: inside test ``(m, 3) float64 -> (m,) bool``, or ``None``.
    vertices, faces: the surface ``inside_fn`` describes (speeds up carving), or ``None``.
    min_quality, orphan_min_quality: thresholds on :func:`tet_quality`, in [0, 1).
    seed: seed of the jitter.

    Returns
    -------
    tets: (t, 4) int64 indices into ``points``, positively oriented.
    orphans: (n,) bool, the points in no tet.
    info: counts (``delaunay_tets``, ``slivers_removed``, ``outside_removed``,
        ``orphans_readmitted``, ``orphans``) and the tets' total volume ``tet_volume`` [m^3].
    """
    from scipy.spatial import Delaunay, QhullError, cKDTree

    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 4:
        raise BuildError(f"cloud_tets needs points of shape (n >= 4, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise BuildError("points contain NaN or infinite coordinates")
    for name, q in (("min_quality", min_quality), ("orphan_min_quality", orphan_min_quality)):
        if not (0.0 <= float(q) < 1.0):
            raise BuildError(f"{name} must be in [0, 1), got {q!r}")
    n = p.shape[0]
    eps = _default_epsilon(cKDTree(p), p)
    diag = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    amp = JITTER_FRACTION * eps if eps > 0 else 1e-9 * diag
    jittered = p + np.random.default_rng(seed).uniform(-amp, amp, size=p.shape)
    try:
        simplices = Delaunay(jittered).simplices.astype(np.int64)
    except QhullError as exc:  # all points coplanar etc.
        raise BuildError(f"Qhull could not tetrahedralize the points: {exc}") from exc
    sv = tet_signed_volumes(p, simplices)
    q = tet_quality(p, simplices, sv)
    inside = (np.ones(len(simplices), dtype=bool) if inside_fn is None
              else _carve(p, simplices, inside_fn, vertices, faces))
    good = (q >= float(min_quality)) & (q > 0)
    keep = good & inside
    covered = np.zeros(n, dtype=bool)
    covered[simplices[keep].ravel()] = True
    readmitted = 0
    spare = np.flatnonzero(inside & ~good & (q >= float(orphan_min_quality)) & (q > 0))
    if not covered.all() and spare.size:
        # best spare tet of each uncovered point: sort the spare tets by quality (best last,
        # ties by index) so the last write per point wins
        order = spare[np.lexsort((-spare, q[spare]))]
        best = np.full(n, -1, dtype=np.int64)
        for c in range(4):
            best[simplices[order, c]] = order
        pick = np.unique(best[~covered & (best >= 0)])
        keep[pick] = True
        readmitted = int(pick.size)
        covered[simplices[pick].ravel()] = True
    if not keep.any():
        raise BuildError("no well-shaped tet over the points (are they all in a plane or on a "
                         "line?), or the inside test rejects every tet")
    tets = simplices[keep]
    neg = sv[keep] < 0
    tets[neg, 2], tets[neg, 3] = tets[neg, 3], tets[neg, 2].copy()
    info = {
        "delaunay_tets": int(len(simplices)),
        "slivers_removed": int(np.sum(~good)),
        "outside_removed": int(np.sum(good & ~inside)),
        "orphans_readmitted": readmitted,
        "orphans": int(np.sum(~covered)),
        "min_quality": float(min_quality),
        "orphan_min_quality": float(orphan_min_quality),
        "tet_volume": float(np.abs(sv[keep]).sum()),
    }
    return tets, ~covered, info


_MOVED = {"marching_grid": "tet_marching", "tetgen_body": "tet_tetgen",
          "surface_defects": "tet_tetgen"}


def __getattr__(name: str):
    """The marching-grid and TetGen builders live in their own modules (imported on first use,
    so that they can import this module's helpers without a cycle)."""
    if name in _MOVED:
        import importlib

        value = getattr(importlib.import_module(f"jellysim.geometry.{_MOVED[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
