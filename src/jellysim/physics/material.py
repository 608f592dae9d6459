"""Material -> springs: spring stiffnesses and point masses from density and Young's modulus.

Method (virial calibration, after Van Gelder 1998 and the affine "Born" stiffness of lattice
dynamics, Born & Huang 1954):

1. **Shape of the stiffness field.**  Each spring gets a weight ``w_s`` [m] that spreads the
   material's volume over the springs:

   * bodies with tetrahedra (marching grid, Delaunay, TetGen): ``w_s = sum_{t ∋ s} V_t / L_s^2``
     over the tets that contain edge s (Van Gelder, "Approximate simulation of elastic membranes
     by triangulated spring meshes", J. Graphics Tools 3(2), 1998, in its 3D form);
   * point clouds (radius springs): every point p owns a volume ``V_p`` (given, e.g. by
     :func:`jellysim.geometry.lattice.grid_point_volumes`, or the body volume split evenly) and
     shares it equally among its ``Z_p`` springs:
     ``w_s = (V_i / Z_i + V_j / Z_j) / L_s^2``.

   Either way ``sum_s w_s L_s^2`` is the body volume, so surface points (fewer springs) get
   stiffer springs and the modulus does not drop near the surface.

2. **Scale.**  Under a small uniform strain ``eps`` the network's elastic energy per volume, if
   every point follows the strain (affine), is ``1/2 eps : C : eps`` with the *virial* (Born)
   stiffness ``C_abcd = (1/V) sum_s k_s L_s^2 n_a n_b n_c n_d``.  Points of a disordered network
   relax away from the affine positions, which softens it by ``(1/V) Xi^T K^-1 Xi``
   (Lemaitre & Maloney 2006; ``Xi``: the forces the affine strain leaves on the points, ``K``:
   the network's stiffness matrix).  How much a finite body relaxes depends on how its surface
   is loaded; the kinematic (boundary points affine) and static (uniform stress on the boundary)
   apparent stiffnesses bound it from above and below (Hill 1963, Huet 1990).  Bodies with
   tets use their mean (:func:`kinematic_stiffness`, :func:`static_compliance`, the
   Voigt-Reuss-Hill estimate); point clouds the affine stiffness minus the relaxation of the
   inner points per inner volume (:func:`relaxation_stiffness`).  Everything is linear in the
   springs' common scale ``c`` (``k_s = c w_s``), so ``c`` follows from one evaluation:
   ``E_network(c) = c E_network(1) = E``.  Young's modulus of the anisotropic tensor is taken
   as the mean of ``1 / S_aa`` over the three axes (``S = C^-1`` in Voigt notation).

Limits (documented in docs/physics.md): a central-force network obeys the Cauchy relation
``C_12 = C_44``, so it cannot represent an arbitrary Poisson's ratio: an isotropic network has
``nu = 1/4`` (gelatin is nearly incompressible, ``nu ~ 0.5``, so the network's bulk modulus
is far too low).  Only E is matched, at small strain.
"""
from __future__ import annotations

import numpy as np

from ..body import Body
from ..geometry.tetra import tet_signed_volumes
from .._numba_cache import check
from ..errors import ParameterError

__all__ = ["spring_weights", "virial_stiffness", "relaxation_stiffness", "kinematic_stiffness",
           "static_compliance",
           "youngs_from_stiffness", "network_youngs_modulus", "calibrate_springs",
           "point_masses", "point_volumes", "surface_points", "spring_tets",
           "static_displacements"]

_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def spring_tets(body: Body):
    """The tets (t, 4) whose edges are ``body``'s springs, or ``None`` for a point cloud.

    A radius body (``body.meta["connect"] == "radius"``, from :func:`jellysim.build.build_body`
    or a scene's box field) may carry tets (Delaunay of its points, for the tetrahedral
    elasticity), but its springs are the radius springs, not the tets' edges: the calibration
    treats it as the point cloud it is."""
    if body.tets is None or not len(body.tets) or body.meta.get("connect") == "radius":
        return None
    return np.asarray(body.tets, dtype=np.int64)


def _edge_index(springs: np.ndarray, n: int) -> dict:
    return {int(a) * n + int(b): s for s, (a, b) in enumerate(springs)}


def point_volumes(body: Body, *, density: float | None = None) -> np.ndarray:
    """Volume owned by each point [m^3], shape (n,).

    From tets whose edges are the springs (a quarter of each incident tet, see
    :func:`spring_tets`), else from ``body.masses / density``, else the body volume split
    evenly.
    """
    n = body.point_count
    tets = spring_tets(body)
    if tets is not None:
        vol = np.abs(tet_signed_volumes(body.points, tets))
        return np.bincount(tets.ravel(), weights=np.repeat(vol / 4, 4), minlength=n)
    if body.masses is not None and density:
        return np.asarray(body.masses, dtype=np.float64) / density
    if body.volume is None:
        raise ParameterError("cannot derive point volumes: the body has no tets and no volume "
                         "(a body file: add a 'volume' line, a mass column or tets; a scene: "
                         "[mass] point_mass; Python: Body(..., volume=...))")
    return np.full(n, float(body.volume) / n)


def point_masses(body: Body, density: float) -> np.ndarray:
    """Point masses [kg], shape (n,): density x the volume each point owns (lumped mass)."""
    if body.masses is not None:
        return np.asarray(body.masses, dtype=np.float64)
    return density * point_volumes(body)


def spring_weights(body: Body, *, point_volume=None) -> np.ndarray:
    """Relative stiffness ``w_s`` [m], shape (k,), in the body's spring order (see module doc).

    ``point_volume`` [m^3], shape (n,): the volume each point owns, for bodies without tets
    (default: :func:`point_volumes`)."""
    pts = np.asarray(body.points, dtype=np.float64)
    springs = np.asarray(body.springs, dtype=np.int64).reshape(-1, 2)
    n, k = pts.shape[0], springs.shape[0]
    length = np.linalg.norm(pts[springs[:, 1]] - pts[springs[:, 0]], axis=1)
    if np.any(length <= 0):
        raise ParameterError("a spring has zero rest length")
    tets = spring_tets(body)
    if tets is not None:
        vol = np.abs(tet_signed_volumes(pts, tets))
        pairs = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
        e = np.sort(tets[:, pairs].reshape(-1, 2), axis=1)
        key = e[:, 0] * n + e[:, 1]
        skey = springs[:, 0] * n + springs[:, 1]
        order = np.argsort(skey)
        pos = np.searchsorted(skey[order], key)
        pos = np.minimum(pos, k - 1)
        found = skey[order][pos] == key
        if not np.all(found):
            raise ParameterError("a tet edge has no spring: build springs from the tets' edges "
                             "(or set body.meta['connect'] = 'radius' when the tets are not "
                             "the spring network)")
        w = np.bincount(order[pos], weights=np.repeat(vol, 6), minlength=k)
        if np.any(w <= 0):
            raise ParameterError("a spring belongs to no tet: cannot weight it by tet volume")
        return w / length**2
    vp = point_volumes(body) if point_volume is None else np.asarray(point_volume, float)
    z = np.bincount(springs.ravel(), minlength=n).astype(np.float64)
    share = np.where(z > 0, vp / np.maximum(z, 1.0), 0.0)
    return (share[springs[:, 0]] + share[springs[:, 1]]) / length**2


def _directions(points, springs):
    d = points[springs[:, 1]] - points[springs[:, 0]]
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], length


def virial_stiffness(points, springs, stiffness, volume) -> np.ndarray:
    """Affine (Born) stiffness [Pa], 6 x 6 Voigt matrix: ``(1/V) sum k L^2 n n n n``."""
    nrm, length = _directions(points, springs)
    a = np.stack([nrm[:, i] * nrm[:, j] for i, j in _VOIGT], axis=1)  # (k, 6)
    return (a * (stiffness * length**2)[:, None]).T @ a / volume


def _stiffness_matrix(points, springs, stiffness, n):
    """Rest stiffness K [N/m], sparse CSR (3n, 3n): ``K u`` is minus the spring force.  Built
    block by block (3 x 3 per point pair, each row's blocks in column order)."""
    from scipy.sparse import bsr_matrix

    nrm, _ = _directions(points, springs)
    blocks = stiffness[:, None, None] * nrm[:, :, None] * nrm[:, None, :]  # (k, 3, 3)
    i, j = springs[:, 0], springs[:, 1]
    diag = np.zeros((n, 3, 3))
    for a in range(3):
        for b in range(3):
            diag[:, a, b] = np.bincount(i, blocks[:, a, b], n) + np.bincount(j, blocks[:, a, b], n)
    rows = np.concatenate([np.arange(n), i, j])
    cols = np.concatenate([np.arange(n), j, i])
    order = np.argsort(rows * n + cols, kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
    data = np.concatenate([diag, -blocks, -blocks])[order]
    return bsr_matrix((data, cols[order], indptr), shape=(3 * n, 3 * n)).tocsr()


def static_displacements(points, springs, stiffness, forces, held) -> np.ndarray:
    """Linear static equilibrium of a spring network [m], shape (n, 3): ``K u = forces``
    (``forces`` [N], (n, 3)) with the displacement components where ``held`` ((n, 3) bool) is
    True kept at 0 exactly (their rows and columns replaced by the mean diagonal times the
    identity, their loads by 0: the system stays as well conditioned as K; a penalty of 1e6
    of the diagonal instead made the multigrid CG 8x slower).  Rigid motions the constraints
    leave free (e.g. sliding on a frictionless support) are fixed by a shift of 1e-9 of the
    mean diagonal, harmless for balanced loads.  Solved like the calibration
    (:func:`_solve`: multigrid-preconditioned CG), to a relative residual 1e-10."""
    from scipy.sparse import diags

    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    K = _stiffness_matrix(points, np.asarray(springs, dtype=np.int64).reshape(-1, 2),
                          np.asarray(stiffness, dtype=np.float64), n)
    mean = float(K.diagonal().mean())
    pin = np.asarray(held, dtype=bool).reshape(3 * n)
    free = diags((~pin).astype(np.float64))
    K = free @ K @ free + diags(1e-9 * mean + mean * pin)
    f = np.asarray(forces, dtype=np.float64).reshape(3 * n, 1) * (~pin)[:, None]
    return _solve(K, f, points, rtol=1e-10).reshape(n, 3)


def surface_points(points, springs, tets=None) -> np.ndarray:
    """Mask (n,) of the points on the body's surface.

    With tets: the corners of the faces that belong to one tet only.  Without: the points
    whose springs are lopsided, i.e. the mean of their unit spring directions is longer than
    0.35 (0 for a point surrounded evenly, 0.5 on a flat face).  Either way also the points
    whose springs cannot hold them in every direction (fewer than 4, or all in a plane).
    """
    n = points.shape[0]
    nrm, _ = _directions(points, springs)
    z = np.bincount(springs.ravel(), minlength=n)
    if tets is not None and len(tets):
        from ..geometry.tetra import boundary_faces

        mask = np.zeros(n, dtype=bool)
        mask[boundary_faces(tets, n).ravel()] = True
    else:
        total = np.zeros((n, 3))
        for c in range(3):
            total[:, c] = (np.bincount(springs[:, 0], nrm[:, c], n)
                           - np.bincount(springs[:, 1], nrm[:, c], n))
        mask = np.linalg.norm(total, axis=1) > 0.35 * np.maximum(z, 1)  # lopsided
    # springs that do not span 3D (a point on a thin sheet or strand) cannot hold the point in
    # every direction: treat it as surface (held), or the relaxation solve would be singular
    scatter = np.zeros((n, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            w = nrm[:, a] * nrm[:, b]
            scatter[:, a, b] = scatter[:, b, a] = (np.bincount(springs[:, 0], w, n)
                                                   + np.bincount(springs[:, 1], w, n))
    flat = np.linalg.eigvalsh(scatter)[:, 0] < 0.05 * np.maximum(z, 1)
    return mask | flat | (z < 4)


def inner_points(points, surface, skin: float) -> np.ndarray:
    """Mask (n,) of the points farther than ``skin`` [m] from every ``surface`` point."""
    from scipy.spatial import cKDTree

    n = points.shape[0]
    if not surface.any():
        return np.ones(n, dtype=bool)
    dist, _ = cKDTree(points[surface]).query(points)
    return dist > skin


def _strain_forces(points, springs, stiffness):
    """Xi (3n, 6): force on each point per unit affine Voigt strain (engineering shear).  A
    spring's length changes by ``L a . e`` (a as in :func:`virial_stiffness`), its tension by
    ``k L a . e``; the tension pulls its first point along +n and its second along -n."""
    n = points.shape[0]
    nrm, length = _directions(points, springs)
    a = np.stack([nrm[:, i] * nrm[:, j] for i, j in _VOIGT], axis=1)
    tension = (stiffness * length)[:, None] * a
    xi = np.zeros((3 * n, 6))
    for c in range(3):
        f = tension * nrm[:, c:c + 1]
        for v in range(6):
            xi[c::3, v] = (np.bincount(springs[:, 0], f[:, v], n)
                           - np.bincount(springs[:, 1], f[:, v], n))
    return xi


def _rigid_modes(points) -> np.ndarray:
    """The six rigid motions of ``points`` [m] (n, 3) as displacement columns (3n, 6):
    translations along x, y, z, then small rotations about the centroid's x, y, z axes."""
    p = np.asarray(points, dtype=np.float64)
    p = p - p.mean(axis=0)
    B = np.zeros((3 * p.shape[0], 6))
    for c in range(3):
        B[c::3, c] = 1.0
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    B[1::3, 3], B[2::3, 3] = -z, y
    B[0::3, 4], B[2::3, 4] = z, -x
    B[0::3, 5], B[1::3, 5] = -y, x
    return B


def _gs_sweep_py(indptr, indices, data, b, x, forward):  # pragma: no cover (compiled)
    """One Gauss-Seidel sweep over the rows of a CSR matrix for every column of ``x`` (n, m)
    at once, in place; rows in ascending (``forward``) or descending order."""
    n, m = x.shape
    acc = np.empty(m)
    for step in range(n):
        i = step if forward else n - 1 - step
        d = 0.0
        for c in range(m):
            acc[c] = b[i, c]
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if j == i:
                d += data[p]
            else:
                a = data[p]
                for c in range(m):
                    acc[c] -= a * x[j, c]
        if d > 0.0:
            for c in range(m):
                x[i, c] = acc[c] / d


_GS = []


def _gs_sweep():
    if not _GS:
        from numba import njit


        check()

        _GS.append(njit(cache=True, nogil=True)(_gs_sweep_py))
    return _GS[0]


class _Multigrid:
    """A symmetric V-cycle on several columns at once over the smoothed-aggregation hierarchy
    that pyamg builds (:func:`pyamg.smoothed_aggregation_solver`, near-null space: the rigid
    motions ``B``; Vanek, Mandel & Brezina 1996): one forward Gauss-Seidel sweep before the
    coarse correction, one backward after (so the cycle is symmetric positive definite, a
    valid CG preconditioner), a (shifted) Cholesky solve on the coarsest level."""

    def __init__(self, K, B):
        import pyamg

        # strength threshold 0.02 (pyamg's default 0: every connection strong): smaller
        # aggregates than 0 (12 -> 9 CG iterations on the 104k bunny's static solve at 1e-2),
        # coarse levels sparser than at 0.05 (which gave 392 entries per row on the second
        # level, and a V-cycle twice as dear): 13.4 s against 14.7 s (0) and 17.7 s (0.05)
        # for the whole calibration; improving the candidates by relaxation did not reduce
        # the iterations and cost a third of the setup
        # pyamg estimates spectral radii from np.random's global generator: seed it for the
        # setup (same hierarchy, same result every call) and give the caller's state back
        state = np.random.get_state()
        np.random.seed(0)
        try:
            ml = pyamg.smoothed_aggregation_solver(
                K.tobsr(blocksize=(3, 3)), B=B, max_coarse=500, improve_candidates=None,
                strength=("symmetric", {"theta": 0.02}))
        finally:
            np.random.set_state(state)
        self.levels = []
        for lvl in ml.levels[:-1]:
            A = lvl.A.tocsr()
            A.sort_indices()
            self.levels.append((A, lvl.P, lvl.R))  # P, R stay in BSR (3 x 3 blocks)
        # the coarsest level by Cholesky, shifted by 1e-10 of its mean diagonal so that a free
        # body's (singular: rigid motions) factors too; the caller projects the rigid motions
        # out of every preconditioned residual, so the shift only keeps the cycle positive
        # definite (a dense pseudo-inverse cost seconds on a 2,500-row coarse level)
        from scipy.linalg import cho_factor

        Ac = ml.levels[-1].A.toarray()
        Ac += 1e-10 * float(np.mean(np.diag(Ac))) * np.eye(Ac.shape[0])
        self.coarse = cho_factor(Ac, lower=True, check_finite=False)
        self.sweep = _gs_sweep()

    def __call__(self, b, level: int = 0):
        if level == len(self.levels):
            from scipy.linalg import cho_solve

            return cho_solve(self.coarse, b, check_finite=False)
        A, P, R = self.levels[level]
        x = np.zeros_like(b)
        self.sweep(A.indptr, A.indices, A.data, b, x, True)
        x += P @ self(np.ascontiguousarray(R @ (b - A @ x)), level + 1)
        self.sweep(A.indptr, A.indices, A.data, b, x, False)
        return x


def _solve(K, rhs, points, *, singular: bool = False, rtol: float = 1e-2) -> np.ndarray:
    """``K^-1 rhs`` for a symmetric positive (semi-)definite sparse stiffness ``K`` (3n, 3n,
    rows in point triples) of the ``points`` [m] (n, 3), and a few right-hand sides (columns).

    Conjugate gradients on all columns at once, preconditioned by algebraic multigrid
    (:class:`_Multigrid`: pyamg's smoothed aggregation with the rigid motions as near-null
    space); relative residual ``rtol`` per column.  ``singular``: ``K`` is a free-floating
    body's (its null space the rigid motions): the right-hand sides must be balanced (no net
    force or moment; their unbalanced part is projected out) and the returned displacements
    are the ones orthogonal to the rigid motions.  The results enter energies
    (``rhs^T K^-1 rhs``), whose error is of second order in the solution's: on the 104k-point
    bunny the calibrated stiffness at ``rtol`` 1e-2 differs from 1e-5's by 6e-6 (relative),
    for 4-12 instead of ~10-20 iterations.  Reductions are
    in a fixed order and BLAS runs on one thread, so the result does not depend on the thread
    count.  Columns that do not converge (a mechanism in the network) are solved by sparse LU,
    regularised (1e-9 of the mean diagonal) if singular."""
    from scipy.sparse import identity
    from scipy.sparse.linalg import splu
    from threadpoolctl import threadpool_limits

    K = K.tocsr()
    K.sort_indices()
    b = np.array(rhs, dtype=np.float64, copy=True).reshape(K.shape[0], -1)
    x = np.zeros_like(b)
    if K.shape[0] == 0:
        return x
    with threadpool_limits(limits=1, user_api="blas"):
        B = _rigid_modes(points)
        Q = np.linalg.qr(B)[0] if singular else None

        def project(v):
            return v - Q @ (Q.T @ v) if singular else v

        b = project(b)
        precondition = _Multigrid(K, B)

        def pcg(cols):
            bc = np.ascontiguousarray(b[:, cols])
            xc = np.zeros_like(bc)
            r = bc.copy()
            z = project(precondition(r))
            p = z.copy()
            rz = np.einsum("ij,ij->j", r, z)
            goal = rtol * np.linalg.norm(bc, axis=0)
            active = np.linalg.norm(r, axis=0) > goal
            for _ in range(500):
                if not active.any():
                    break
                q = K @ p
                pq = np.einsum("ij,ij->j", p, q)
                alpha = np.where(active & (pq > 0), rz / np.where(pq > 0, pq, 1.0), 0.0)
                xc += alpha * p
                r -= alpha * q
                z = project(precondition(r))
                rz_new = np.einsum("ij,ij->j", r, z)
                beta = np.where(active, rz_new / np.where(rz != 0, rz, 1.0), 0.0)
                p = z + beta * p
                rz = rz_new
                active &= np.linalg.norm(r, axis=0) > goal
            x[:, cols] = xc
            return active

        # the columns in two fixed halves, solved side by side (the sweeps and sparse products
        # release the GIL): the split never depends on the machine, nor do the results
        from concurrent.futures import ThreadPoolExecutor

        halves = np.array_split(np.arange(b.shape[1]), 2)
        with ThreadPoolExecutor(max_workers=2) as pool:
            active = np.concatenate(list(pool.map(pcg, halves)))
        if active.any():
            A = K.tocsc()
            try:
                lu = splu(A)
            except RuntimeError:
                lu = splu((A + 1e-9 * float(K.diagonal().mean()) * identity(A.shape[0])).tocsc())
            x[:, active] = lu.solve(b[:, active])
        return project(x)


def _relaxation(points, springs, stiffness, held) -> np.ndarray:
    """``Xi_free^T K_free^-1 Xi_free`` [N m], 6 x 6: the energy the free points (``~held``)
    give back by relaxing from the affine positions while the ``held`` points stay affine."""
    n = points.shape[0]
    xi = _strain_forces(points, springs, stiffness)
    dof = np.repeat(~held, 3)
    K = _stiffness_matrix(points, springs, stiffness, n)
    rhs = xi[dof]
    return rhs.T @ _solve(K[dof][:, dof], rhs, points[~held])


def relaxation_stiffness(points, springs, stiffness, volume, *, skin: float | None = None,
                         tets=None) -> np.ndarray:
    """Non-affine softening [Pa], 6 x 6 Voigt: ``(1/V_in) Xi_in^T K_in^-1 Xi_in``.

    ``Xi``: force on each point per unit affine strain; the surface points and those within
    ``skin`` [m] (default 0) of them are held affine, the others relax.  (Holding a thicker skin restrains
    the relaxation: measured on random networks, skin 0 matches tensile tests best.)
    ``V_in`` is the volume the inner points own (their share of ``volume``).
    """
    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    inner = inner_points(points, surface_points(points, springs, tets), skin or 0.0)
    if inner.sum() < 8:
        return np.zeros((6, 6))
    v_in = volume * inner.sum() / n
    return _relaxation(points, springs, stiffness, ~inner) / v_in


def kinematic_stiffness(points, springs, stiffness, tets, volume) -> np.ndarray:
    """Apparent stiffness [Pa], 6 x 6 Voigt, of a tet body whose boundary points follow a
    uniform strain (kinematic boundary conditions) and whose other points relax:
    ``(sum_s k L^2 a a^T - Xi^T K^-1 Xi) / V``.  An upper bound of the body's stiffness."""
    points = np.asarray(points, dtype=np.float64)
    C = virial_stiffness(points, springs, stiffness, volume)
    held = surface_points(points, springs, tets)
    if (~held).sum() < 1:
        return C
    return C - _relaxation(points, springs, stiffness, held) / volume


def static_compliance(points, springs, stiffness, tets) -> np.ndarray:
    """Apparent compliance [1/Pa], 6 x 6 Voigt, of a tet body loaded by a uniform stress on
    its boundary (static boundary conditions): each boundary face carries ``sigma n A`` split
    over its corners; the mean strain is ``(1/V) integral sym(u n) dA`` over the boundary (the
    divergence theorem, exact for the tets' linear interpolation), computed as the load's work
    ``f . u = V sigma : mean strain``.  Its inverse is a lower bound of the body's stiffness."""
    from ..geometry.tetra import boundary_faces, orient_tets

    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    tets = orient_tets(points, np.asarray(tets, dtype=np.int64))
    faces = boundary_faces(tets, n)
    p = points[faces]
    an = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # outward normal x area
    volume = float(np.abs(tet_signed_volumes(points, tets)).sum())
    load = np.zeros((3 * n, 6))
    for v, (i, j) in enumerate(_VOIGT):
        t = np.zeros_like(an)  # traction sigma n for the unit Voigt stress v
        t[:, i] += an[:, j]
        if i != j:
            t[:, j] += an[:, i]
        for c in range(3):
            load[c::3, v] = np.bincount(faces.ravel(), np.repeat(t[:, c] / 3.0, 3), n)
    # K is singular (rigid motions) but the load is balanced (no net force or moment on a
    # closed boundary), so conjugate gradients converge; rigid motions of u do not change the
    # symmetric mean strain.
    u = _solve(_stiffness_matrix(points, springs, stiffness, n), load, points,
               singular=True)
    # the work of the load is V sigma : mean strain (Hill-Mandel; exact for the faces' linear
    # interpolation), so S = load^T u / V: an energy, accurate to second order in u
    S = load.T @ u / volume
    return 0.5 * (S + S.T)


def youngs_from_stiffness(C: np.ndarray) -> float:
    """Mean over the axes of Young's modulus ``1 / S_aa`` [Pa] of a 6 x 6 Voigt stiffness."""
    S = np.linalg.inv(C)
    return float(np.mean(1.0 / np.diag(S)[:3]))


def network_youngs_modulus(body: Body, stiffness, *, relax: bool = True,
                           volume: float | None = None) -> float:
    """Effective Young's modulus [Pa] of ``body``'s springs with per-spring ``stiffness`` [N/m].

    Without ``relax``: the virial (affine) stiffness.  With it, bodies with tets: the mean
    (Hill) of the kinematic and static apparent stiffnesses of the whole body
    (:func:`kinematic_stiffness`, :func:`static_compliance`), which bound it from above and
    below; point clouds: the virial stiffness minus the relaxation of the inner points
    (:func:`relaxation_stiffness`), over the body's volume (tets, else ``body.volume``).

    ``volume`` [m^3]: the volume the network's stiffness is spread over (the virial and
    kinematic terms); ``None`` (default): :func:`point_volumes` summed (the spring tets'
    volume, else ``body.volume``).
    """
    from threadpoolctl import threadpool_limits

    # BLAS on one thread: its reductions' order (and the last bits) would follow the thread count
    with threadpool_limits(limits=1, user_api="blas"):
        return _network_youngs_modulus(body, stiffness, relax, volume)


def _network_youngs_modulus(body, stiffness, relax, volume):
    pts = np.asarray(body.points, dtype=np.float64)
    springs = np.asarray(body.springs, dtype=np.int64).reshape(-1, 2)
    k = np.asarray(stiffness, dtype=np.float64)
    if volume is None:
        volume = float(point_volumes(body).sum())
    if not relax:
        return youngs_from_stiffness(virial_stiffness(pts, springs, k, volume))
    tets = spring_tets(body)
    if tets is not None:
        upper = kinematic_stiffness(pts, springs, k, tets, volume)
        lower = np.linalg.inv(static_compliance(pts, springs, k, tets))
        return youngs_from_stiffness(0.5 * (upper + lower))
    C = virial_stiffness(pts, springs, k, volume)
    return youngs_from_stiffness(C - relaxation_stiffness(pts, springs, k, volume))


def calibrate_springs(body: Body, youngs_modulus: float, *, relax: bool = True,
                      point_volume=None) -> np.ndarray:
    """Per-spring stiffness [N/m], shape (k,), so that the network's Young's modulus is
    ``youngs_modulus`` [Pa] (see the module docstring for the method and its limits).

    ``relax``: calibrate against the relaxed network modulus (:func:`network_youngs_modulus`
    with ``relax=True``, the default); ``False``: against the affine (virial) one.
    ``point_volume`` [m^3], shape (n,): the volume each point owns when the body has no tets
    (e.g. :func:`jellysim.geometry.lattice.grid_point_volumes`); default: the body volume
    split evenly."""
    if not (np.isfinite(youngs_modulus) and youngs_modulus > 0):
        raise ParameterError(f"Young's modulus must be a positive number of Pa, got {youngs_modulus}")
    w = spring_weights(body, point_volume=point_volume)
    e1 = network_youngs_modulus(body, w, relax=relax, volume=None if point_volume is None
                                else float(np.sum(point_volume)))
    if not e1 > 0:
        raise ParameterError("the spring network is not rigid (its effective modulus is 0): "
                         "connect more points (a larger radius) or use tets")
    return w * (youngs_modulus / e1)
