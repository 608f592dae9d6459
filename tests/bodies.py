"""Box bodies from three builders, and a static uniaxial-stretch measurement (test helpers).

Until ``jellysim.geometry.tetra`` lands, the tet builders are imitated here: a structured grid
split into 6 Kuhn tets per cube (marching-style) and ``scipy.spatial.Delaunay`` of jittered
grid points (delaunay-style).
"""
from __future__ import annotations

import itertools

import numpy as np

from jellysim.body import Body
from jellysim.geometry.connect import canonical_springs, radius_springs
from jellysim.geometry.sampling import box_field
from jellysim.geometry.tetra import tet_signed_volumes as tet_volumes

_PAIRS = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])


def _grid(shape, lower, upper):
    axes = [np.linspace(lo, hi, s + 1) for lo, hi, s in zip(lower, upper, shape)]
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return g


def _tet_body(points, tets, builder):
    vol = tet_volumes(points, tets)
    tets = np.where((vol < 0)[:, None], tets[:, [0, 2, 1, 3]], tets)
    springs = canonical_springs(np.sort(tets[:, _PAIRS].reshape(-1, 2), axis=1))
    return Body(points=points, springs=springs, tets=tets,
                volume=float(np.abs(vol).sum()), meta={"builder": builder})


def kuhn_box(shape, lower=(0, 0, 0), upper=(1, 1, 1)) -> Body:
    """Grid of ``shape`` cubes, each split into 6 tets around its main diagonal (the plain,
    unmirrored split: the figures of the tests that use it were measured on it)."""
    from jellysim.geometry.lattice import cell_tets

    nx, ny, nz = shape
    pts = _grid(shape, lower, upper)
    cells = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"),
                     axis=-1).reshape(-1, 3)
    tets = cell_tets(cells, ((ny + 1) * (nz + 1), nz + 1, 1), mirrored=False)
    return _tet_body(pts, tets, "kuhn")


def delaunay_box(shape, lower=(0, 0, 0), upper=(1, 1, 1), *, jitter=0.3, seed=0) -> Body:
    """Delaunay tets of a grid whose points are jittered (along the faces on the faces)."""
    from scipy.spatial import Delaunay

    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    pts = _grid(shape, lower, upper)
    h = (upper - lower) / np.asarray(shape)
    rng = np.random.default_rng(seed)
    move = rng.uniform(-jitter, jitter, pts.shape) * h
    on_face = np.isclose(pts, lower) | np.isclose(pts, upper)
    pts = pts + np.where(on_face, 0.0, move)
    tets = Delaunay(pts).simplices.astype(np.int64)
    vol = np.abs(tet_volumes(pts, tets))
    tets = tets[vol > 1e-9 * np.prod(h)]
    return _tet_body(pts, tets, "delaunay")


def radius_box(count, lower=(0, 0, 0), upper=(1, 1, 1), *, neighbours=2.0, seed=0) -> Body:
    """Uniform random points, springs to every point within ``neighbours`` mean spacings."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    volume = float(np.prod(upper - lower))
    pts = box_field(count, lower, upper, distribution="uniform", seed=seed)
    r = neighbours * (volume / count) ** (1 / 3)
    return Body(points=pts, springs=radius_springs(pts, r), volume=volume,
                meta={"builder": "radius"})


def stiffness_matrix(points, springs, k):
    from jellysim.physics.material import _stiffness_matrix

    return _stiffness_matrix(np.asarray(points, float), np.asarray(springs), np.asarray(k),
                             len(points))


def uniaxial_youngs(body: Body, k, *, axis=0, strain=1e-4):
    """Young's modulus [Pa] and Poisson's ratio of the box ``body`` with springs ``k`` [N/m],
    measured like a tensile test: the points in the lowest and highest slabs (half a mean spacing
    thick) along ``axis`` are held at 0 and moved by ``strain * length`` along ``axis``, free
    sideways; stress = reaction force / cross-section area; strain = the slope of the
    displacement over the middle 40 % of the body (least squares)."""
    from scipy.sparse.linalg import spsolve

    x = np.asarray(body.points, float)
    n = len(x)
    lo, hi = x.min(axis=0), x.max(axis=0)
    size = hi - lo
    spacing = (np.prod(size) / n) ** (1 / 3)
    length = size[axis]
    bottom = x[:, axis] < lo[axis] + 0.5 * spacing
    top = x[:, axis] > hi[axis] - 0.5 * spacing
    K = stiffness_matrix(x, body.springs, k).tocsr()
    u = np.zeros(3 * n)
    fixed = np.zeros(3 * n, bool)
    fixed[3 * np.nonzero(bottom)[0] + axis] = True
    fixed[3 * np.nonzero(top)[0] + axis] = True
    u[3 * np.nonzero(top)[0] + axis] = strain * length
    # remove the sideways rigid motions: pin one bottom point sideways, a second one partly
    lat = [c for c in range(3) if c != axis]
    b = np.nonzero(bottom)[0]
    centre = lo + 0.5 * size
    p0 = b[np.argmin(np.linalg.norm(x[b] - centre * (np.arange(3) != axis) - lo * (
        np.arange(3) == axis), axis=1))]
    p1 = b[np.argmax(np.abs(x[b, lat[0]] - x[p0, lat[0]]))]
    fixed[3 * p0 + lat[0]] = fixed[3 * p0 + lat[1]] = True
    fixed[3 * p1 + lat[1]] = True
    free = ~fixed
    u[free] = spsolve(K[free][:, free].tocsc(), -K[free][:, fixed] @ u[fixed])
    force = K @ u
    reaction = force[3 * np.nonzero(top)[0] + axis].sum()
    area = np.prod(size) / length
    mid = np.abs(x[:, axis] - centre[axis]) < 0.2 * length
    U = u.reshape(n, 3)
    A = np.stack([x[mid, axis], np.ones(mid.sum())], axis=1)
    eps = np.linalg.lstsq(A, U[mid, axis], rcond=None)[0][0]
    eps_lat = np.mean([np.linalg.lstsq(np.stack([x[mid, c], np.ones(mid.sum())], axis=1),
                                       U[mid, c], rcond=None)[0][0] for c in lat])
    return reaction / area / eps, -eps_lat / eps
