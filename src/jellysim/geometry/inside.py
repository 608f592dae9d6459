"""Point-in-mesh: the report's slicing test (section 4.4), exact and batched.

The algorithm
-------------
The report slices the triangle mesh by a plane through the query point ``p`` (giving a 2D
contour), slices that contour by a line through ``p`` (giving 1D segments on a number line) and
counts the contour crossings on one side of ``p``. We slice by the plane ``z = pz`` and the line
``y = py`` inside it and count crossings on the side ``x > px``. A triangle contributes one
crossing exactly when its projection onto the (y, z) plane contains ``(py, pz)`` and its plane is
met at some ``x > px``: the segment the triangle leaves in the 2D contour (report case 2) is then
cut by the line at one point, and that point lies to the right of ``p``. So the whole 3D -> 2D ->
1D reduction is, per triangle, one point-in-triangle test in (y, z) and one side test in x.

Tie-breaking instead of stitching
---------------------------------
The report's special cases (a vertex on the plane, an edge in the plane, a triangle in the plane,
and the same again one dimension down for the line) all come from values *exactly equal* to the
query's coordinates. We resolve them once and for all by symbolic perturbation: the query's
(y, z) is replaced by ``(py + e, pz + e^2)`` for an infinitesimal ``e > 0``. Geometrically the
slicing plane sits infinitesimally *above* ``z = pz`` and the line infinitesimally to the side
``y > py`` of it, with the plane's offset much smaller than the line's. Every vertex whose z equals
``pz`` is therefore below the plane (one fixed side, the same for all triangles, which is the
report's case-3 rule), every contour vertex whose y equals ``py`` lies on one fixed side of the
line, and a triangle lying in the plane is below it and ignored (report case 4; it matters only
for points on the surface, which we detect separately and exactly, see below).

For an edge ``a -> b`` of a projected triangle the perturbed orientation is::

    orient(a, b, q + (e, e^2)) = orient(a, b, q) + e (a_z - b_z) + e^2 (b_y - a_y)

so when ``orient(a, b, q) == 0`` its sign is ``sign(a_z - b_z)``, or ``sign(b_y - a_y)`` when
``a_z == b_z`` (these are exact comparisons of input coordinates). The sign is never zero unless
``a`` and ``b`` project to the same point, in which case the projected triangle has zero area and
the perturbed line misses it. Because the rule depends only on the two end points, the two
triangles sharing an edge see the perturbed line on opposite sides of it: the perturbed line
crosses a closed surface a well-defined number of times and never through a vertex or an edge.
This is why no contour has to be built or stitched: the contour only exists implicitly, as the set
of triangles that the perturbed line pierces, and it is consistent by construction.

Exactness
---------
Every decision is the sign of a polynomial in the input float64 coordinates:

* ``orient2d`` (point in projected triangle), and the sign of the triangle's projected area;
* ``orient3d`` (which side of the triangle's plane ``p`` is on: crossing at ``x > px`` or not;
  zero means ``p`` is on the plane);
* comparisons of coordinates (bounding boxes, the tie-break).

The orientations are evaluated with a floating-point filter (Shewchuk's first-stage error bounds:
if the rounded determinant exceeds a bound on its rounding error its sign is right) and, when the
filter cannot decide, exactly: the determinant is expanded into a sum of products of input
coordinates, each product is made exact with Dekker's TwoProduct, and the terms are summed into a
non-overlapping floating-point expansion with TwoSum; the sign of an expansion is the sign of its
largest non-zero component. This is exact as long as no intermediate product overflows or
underflows (coordinates between about 1e-75 and 1e75 in magnitude, or zero). So the decisions do
not depend on rounding luck: the same point gets the same answer on every machine, for every
thread count and every batch order.

Points on the surface
---------------------
``p`` lies on a triangle exactly when ``orient3d(A, B, C, p) == 0`` and ``(py, pz)`` is in the
*closed* projected triangle (triangles parallel to the x axis are checked in the (x, y) or (z, x)
projection instead). These points get the label 2 from :func:`classify` and follow the
``on_surface`` policy of :func:`inside`.

Rules
-----
``parity``: the report's rule, inside when the number of crossings is odd (even-odd). On nested
shells with the same orientation, or on self-intersecting surfaces, this answers "outside" where
the surface wraps a point twice.

``winding``: the winding number, inside when ``w > 1/2``. Each crossing is signed by the sign of
the triangle's normal x-component. On a mesh whose boundary is zero as a chain (every edge
traversed as often in one direction as in the other, which includes all closed meshes, also
self-intersecting ones) the signed count *is* the winding number, an exact integer. A mesh with
boundary (open, cracked) is closed by cones of "cap" triangles over its boundary chain (one apex
per boundary component); the generalized winding number (sum of signed solid angles over 4 pi)
of the mesh is then ``w = W_closed - w_cap``: the exact integer crossing count of mesh + cap,
minus the solid angle (a float sum, Van Oosterom-Strackee) of the few cap triangles only. The
float part has an error of order (number of cap triangles) x 1e-16 relative, except near the cap,
where the jump of the cap's solid angle is taken from the same exact orient3d sign as the
crossing count so that the two parts stay consistent; a point exactly on a cap triangle falls back
to the direct float sum over the mesh's triangles. Only the final comparison ``w > 1/2`` is
inexact, for points where the true ``w`` is within ~1e-12 of 1/2 (for example in the plane of a
missing face, where ``w`` is exactly 1/2 and no float method can decide).

``auto``: parity on a closed, consistently oriented, edge-manifold mesh; otherwise the winding
rule with a :class:`UserWarning` naming the defects.

Speed
-----
:class:`InsideQuery` builds, once, a uniform 2D grid over the (y, z) bounding boxes of the
triangles (CSR lists, triangle data copied into list order for cache locality). A query looks up
the one cell that contains ``(py, pz)`` and tests only the triangles listed there; large batches
are first counting-sorted by cell so that consecutive points reuse the same lists. Cell indices are
computed by the same monotone float function at build and query time, so a triangle whose closed
bounding box contains ``(py, pz)`` is always in that cell. Queries run in a ``numba`` kernel with
``prange`` over points; each point writes only its own outputs, so results do not depend on the
number of threads.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit, prange

from jellysim._numba_cache import check as _check_cache

_check_cache()

from jellysim.geometry.mesh import Mesh
# the exact predicates (orient2d/3d, the tie-break) live in their own module
from jellysim.geometry.predicates import _orient2d, _orient3d, _sos_edge

__all__ = ["InsideQuery", "inside", "classify", "OUTSIDE", "INSIDE", "ON_SURFACE"]

OUTSIDE = 0
INSIDE = 1
ON_SURFACE = 2

_RULES = ("auto", "parity", "winding")

# --------------------------------------------------------------------------- grid


@njit(cache=True, inline="always")
def _cell(v, lo, inv_h, n):
    """Grid index of coordinate v: a monotone function of v, clipped to [0, n)."""
    t = (v - lo) * inv_h
    if not (t >= 0.0):  # also NaN
        return 0
    if t >= n:
        return n - 1
    i = int(math.floor(t))
    return i if i < n else n - 1


@njit(cache=True)
def _cell_ranges(bb, y0, z0, inv_hy, inv_hz, ny, nz):
    m = bb.shape[0]
    out = np.empty((m, 4), np.int64)
    for t in range(m):
        out[t, 0] = _cell(bb[t, 1], y0, inv_hy, ny)
        out[t, 1] = _cell(bb[t, 4], y0, inv_hy, ny)
        out[t, 2] = _cell(bb[t, 2], z0, inv_hz, nz)
        out[t, 3] = _cell(bb[t, 5], z0, inv_hz, nz)
    return out


# --------------------------------------------------------------------------- query kernel


@njit(cache=True)
def _order_by_cell(points, y0, z0, inv_hy, inv_hz, ny, nz):
    """Counting sort of the points by grid cell, so that consecutive points reuse the same
    triangle lists (cache locality). Only an ordering of the work: each point's result is the
    same whatever the order."""
    n = points.shape[0]
    cell = np.empty(n, np.int64)
    counts = np.zeros(ny * nz + 1, np.int64)
    for i in range(n):
        c = _cell(points[i, 1], y0, inv_hy, ny) * nz + _cell(points[i, 2], z0, inv_hz, nz)
        cell[i] = c
        counts[c + 1] += 1
    for c in range(ny * nz):
        counts[c + 1] += counts[c]
    order = np.empty(n, np.int64)
    for i in range(n):
        c = cell[i]
        order[counts[c]] = i
        counts[c] += 1
    return order

_MAX_ENTRIES_PER_TRIANGLE = 8

# columns of the per-entry float data
# 0..8: Ax Ay Az Bx By Bz Cx Cy Cz; 9..14: xmin ymin zmin xmax ymax zmax
_NF = 15


@njit(cache=True, inline="always")
def _on_triangle_flat(fd, k, px, py, pz, proj):
    """p on the closed triangle that is parallel to the x axis (zero (y, z) area)."""
    ax, ay, az = fd[k, 0], fd[k, 1], fd[k, 2]
    bx, by, bz = fd[k, 3], fd[k, 4], fd[k, 5]
    cx, cy, cz = fd[k, 6], fd[k, 7], fd[k, 8]
    if _orient3d(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz) != 0:
        return False
    if proj == 1:  # (x, y)
        s = _orient2d(ax, ay, bx, by, cx, cy)
        o1 = _orient2d(ax, ay, bx, by, px, py)
        o2 = _orient2d(bx, by, cx, cy, px, py)
        o3 = _orient2d(cx, cy, ax, ay, px, py)
    elif proj == 2:  # (z, x)
        s = _orient2d(az, ax, bz, bx, cz, cx)
        o1 = _orient2d(az, ax, bz, bx, pz, px)
        o2 = _orient2d(bz, bx, cz, cx, pz, px)
        o3 = _orient2d(cz, cx, az, ax, pz, px)
    else:
        return False
    return o1 != -s and o2 != -s and o3 != -s


@njit(cache=True, parallel=True)
def _query_kernel(points, order, y0, z0, inv_hy, inv_hz, ny, nz, start, fd, sgn, proj, is_cap,
                  count, parity, flag):
    n = points.shape[0]
    for j in prange(n):
        i = order[j]
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        c = _cell(py, y0, inv_hy, ny) * nz + _cell(pz, z0, inv_hz, nz)
        cnt = 0
        par = 0
        fl = 0
        for k in range(start[c], start[c + 1]):
            if py < fd[k, 10] or py > fd[k, 13] or pz < fd[k, 11] or pz > fd[k, 14]:
                continue
            if px > fd[k, 12]:
                continue
            s = sgn[k]
            if s == 0:
                if px >= fd[k, 9] and _on_triangle_flat(fd, k, px, py, pz, proj[k]):
                    fl = 1 if (is_cap[k] == 0 or fl == 1) else 2
                continue
            ay, az = fd[k, 1], fd[k, 2]
            by, bz = fd[k, 4], fd[k, 5]
            cy, cz = fd[k, 7], fd[k, 8]
            e1, o1 = _sos_edge(ay, az, by, bz, py, pz)
            if o1 == -s:
                continue
            e2, o2 = _sos_edge(by, bz, cy, cz, py, pz)
            if o2 == -s:
                continue
            e3, o3 = _sos_edge(cy, cz, ay, az, py, pz)
            if o3 == -s:
                continue
            # (py, pz) is in the closed projected triangle
            hit = e1 == s and e2 == s and e3 == s
            if px < fd[k, 9]:
                if hit:
                    cnt += s
                    par ^= 1
                continue
            o = _orient3d(fd[k, 0], ay, az, fd[k, 3], by, bz, fd[k, 6], cy, cz, px, py, pz)
            if o == 0:
                fl = 1 if (is_cap[k] == 0 or fl == 1) else 2
            elif hit and o == s:
                cnt += s
                par ^= 1
        # outputs in work order (sequential writes); _scatter puts them back in input order
        count[j] = cnt
        parity[j] = par
        flag[j] = fl


@njit(cache=True, parallel=True)
def _gather(points, order):
    out = np.empty_like(points)
    for j in prange(order.shape[0]):
        i = order[j]
        out[j, 0] = points[i, 0]
        out[j, 1] = points[i, 1]
        out[j, 2] = points[i, 2]
    return out


@njit(cache=True, parallel=True)
def _scatter(order, count_w, parity_w, flag_w, count, parity, flag):
    for j in prange(order.shape[0]):
        i = order[j]
        count[i] = count_w[j]
        parity[i] = parity_w[j]
        flag[i] = flag_w[j]


@njit(cache=True, inline="always")
def _solid_angle(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz, det_sign):
    """Signed solid angle of triangle abc seen from p (Van Oosterom & Strackee)."""
    ax -= px
    ay -= py
    az -= pz
    bx -= px
    by -= py
    bz -= pz
    cx -= px
    cy -= py
    cz -= pz
    la = math.sqrt(ax * ax + ay * ay + az * az)
    lb = math.sqrt(bx * bx + by * by + bz * bz)
    lc = math.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    den = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la \
        + (cx * ax + cy * ay + cz * az) * lb
    if det_sign != 2:  # use the exact sign where the float one may be wrong
        if det_sign == 0:
            return 0.0
        if (det > 0.0) != (det_sign > 0):
            det = math.copysign(0.0, float(det_sign))
    return 2.0 * math.atan2(det, den)


@njit(cache=True, parallel=True)
def _cap_winding_kernel(points, cap, out):
    """Sum over cap triangles of the solid angle / 4 pi, with the exact orientation sign."""
    n = points.shape[0]
    for i in prange(n):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        acc = 0.0
        for t in range(cap.shape[0]):
            ax, ay, az = cap[t, 0], cap[t, 1], cap[t, 2]
            bx, by, bz = cap[t, 3], cap[t, 4], cap[t, 5]
            cx, cy, cz = cap[t, 6], cap[t, 7], cap[t, 8]
            o = _orient3d(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz)
            acc += _solid_angle(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz, o)
        out[i] = acc / (4.0 * math.pi)


@njit(cache=True, parallel=True)
def _direct_winding_kernel(points, tri, out):
    n = points.shape[0]
    for i in prange(n):
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        acc = 0.0
        for t in range(tri.shape[0]):
            acc += _solid_angle(tri[t, 0], tri[t, 1], tri[t, 2], tri[t, 3], tri[t, 4], tri[t, 5],
                                tri[t, 6], tri[t, 7], tri[t, 8], px, py, pz, 2)
        out[i] = acc / (4.0 * math.pi)


# --------------------------------------------------------------------------- setup


def _boundary_chain(faces: np.ndarray) -> np.ndarray:
    """Directed boundary edges (u, v) of the faces as a 1-chain, with multiplicity."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    lo = np.minimum(e[:, 0], e[:, 1])
    hi = np.maximum(e[:, 0], e[:, 1])
    sign = np.where(e[:, 0] < e[:, 1], 1, -1)
    key = lo * (int(faces.max()) + 1) + hi
    uk, inv = np.unique(key, return_inverse=True)
    net = np.bincount(inv.reshape(-1), weights=sign, minlength=len(uk)).astype(np.int64)
    nz = np.flatnonzero(net)
    n1 = int(faces.max()) + 1
    u, v = uk[nz] // n1, uk[nz] % n1
    mult = np.abs(net[nz])
    u_dir = np.where(net[nz] > 0, u, v)
    v_dir = np.where(net[nz] > 0, v, u)
    return np.repeat(np.stack([u_dir, v_dir], axis=1), mult, axis=0)


def _cap_triangles(v: np.ndarray, chain: np.ndarray) -> np.ndarray:
    """Close the boundary chain by cones: one apex per connected boundary component.

    For each boundary edge u -> v the cap triangle is (v, u, apex): together with the mesh face
    that traverses u -> v the edge cancels, and the apex edges cancel between consecutive edges of
    the (balanced) boundary cycle. Any apex would do; a generic offset from the component's
    centroid keeps the cap out of the planes and lines that test points and grids sit on, and
    one apex per component keeps the cap triangles small (few grid cells each).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nv = len(v)
    g = coo_matrix((np.ones(len(chain)), (chain[:, 0], chain[:, 1])), shape=(nv, nv))
    _, label = connected_components(g, directed=False)
    comp = label[chain[:, 0]]
    offset = np.array([0.0123456789, -0.0071234567, 0.0093456781])
    apex = np.empty((len(chain), 3))
    for c in np.unique(comp):
        idx = np.unique(chain[comp == c].ravel())
        pts = v[idx]
        size = float(np.linalg.norm(pts.max(0) - pts.min(0))) or 1.0
        apex[comp == c] = pts.mean(axis=0) + size * offset
    return np.concatenate([v[chain[:, 1]], v[chain[:, 0]], apex], axis=1)


class InsideQuery:
    """A prepared point-in-mesh query: build once (grid, caps), query many times.

    Parameters
    ----------
    mesh:
        A :class:`~jellysim.geometry.mesh.Mesh` (or anything with ``vertices`` (n, 3) float and
        ``faces`` (m, 3) int).
    rule:
        ``"auto"``, ``"parity"`` or ``"winding"`` (see the module docstring).
    cells_per_triangle:
        Grid resolution: about this many grid cells per triangle.
    """

    def __init__(self, mesh, *, rule: str = "auto", cells_per_triangle: float = 2.0):
        if rule not in _RULES:
            raise ValueError(f"rule must be one of {_RULES}, got {rule!r}")
        if not isinstance(mesh, Mesh) or mesh.defects.face_count != len(mesh.faces):
            # not made by load_mesh / from_arrays: clean it and compute its defects report
            mesh = Mesh.from_arrays(mesh.vertices, mesh.faces)
        v = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        f = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self.mesh = mesh
        chain = _boundary_chain(f)
        if rule == "auto":
            d = mesh.defects
            if d.watertight:
                rule = "parity"
            else:
                problems = ", ".join(d.problems()) or "defects"
                name = mesh.path if mesh.path is not None else "mesh"
                warnings.warn(
                    f"{name} is not a closed manifold ({problems}); using the winding-number "
                    "rule (inside where w > 1/2) instead of the crossing parity",
                    UserWarning,
                    stacklevel=3,
                )
                rule = "winding"
        self.rule = rule
        tri = np.concatenate([v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]], axis=1)
        self.triangles = tri
        """Mesh triangles, shape (m, 9): Ax Ay Az Bx By Bz Cx Cy Cz."""
        cap = np.zeros((0, 9))
        if rule == "winding" and len(chain):
            cap = _cap_triangles(v, chain)
        self.cap = np.ascontiguousarray(cap)
        """Cap triangles (v, u, apex) for each boundary edge u -> v, shape (k, 9)."""
        all_tri = np.concatenate([tri, cap]) if len(cap) else tri
        cap_flag = np.concatenate([np.zeros(len(tri), np.uint8), np.ones(len(cap), np.uint8)])
        self._build_grid(all_tri, cap_flag, cells_per_triangle)

    def _build_grid(self, tri, cap_flag, cells_per_triangle):
        m = len(tri)
        xs, ys, zs = tri[:, 0::3], tri[:, 1::3], tri[:, 2::3]
        bb = np.column_stack([xs.min(1), ys.min(1), zs.min(1), xs.max(1), ys.max(1), zs.max(1)])
        y0, z0 = float(bb[:, 1].min()), float(bb[:, 2].min())
        wy = float(bb[:, 4].max()) - y0
        wz = float(bb[:, 5].max()) - z0
        ncell = max(1.0, cells_per_triangle * m)
        while True:
            if wy > 0 and wz > 0:
                h = math.sqrt(wy * wz / ncell)
            else:
                h = max(wy, wz) / ncell or 1.0
            ny = int(min(max(1, math.ceil(wy / h)), 4096)) if wy > 0 else 1
            nz = int(min(max(1, math.ceil(wz / h)), 4096)) if wz > 0 else 1
            inv_hy = ny / wy if wy > 0 else 0.0
            inv_hz = nz / wz if wz > 0 else 0.0
            rng = _cell_ranges(bb, y0, z0, inv_hy, inv_hz, ny, nz)
            cy = rng[:, 1] - rng[:, 0] + 1
            cz = rng[:, 3] - rng[:, 2] + 1
            per = cy * cz
            # small triangles seen from far (scans): coarsen until each triangle is listed in
            # a few cells only, which bounds memory at ~MAX_ENTRIES_PER_TRIANGLE x m
            if per.sum() <= _MAX_ENTRIES_PER_TRIANGLE * m or ncell <= 1.0:
                break
            ncell = max(1.0, ncell / 2.0)
        tid = np.repeat(np.arange(m), per)
        off = np.arange(len(tid)) - np.repeat(np.cumsum(per) - per, per)
        iy = rng[tid, 0] + off // cz[tid]
        iz = rng[tid, 2] + off % cz[tid]
        cell = iy * nz + iz
        order = np.argsort(cell, kind="stable")
        tid = tid[order]
        start = np.zeros(ny * nz + 1, np.int64)
        np.cumsum(np.bincount(cell, minlength=ny * nz), out=start[1:])

        # exact per-triangle constants
        sgn = np.empty(m, np.int8)
        proj = np.zeros(m, np.int8)
        _triangle_signs(tri, sgn, proj)
        self._grid = (y0, z0, inv_hy, inv_hz, ny, nz, start)
        self._fd = np.ascontiguousarray(np.concatenate([tri, bb], axis=1)[tid])
        self._sgn = np.ascontiguousarray(sgn[tid])
        self._proj = np.ascontiguousarray(proj[tid])
        self._is_cap = np.ascontiguousarray(cap_flag[tid])

    # ----------------------------------------------------------------------- queries

    def crossings(self, points):
        """Raw results: signed crossing count (int32), parity (uint8) and flag (uint8: 1 on the
        mesh surface, 2 on a cap triangle) for each point, shape (n,) each."""
        pts = _as_points(points)
        n = len(pts)
        count = np.empty(n, np.int32)
        parity = np.empty(n, np.uint8)
        flag = np.empty(n, np.uint8)
        y0, z0, inv_hy, inv_hz, ny, nz, start = self._grid
        if n:
            if n >= 4 * ny * nz:
                order = _order_by_cell(pts, y0, z0, inv_hy, inv_hz, ny, nz)
                cw = np.empty(n, np.int32)
                pw = np.empty(n, np.uint8)
                fw = np.empty(n, np.uint8)
                # contiguous sorted copy: the kernel then streams through points and lists
                _query_kernel(_gather(pts, order), np.arange(n, dtype=np.int64), y0, z0, inv_hy,
                              inv_hz, ny, nz, start, self._fd, self._sgn, self._proj,
                              self._is_cap, cw, pw, fw)
                _scatter(order, cw, pw, fw, count, parity, flag)
            else:
                order = np.arange(n, dtype=np.int64)
                _query_kernel(pts, order, y0, z0, inv_hy, inv_hz, ny, nz, start, self._fd,
                              self._sgn, self._proj, self._is_cap, count, parity, flag)
        return count, parity, flag

    def winding_number(self, points):
        """Generalized winding number of each point, shape (n,) float64 (exact integers on a
        mesh without boundary; nan for points on the surface)."""
        pts = _as_points(points)
        count, _, flag = self.crossings(pts)
        return self._winding_from(pts, count, flag)

    def _winding_from(self, pts, count, flag):
        w = count.astype(np.float64)
        if len(self.cap):
            wc = np.empty(len(pts))
            _cap_winding_kernel(pts, self.cap, wc)
            w -= wc
            on_cap = flag == 2
            if on_cap.any():
                wd = np.empty(int(on_cap.sum()))
                _direct_winding_kernel(np.ascontiguousarray(pts[on_cap]), self.triangles, wd)
                w[on_cap] = wd
        w[flag == 1] = np.nan
        return w

    def classify(self, points) -> np.ndarray:
        """0 outside, 1 inside, 2 on the surface, shape (n,) int8."""
        pts = _as_points(points)
        count, parity, flag = self.crossings(pts)
        if self.rule == "parity":
            out = parity.view(np.int8)
        elif len(self.cap) == 0:
            out = (count >= 1).view(np.int8)
        else:
            with np.errstate(invalid="ignore"):
                out = (self._winding_from(pts, count, flag) > 0.5).view(np.int8)
        out[flag == 1] = ON_SURFACE
        return out

    def query(self, points, *, on_surface: str = "inside") -> np.ndarray:
        """Inside test, shape (n,) bool; ``on_surface`` is "inside" or "outside"."""
        if on_surface not in ("inside", "outside"):
            raise ValueError(
                f"on_surface must be 'inside' or 'outside', got {on_surface!r} "
                "(use classify() for a third label)"
            )
        c = self.classify(points)
        return (c == INSIDE) | ((c == ON_SURFACE) & (on_surface == "inside"))


@njit(cache=True)
def _triangle_signs(tri, sgn, proj):
    for t in range(tri.shape[0]):
        ax, ay, az = tri[t, 0], tri[t, 1], tri[t, 2]
        bx, by, bz = tri[t, 3], tri[t, 4], tri[t, 5]
        cx, cy, cz = tri[t, 6], tri[t, 7], tri[t, 8]
        sgn[t] = _orient2d(ay, az, by, bz, cy, cz)
        if sgn[t] == 0:
            if _orient2d(ax, ay, bx, by, cx, cy) != 0:
                proj[t] = 1
            elif _orient2d(az, ax, bz, bx, cz, cx) != 0:
                proj[t] = 2
            else:
                proj[t] = 0


def _as_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape[0] == 3:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("points contain NaN or infinite coordinates")
    return np.ascontiguousarray(p)


def inside(mesh, points, *, rule: str = "auto", on_surface: str = "inside") -> np.ndarray:
    """Which points are inside the mesh, shape (n,) bool for (n, 3) points.

    ``rule``: "auto" (parity on a closed manifold, else winding with a warning), "parity"
    (the report's even-odd crossing count) or "winding" (w > 1/2). ``on_surface``: "inside" or
    "outside" for points exactly on the surface; :func:`classify` labels them 2 instead.
    For many queries on one mesh build an :class:`InsideQuery` once.
    """
    return InsideQuery(mesh, rule=rule).query(points, on_surface=on_surface)


def classify(mesh, points, *, rule: str = "auto") -> np.ndarray:
    """0 outside, 1 inside, 2 exactly on the surface; shape (n,) int8."""
    return InsideQuery(mesh, rule=rule).classify(points)
