"""Skins: a surface mesh carried by the simulated points (report section 6.2, future work).

A skin is a triangle mesh whose vertices are *bound once*, at build time, to the body and then
*deformed every frame* from the point positions:

    skin_vertex[j] = sum_c weights[j, c] * x[point_index[j, c]]      (c = 0..3)

Binding (:func:`bind_skin`):

* **Tet bodies** (``body.tets`` given): each skin vertex gets the barycentric coordinates of
  the tetrahedron that contains it.
* **Radius bodies** (no tets): the sample points are tetrahedralised (scipy's Delaunay), and
  only tetrahedra whose six edges are all springs of the body are kept (the cells that the
  springs actually hold together; a Delaunay cell spanning a gap between, say, two legs of a
  cow has an edge longer than the spring radius and is dropped).  If that leaves no cell, every
  non-degenerate Delaunay cell is used.  Then as for tet bodies.
* **Vertices outside every tet** (e.g. just outside the sampled cloud) are never dropped: they
  are bound to a nearby tet by *extrapolation* (barycentric coordinates outside [0, 1], still
  summing to 1).  Among the tets nearest to the vertex, the one with the smallest largest
  |weight| is chosen: that is a tet close to the vertex and not a sliver (a sliver would
  amplify the points' motion onto the vertex).

Because the four weights of every vertex sum to one, the deformed skin follows any affine
motion of the points exactly (to rounding): rigid translations and rotations in particular.

Box scenes get the box's surface as their skin (:func:`box_skin`); a body file built from a
mesh carries that mesh (``Body.skin_vertices`` / ``skin_faces``) and gets it; a body given as
points with surface ``triangles`` gets those triangles (each vertex bound to its own point,
weight 1).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .errors import BuildError
from .params import _user_stacklevel

__all__ = ["Skin", "bind_body_skin", "bind_skin", "body_tets", "box_skin", "box_surface", "default_skin",
           "identity_skin", "outer_skin"]

CANDIDATES = 16
"""How many tets (nearest by centroid) are examined per skin vertex."""
INSIDE_TOL = 1e-10
"""A vertex whose smallest barycentric coordinate is >= -INSIDE_TOL counts as inside a tet."""


@dataclass(frozen=True, eq=False)
class Skin:
    """A triangle mesh bound to the points of a body.

    Attributes
    ----------
    rest_vertices:
        Skin vertex positions at rest [m], shape (m, 3), float64.
    faces:
        Triangles (indices into the skin vertices), shape (f, 3), int64.
    point_index:
        The four body points each skin vertex follows, shape (m, 4), int64.
    weights:
        Their weights [-], shape (m, 4), float64; each row sums to 1.  Barycentric coordinates
        of the vertex in the tet ``point_index[j]`` (negative entries: extrapolated vertex).
    uv:
        Texture coordinates [-] of each face corner, shape (f, 3, 2), float64, or ``None``
        (the mesh file's, :mod:`jellysim.geometry.texcoords`).
    materials:
        Which of the mesh file's materials each face uses
        (:class:`~jellysim.geometry.texcoords.Materials`), or ``None``.
    """

    rest_vertices: np.ndarray
    faces: np.ndarray
    point_index: np.ndarray
    weights: np.ndarray
    uv: np.ndarray | None = None
    materials: object = None

    @property
    def vertex_count(self) -> int:
        return int(self.rest_vertices.shape[0])

    def deform(self, positions: np.ndarray, *, floor: float | None = None,
               obstacles=None) -> np.ndarray:
        """Skin vertex positions [m] from point positions [m].

        ``positions`` of shape (n, 3) gives (m, 3); shape (F, n, 3) gives (F, m, 3).
        ``floor``: the ground's height [m]: vertices below it are lifted onto it;
        ``obstacles``: ``(kind, data)`` of :func:`jellysim.physics.contact.pack_obstacles`:
        vertices inside one are moved out along its normal.  A vertex bound by extrapolation
        (outside every tet) follows its tet's motion beyond the points, so it can dip below a
        ground or into an obstacle the points touch (measured: 0.05-0.5 mm at rest, 1.5 mm on
        a landing, a spring body's flattened box skin 30 cm; 7 % of a sphere's radius); the
        points themselves never do.  Runs, renders and exports pass their ground and
        obstacles.
        """
        positions = np.asarray(positions, dtype=np.float64)
        gathered = positions[..., self.point_index, :]          # (..., m, 4, 3)
        out = np.einsum("...mcd,mc->...md", gathered, self.weights)
        if floor is not None:
            out[..., 1] = np.maximum(out[..., 1], floor)
        if obstacles is not None and len(obstacles[0]):
            from .kernels.contact_numpy import _contact_geometry

            flat = np.ascontiguousarray(out).reshape(-1, 3)
            for kind, geom in zip(*obstacles):
                phi, nrm = _contact_geometry(int(kind), geom, flat)
                inside = phi < 0.0
                flat[inside] -= phi[inside, None] * nrm[inside]
            out = flat.reshape(out.shape)
        return out

    def arrays(self) -> dict[str, np.ndarray]:
        """The skin as named arrays (as stored in a trajectory ``.npz``)."""
        out = {"skin_rest_vertices": self.rest_vertices, "skin_faces": self.faces,
               "skin_point_index": self.point_index, "skin_weights": self.weights}
        if self.uv is not None:
            out["skin_uv"] = self.uv
        if self.materials is not None:
            import json

            out["skin_material"] = np.asarray(self.materials.index, dtype=np.int64)
            out["skin_material_names"] = np.str_(json.dumps(list(self.materials.names)))
        return out

    @classmethod
    def from_arrays(cls, d) -> "Skin | None":
        """Inverse of :meth:`arrays`; ``None`` when the arrays are absent or empty."""
        if "skin_rest_vertices" not in d or len(d["skin_rest_vertices"]) == 0:
            return None
        return cls(rest_vertices=np.asarray(d["skin_rest_vertices"], dtype=np.float64),
                   faces=np.asarray(d["skin_faces"], dtype=np.int64).reshape(-1, 3),
                   point_index=np.asarray(d["skin_point_index"], dtype=np.int64),
                   weights=np.asarray(d["skin_weights"], dtype=np.float64),
                   uv=np.asarray(d["skin_uv"], dtype=np.float64).reshape(-1, 3, 2)
                   if "skin_uv" in d and len(d["skin_uv"]) else None,
                   materials=_materials(d))


def _materials(d):
    """The :class:`~jellysim.geometry.texcoords.Materials` stored by :meth:`Skin.arrays`."""
    if "skin_material" not in d:
        return None
    import json

    from .geometry.texcoords import Materials

    return Materials.of(d["skin_material"], json.loads(str(d["skin_material_names"])))


def _barycentric(points: np.ndarray, tets: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of ``query`` (q, 3) in tets ``tets`` (q, 4) -> (q, 4).

    Degenerate tets give NaN rows."""
    a = points[tets[:, 0]]
    m = np.stack([points[tets[:, 1]] - a, points[tets[:, 2]] - a, points[tets[:, 3]] - a],
                 axis=2)                                           # (q, 3, 3) columns = edges
    rhs = (query - a)[..., None]
    out = np.full((len(tets), 4), np.nan)
    det = np.linalg.det(m)
    scale = np.einsum("qij,qij->q", m, m) ** 1.5
    ok = np.abs(det) > 1e-12 * np.maximum(scale, np.finfo(float).tiny)
    if np.any(ok):
        lam = np.linalg.solve(m[ok], rhs[ok])[..., 0]
        out[ok, 1:] = lam
        out[ok, 0] = 1.0 - lam.sum(axis=1)
    return out


def body_tets(points: np.ndarray, springs: np.ndarray | None = None,
              tets: np.ndarray | None = None) -> np.ndarray:
    """The tetrahedra a skin is bound to, shape (t, 4), int64.

    ``tets`` when given and non-empty; otherwise the Delaunay cells of ``points`` whose six
    edges are all in ``springs`` (all non-degenerate cells if none qualifies or no springs).
    """
    if tets is not None and len(tets):
        return np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    from scipy.spatial import Delaunay, QhullError

    points = np.asarray(points, dtype=np.float64)
    if len(points) < 4:
        raise BuildError(f"a skin needs at least 4 body points to bind to, got {len(points)}")
    try:
        cells = Delaunay(points).simplices.astype(np.int64)
    except QhullError as exc:
        raise BuildError(f"cannot tetrahedralise the body's points for the skin "
                         f"(are they coplanar?): {str(exc).splitlines()[0]}") from None
    a = points[cells[:, 0]]
    vol = np.abs(np.einsum("ij,ij->i", points[cells[:, 1]] - a,
                           np.cross(points[cells[:, 2]] - a, points[cells[:, 3]] - a)))
    cells = cells[vol > 1e-14 * max(np.ptp(points, axis=0).max(), 1e-300) ** 3]
    if springs is None or len(springs) == 0 or len(cells) == 0:
        return cells
    keep = _held_by_springs(cells, springs, len(points))
    return cells[keep] if np.any(keep) else cells


def _held_by_springs(cells: np.ndarray, springs, n: int) -> np.ndarray:
    """Whether each tet of ``cells`` (t, 4) has all six edges among ``springs`` (k, 2), (t,)."""
    s = np.sort(np.asarray(springs, dtype=np.int64).reshape(-1, 2), axis=1)
    keys = np.sort(s[:, 0] * n + s[:, 1])
    keep = np.ones(len(cells), dtype=bool)
    for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        k = np.minimum(cells[:, i], cells[:, j]) * n + np.maximum(cells[:, i], cells[:, j])
        pos = np.clip(np.searchsorted(keys, k), 0, len(keys) - 1)
        keep &= keys[pos] == k
    return keep


def bind_skin(points: np.ndarray, tets: np.ndarray, vertices: np.ndarray,
              faces: np.ndarray) -> Skin:
    """Bind a surface mesh to a body's tetrahedra (see the module docstring).

    Parameters
    ----------
    points: body rest positions [m], shape (n, 3).
    tets: tetrahedra (indices into ``points``), shape (t, 4), t >= 1 (see :func:`body_tets`).
    vertices: skin vertices at rest [m], shape (m, 3).
    faces: skin triangles, shape (f, 3), indices into ``vertices``.

    Returns
    -------
    The :class:`Skin`; every vertex is bound.
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(tets) == 0:
        raise BuildError("cannot bind a skin: the body has no tetrahedra")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise BuildError("skin faces refer to vertices that do not exist")
    centroids = points[tets].mean(axis=1)
    k = min(CANDIDATES, len(tets))
    _, cand = cKDTree(centroids).query(vertices, k=k)
    cand = np.asarray(cand, dtype=np.int64).reshape(len(vertices), k)
    m = len(vertices)
    bary = _barycentric(points, tets[cand.ravel()], np.repeat(vertices, k, axis=0))
    bary = bary.reshape(m, k, 4)
    valid = ~np.isnan(bary[..., 0])
    min_w = np.where(valid, np.nan_to_num(bary).min(axis=2), -np.inf)
    max_abs = np.where(valid, np.abs(np.nan_to_num(bary)).max(axis=2), np.inf)
    inside = min_w >= -INSIDE_TOL
    # inside: the first (nearest-centroid) containing tet; outside: least amplification
    score = np.where(inside, -1.0 + np.arange(k)[None, :] * 1e-6, max_abs)
    best = np.argmin(score, axis=1)
    rows = np.arange(m)
    if np.any(~np.isfinite(score[rows, best])):
        # no usable tet among the nearest candidates: search every tet for those vertices
        for j in np.flatnonzero(~np.isfinite(score[rows, best])):
            all_b = _barycentric(points, tets, np.repeat(vertices[j:j + 1], len(tets), axis=0))
            ok = ~np.isnan(all_b[:, 0])
            if not np.any(ok):
                raise BuildError("cannot bind a skin: every tetrahedron is degenerate")
            amp = np.where(ok, np.abs(np.nan_to_num(all_b)).max(axis=1), np.inf)
            t = int(np.argmin(amp))
            cand[j, 0], bary[j, 0], best[j] = t, all_b[t], 0
    chosen = cand[rows, best]
    weights = bary[rows, best]
    _say_extrapolated(vertices, np.abs(weights).max(axis=1))
    return Skin(rest_vertices=vertices, faces=faces, point_index=tets[chosen],
                weights=np.ascontiguousarray(weights))


EXTRAPOLATED = 3.0
"""A skin vertex whose weights exceed this in size moves more than 3x its tet's corners: it lies
well outside the body (measured: up to 2.8 on the teapot's spout, 1.1-2.3 on Spot, the torus,
Suzanne and the bunny; 3.9 on a 2 mm crumb beside a ball, 23 on 1 mm fins)."""


def _say_extrapolated(vertices: np.ndarray, amplification: np.ndarray) -> None:
    far = amplification > EXTRAPOLATED
    if not np.any(far):
        return
    import warnings

    from scipy.spatial import cKDTree

    spacing = float(np.median(cKDTree(vertices).query(vertices, k=2)[0][:, 1]))
    where = _places(vertices[far], amplification[far], np.ptp(vertices, axis=0).max(), spacing)
    warnings.warn(f"skin: {int(far.sum())} of its {len(vertices)} vertices ({where}) lie well "
                  f"outside the body's tets and follow them by extrapolation, moving up to "
                  f"{float(amplification.max()):.3g}x the nearest corners: a part thinner than "
                  "the point spacing or a piece apart from the body has no points of its own; "
                  "more points, or a thicker part, carry it", UserWarning, stacklevel=3)


def _places(x: np.ndarray, amp: np.ndarray, extent: float, spacing: float = 0.0,
            most: int = 3) -> str:
    """Where the vertices ``x`` [m] lie, as up to ``most`` groups (vertices within 5 % of
    the skin's ``extent``, or four of its vertex ``spacing`` [m], of one another), largest
    amplification first: "12 around (x, y, z) m, up to 4.2x; ...".  (One mean of all of them
    pointed between a teapot's handle and its spout, at neither.)"""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    # one part is one place: linked within 5 % of the skin's size or 4 of its vertex spacings
    pairs = cKDTree(x).query_pairs(max(0.05 * extent, 4.0 * spacing, 1e-300),
                                   output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(x), len(x))) if len(pairs) else coo_matrix((len(x), len(x)))
    count, label = connected_components(graph, directed=False)
    groups = sorted(range(count), key=lambda g: -amp[label == g].max())
    parts = []
    for g in groups[:most]:
        c = x[label == g].mean(axis=0)
        parts.append(f"{int((label == g).sum())} around ({c[0]:.3g}, {c[1]:.3g}, {c[2]:.3g}) m, "
                     f"up to {float(amp[label == g].max()):.3g}x")
    return "; ".join(parts) + (f"; and {count - most} more places" if count > most else "")


def bind_body_skin(body, vertices: np.ndarray, faces: np.ndarray, uv=None,
                   materials=None) -> Skin:
    """Bind a surface (vertices [m] (m, 3), faces (f, 3), optional per-corner texture
    coordinates ``uv`` (f, 3, 2) and the faces' ``materials``) to a
    :class:`~jellysim.body.Body`: its tets when it has some, else the spring-spanned Delaunay
    cells of its points."""
    tets = body_tets(body.points, body.springs, body.tets)
    uv = None if uv is None else np.asarray(uv, dtype=np.float64).reshape(-1, 3, 2)
    vertices, faces, uv, parent = _fine_enough(
        np.asarray(vertices, dtype=np.float64).reshape(-1, 3),
        np.asarray(faces, dtype=np.int64).reshape(-1, 3), body.points, tets, uv)
    if len(vertices) > LARGE_SKIN_VERTICES:  # (a 500k-face torus: 9 MB a frame, unsaid)
        import warnings

        warnings.warn(f"the skin has {len(vertices):,} vertices: a run writes them whole into "
                      f"every frame's ParaView skin file (about {len(vertices) * 36 / 1e6:.0f} "
                      "MB a frame; --no-vtu, [output] vtu = false, skips those files); a "
                      "simplified mesh (Blender: Decimate) looks the same on a jello of "
                      f"{len(body.points):,} points", UserWarning, stacklevel=_user_stacklevel())
    skin = bind_skin(body.points, tets, vertices, faces)
    if materials is not None and parent is not None:  # (subdivided: each face its parent's)
        materials = materials.rows(parent)
    return replace(skin, uv=uv, materials=materials)


MAX_SKIN_FACES = 200_000
"""A coarse skin is subdivided to at most about this many triangles."""

LARGE_SKIN_VERTICES = 150_000
"""A skin of more vertices is said to be heavy (stored whole every frame)."""


def _fine_enough(vertices, faces, points, tets, uv=None):
    """A skin whose edges are longer than twice the body's point spacing (a low-poly mesh: a
    cube of 12 triangles; the demo mould's flat base, a fan of 4 cm triangles) cannot bend
    with the body: it is subdivided to edges of one spacing (trimesh; the same surface, its
    original vertices first, in their order, so a point cache of the file still lines up).
    The spacing is the median edge of the body's tets.  Per-corner texture coordinates ``uv``
    are interpolated onto the fine faces (:func:`~jellysim.geometry.texcoords.subdivided`).
    Returns ``(vertices, faces, uv, parent)``: ``parent`` (f',) the face each fine face came
    from, ``None`` when the skin is kept as it is."""
    if len(faces) == 0 or len(tets) == 0:
        return vertices, faces, uv, None
    edges = points[tets[:, [0, 0, 0, 1, 1, 2]]] - points[tets[:, [1, 2, 3, 2, 3, 3]]]
    spacing = float(np.median(np.linalg.norm(edges, axis=2)))
    longest = float(np.linalg.norm(vertices[faces[:, [1, 2, 0]]] - vertices[faces],
                                   axis=2).max())
    if not (spacing > 0 and longest > 2.0 * spacing):
        return vertices, faces, uv, None
    try:
        from ._interrupts import import_trimesh

        trimesh = import_trimesh()
    except ImportError:  # (the mesh extra): the skin stays as it is
        return vertices, faces, uv, None
    tri = vertices[faces]
    area = 0.5 * float(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                      axis=1).sum())
    edge = max(spacing, float(np.sqrt(area / (0.433 * MAX_SKIN_FACES))))
    try:  # each pass halves the longest edge
        fine_v, fine_f, parent = trimesh.remesh.subdivide_to_size(
            vertices, faces, max_edge=edge, max_iter=int(np.ceil(np.log2(longest / edge))) + 2,
            return_index=True)
    except ValueError:  # (trimesh gave up: the skin is left as it is)
        return vertices, faces, uv, None
    if len(fine_f) > 4 * MAX_SKIN_FACES:  # (a skin far larger than its body: a slip of units)
        return vertices, faces, uv, None
    fine_v, fine_f = np.asarray(fine_v, dtype=np.float64), np.asarray(fine_f, dtype=np.int64)
    parent = np.asarray(parent, np.int64)
    if uv is not None:
        from .geometry.texcoords import subdivided

        uv = subdivided(vertices, faces, uv, fine_v, fine_f, parent)
    return fine_v, fine_f, uv, parent


def identity_skin(points: np.ndarray, triangles: np.ndarray) -> Skin:
    """A skin whose vertices are the body points themselves (weight 1 on one point)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    used = np.unique(np.asarray(triangles, dtype=np.int64).ravel())
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    w = np.zeros((len(used), 4))
    w[:, 0] = 1.0
    return Skin(rest_vertices=points[used].copy(), faces=remap[triangles],
                point_index=np.repeat(used[:, None], 4, axis=1), weights=w)


def box_surface(lower, upper, divisions: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Triangulated surface of the box [lower, upper] [m], each face a ``divisions`` grid.

    Returns vertices [m] (m, 3) and outward-facing triangles (f, 3) (counter-clockwise seen
    from outside).  Vertices on shared edges are merged, so the surface is closed.
    """
    lower = np.asarray(lower, dtype=np.float64).reshape(3)
    upper = np.asarray(upper, dtype=np.float64).reshape(3)
    d = int(divisions)
    verts, faces = [], []
    u = np.linspace(0.0, 1.0, d + 1)
    for axis in range(3):
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            g1, g2 = np.meshgrid(u, u, indexing="ij")
            p = np.empty((d + 1, d + 1, 3))
            p[..., axis] = side
            p[..., a1] = g1
            p[..., a2] = g2
            base = sum(len(v) for v in verts)
            verts.append(p.reshape(-1, 3))
            idx = base + np.arange((d + 1) ** 2).reshape(d + 1, d + 1)
            q0, q1, q2, q3 = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
            # (a1, a2, axis) is right-handed, so q0 q1 q2 faces +axis
            t = np.concatenate([np.stack([q0, q1, q2], -1).reshape(-1, 3),
                                np.stack([q0, q2, q3], -1).reshape(-1, 3)])
            if side == 0:
                t = t[:, ::-1]
            faces.append(t)
    unit = np.concatenate(verts)
    faces = np.concatenate(faces)
    key = np.round(unit * d).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    vertices = lower + unit[first] * (upper - lower)
    return vertices, inverse.reshape(-1)[faces]


def box_skin(body, lower, upper, divisions: int = 8) -> Skin:
    """The box's surface bound to a (random field) body inside it."""
    verts, faces = box_surface(lower, upper, divisions)
    return bind_body_skin(body, verts, faces)


def default_skin(scene, body) -> Skin | None:
    """The skin a scene's body gets when none is given: the input mesh for mesh scenes, and
    the mesh a body file was built from (``body.skin_vertices``); the box surface for box
    scenes; the body's own ``triangles`` when it has some; ``None`` for a tet body (drawn and
    exported by its tets' outer faces); else the outer faces of the cells its springs hold
    together (:func:`outer_skin`; ``None`` when there are none)."""
    b = scene.params.get("body", {}) if scene is not None else {}
    surface = getattr(scene, "surface", None)
    if surface is not None:  # a mesh scene carries its (placed) input mesh
        return bind_body_skin(body, surface[0], surface[1], scene.surface_uv,
                              scene.surface_materials)
    if getattr(body, "skin_vertices", None) is not None:
        return bind_body_skin(body, body.skin_vertices, body.skin_faces, body.skin_uv,
                              body.materials)
    if b.get("type") == "box" and "lower" in b:
        return box_skin(body, b["lower"], b["upper"])
    if body.triangles is not None and len(body.triangles):
        return identity_skin(body.points, body.triangles)
    if getattr(body, "tets", None) is not None and len(body.tets):
        return None  # (a trajectory carries a tet body's outer faces as its triangles)
    return outer_skin(body)


def outer_skin(body) -> Skin | None:
    """The skin of a body with neither a mesh nor triangles: the outer faces of its ``tets``,
    else of the cells its springs hold together, on the body's own points, outward.

    Those cells are the Delaunay cells of the points (a fixed sub-micron jitter breaks a
    grid's ties, whose flat cells would leave holes between two cubes split along different
    diagonals) whose six edges are springs or whose circumsphere is smaller than 0.95 of the
    median distance between nearest points (a grid: a cube's cells, radius 0.87 of a side,
    whichever of its diagonals are springs), so a gap of two spacings or more between the
    points stays open.  ``None`` for fewer than four points, or
    points in one plane (nothing to enclose)."""
    from scipy.spatial import Delaunay, QhullError, cKDTree

    from .geometry.tetra import boundary_faces, orient_tets

    points = np.asarray(body.points, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    tets = getattr(body, "tets", None)
    if tets is not None and len(tets):
        tets = orient_tets(points, np.asarray(tets, dtype=np.int64).reshape(-1, 4))
        faces = boundary_faces(tets, n)
        return identity_skin(points, faces) if len(faces) else None
    springs = np.asarray(body.springs if body.springs is not None else (), np.int64)
    if n < 4 or springs.size == 0 or not np.all(np.isfinite(points)):
        return None
    size = float(np.max(np.ptp(points, axis=0)))
    if np.linalg.svd(points - points.mean(axis=0), compute_uv=False)[-1] <= 1e-6 * size * (
            len(points) ** 0.5):  # in one plane (or a line): nothing to enclose (the jitter
        return None           # below would lift slivers off the plane)
    jitter = np.random.default_rng(0).uniform(-1.0, 1.0, points.shape) * 1e-7 * size
    try:
        cells = Delaunay(points + jitter).simplices.astype(np.int64)
    except QhullError:
        return None
    spacing = float(np.median(cKDTree(points).query(points, k=2)[0][:, 1]))
    keep = _held_by_springs(cells, springs, n) | (
        _circumradius(points + jitter, cells) < 0.95 * spacing)
    if not keep.any():
        return None
    cells = orient_tets(points + jitter, cells[keep])
    faces = boundary_faces(cells, n)
    return identity_skin(points, faces) if len(faces) else None


def _circumradius(points, cells) -> np.ndarray:
    """Each tet's circumsphere radius [m], shape (t,) (inf for a flat one)."""
    a = points[cells[:, 0]]
    e = points[cells[:, 1:]] - a[:, None, :]                  # (t, 3, 3) edges from a
    rhs = 0.5 * np.einsum("tij,tij->ti", e, e)
    det = np.linalg.det(e)
    ok = np.abs(det) > 1e-300
    r = np.full(len(cells), np.inf)
    if ok.any():
        c = np.linalg.solve(e[ok], rhs[ok][..., None])[..., 0]
        r[ok] = np.linalg.norm(c, axis=1)
    return r
