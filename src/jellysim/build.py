"""From a surface mesh to a jello body (report sections 4.2 and 4.3).

:func:`build_body` samples points inside a surface mesh (or uses its tetrahedralization) and
connects them with one of four spring builders:

=============  ==============================================================================
``radius``     the report's "implicit" builder: every pair at most ``r`` apart; ``r`` chosen for
               a target mean neighbour count when not given (reported in ``body.meta``);
               also tets for the tetrahedral elasticity (Delaunay of the points, carved,
               slivers dropped: :func:`~jellysim.geometry.tetra.cloud_tets`)
``marching``   the report's marching-tetrahedra grid: cubes of size ``h``, 6 Kuhn tets each
               (the report says "several tetrahedra"; six Kuhn tets is our reading)
``delaunay``   Qhull Delaunay of the sampled points + surface samples (vertices, sharp edges,
               faces), carved by the inside test, slivers dropped
``tetgen``     TetGen's constrained tetrahedralization of the surface itself (closed meshes)
=============  ==============================================================================

Mass: total = density x the volume the surface encloses, for every builder.  Tet bodies lump
each tet's mass on its corners and, where the tets do not fill the surface exactly (marching
grid: only whole cubes inside; Delaunay: carved hull), scale the lumped masses so the total is
density x enclosed volume (the tets' own volume stays in ``meta["tet_volume"]``).  Radius bodies
split density x enclosed volume evenly over the points (``Body.masses`` stays ``None``); their
tets (the convex hull of random points, less its hull slivers) fill a few percent less than the
enclosed volume (``meta["tet_volume"]``: 93 % for 2,000 uniform points in a cube, 97 % for
16,000) and do not set the masses or the spring calibration.  The enclosed volume is the surface's
signed volume for closed meshes (exact) and a Monte-Carlo estimate with the inside test for open
ones (:data:`VOLUME_SAMPLES` points, relative error about 1/sqrt(samples x fraction inside);
a warning says so).
"""
from __future__ import annotations

import math
import warnings
from enum import Enum
from pathlib import Path

import numpy as np

from .body import Body
from .errors import BuildError, did_you_mean
from .geometry.sampling import Sampling
from .geometry.tet_marching import aligned_edge, fit_height, marching_fill_said, marching_grid
from .params import REPORT_DENSITY
from .resources import check_body_memory

__all__ = ["Connect", "build_body", "body_stats", "enclosed_volume", "shell_overlap"]

VOLUME_SAMPLES = 400_000
SURFACE_GAP = 0.5
"""Delaunay with surface samples: sampled points closer to the surface than this many spacings
are dropped (they would make flat tets with the surface points)."""

FITTED_GRID_GAIN = (1.25, 1.05, 1.25)
"""``marching`` (``h`` not given): a grid aligned to the box's faces, or fitted to the mesh's
height, replaces the centred one when no shorter and its tets hold ``[0]`` times the volume,
or ``[1]`` times with at most ``[2]`` times the points (a 5 cm cube at 200 points: 1.11x).
A fitted one refused for too many points is built again at the asked count (82 -> 100 %)."""

RELAX_PASSES = 10
"""Default Lloyd passes of a ``delaunay`` body's interior points (with surface samples)."""

RELAXED_MIN_QUALITY = 0.25
"""A relaxed ``delaunay`` body also drops its tets below this quality
(:func:`~jellysim.geometry.tetra.tet_quality`) as long as they hold at most 0.2 % of its
volume (:func:`~jellysim.geometry.tetra.delaunay_body` step 6): about 0.5 % of a relaxed
body's tets; 0.15 left far more substep-level inversions on hard drops (docs/physics.md)."""


class Connect(str, Enum):
    """Spring builder."""

    RADIUS = "radius"
    MARCHING = "marching"
    DELAUNAY = "delaunay"
    TETGEN = "tetgen"


def _mesh_of(mesh, size: float | None = None):
    """A loaded :class:`~jellysim.geometry.mesh.Mesh`; with ``size`` scaled (about the
    origin) so its largest bounding-box extent is ``size`` [m]."""
    from dataclasses import replace

    from .geometry.mesh import Mesh, load_mesh

    if isinstance(mesh, (str, Path)):
        m = load_mesh(mesh)
    elif isinstance(mesh, Mesh):
        m = mesh
    elif isinstance(mesh, tuple) and len(mesh) == 2:  # (vertices, faces), e.g. jelly_mould()
        m = Mesh.from_arrays(*mesh)
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):  # trimesh and the like
        m = Mesh.from_arrays(mesh.vertices, mesh.faces)
    else:
        raise BuildError(f"mesh must be a file path, a Mesh, a (vertices, faces) pair or an "
                         f"object with .vertices and .faces, got {type(mesh).__name__}")
    if size is None:  # (the mesh as it is)
        return m
    if not (np.isfinite(size) and size > 0):
        raise BuildError(f"size must be a positive length in metres, got {size}")
    extent = float(np.ptp(m.vertices, axis=0).max())
    if not extent > 0:
        raise BuildError("the mesh has no extent to scale to a size")
    factor = float(size) / extent
    defects = replace(m.defects, volume=m.defects.volume * factor**3)
    return replace(m, vertices=m.vertices * factor, defects=defects)


def _inside_volume(mesh, query, seed: int) -> tuple[float, float]:
    """Seeded Monte-Carlo volume with the inside test: (volume, standard error) [m^3]."""
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    u = np.random.default_rng(seed).random((VOLUME_SAMPLES, 3))
    frac = float(np.mean(query.query(lo + u * (hi - lo))))
    box = float(np.prod(hi - lo))
    return frac * box, box * float(np.sqrt(max(frac * (1 - frac), 0.0) / VOLUME_SAMPLES))


def shell_overlap(mesh, query=None, *, seed: int = 0) -> tuple[bool, float, float] | None:
    """For a closed mesh: (do its shells overlap or nest, or its one shell cross itself, so
    that the inside rule disagrees with the signed volume?, the inside rule's volume, the
    signed volume).  ``None`` for an open mesh (nothing to compare)."""
    if not (d := mesh.defects).watertight:
        return None
    from .geometry.inside import InsideQuery

    query = InsideQuery(mesh) if query is None else query
    vol, err = _inside_volume(mesh, query, seed)
    signed = abs(float(d.volume))
    return abs(vol - signed) > 4.0 * err + 1e-3 * signed, vol, signed


def enclosed_volume(mesh, query=None, *, seed: int = 0) -> tuple[float, bool]:
    """(volume [m^3], exact?) enclosed by ``mesh`` as the inside test counts it: the signed
    volume when it is closed (exact), else, and also when its shells overlap or nest (or it
    crosses itself) so that the inside rule disagrees (:func:`shell_overlap`; warned), a
    seeded Monte-Carlo estimate over its bounding box with the inside test."""
    if mesh.defects.watertight:
        over = shell_overlap(mesh, query, seed=seed)
        if over is None or not over[0]:
            return abs(float(mesh.defects.volume)), True
        if getattr(query, "rule", None) != "winding":  # (winding asked: their union, as meant)
            warnings.warn(f"{getattr(mesh, 'path', None) or 'mesh'}: " + (
                f"its {n} shells overlap or nest" if (n := mesh.defects.shells) > 1 else
                "its surface passes through itself") + f": the inside rule encloses "
                f"{over[1]:.6g}, the signed volume says {over[2]:.6g}; the mass follows the "
                "inside rule, which counts a point inside an odd number of shells (where two "
                "overlap the body is hollow: rule 'winding', [body] rule or --rule, makes them "
                "one solid; or merge the parts into one surface, e.g. a boolean union in "
                "Blender)", UserWarning, stacklevel=2)
        return over[1], False
    from .geometry.inside import InsideQuery

    query = InsideQuery(mesh) if query is None else query
    return _inside_volume(mesh, query, seed)[0], False


def _warn_defects(m, name: str) -> None:
    fixed = m.defects.repairs()
    if fixed:
        warnings.warn(f"{name}: repaired on load: {', '.join(fixed)}", UserWarning, stacklevel=4)


def _rescale_masses(body: Body, density: float, volume: float) -> Body:
    """Scale tet-lumped masses so they total density x ``volume``."""
    tet_volume = float(body.volume)
    if body.masses is not None and tet_volume > 0:
        body.masses = body.masses * (volume / tet_volume)
    body.meta["tet_volume"] = tet_volume
    body.volume = volume
    return body


def build_body(mesh, *, points: int = 5000, connect: Connect | str = Connect.RADIUS,
               sampling: Sampling | str = Sampling.UNIFORM, radius: float | None = None,
               neighbours: float = 24.0, h: float | None = None,
               surface_vertices: bool | None = None, surface_samples: bool | None = None,
               density: float = REPORT_DENSITY,
               seed: int = 0, rule: str = "auto", epsilon: float | None = None,
               min_quality: float | None = None, max_volume: float | None = None,
               size: float | None = None, snap: bool = True,
               relax: int | None = None, up: str = "y") -> Body:
    """A jello :class:`~jellysim.body.Body` from a surface mesh.

    The defaults are the report's (the mesh's own size, ``connect="radius"``, uniform
    sampling), as a scene's ``[body]`` table has them without the gelatin preset;
    :meth:`jellysim.Body.from_mesh` defaults to a 0.1 m body on the ``"marching"`` grid (the
    physical path's best tets; with ``connect="radius"`` it adds ``surface_samples``), so the
    same mesh gives another body there unless ``size`` and ``connect`` are given.

    The mesh's coordinates are read as metres.  ``size`` scales it first (about the origin)
    so that its largest bounding-box extent is ``size`` metres; masses (density x enclosed
    volume) are those of the scaled body.
    The body keeps the (scaled) mesh as ``skin_vertices`` / ``skin_faces`` (and the file's
    UVs and materials, ``skin_uv``, ``skin_material``): written into body files, it is the
    smooth skin a run carries.

    Parameters
    ----------
    mesh: a path (any format :func:`~jellysim.geometry.load_mesh` reads), a loaded mesh, or
        a ``(vertices, faces)`` pair (such as :func:`~jellysim.geometry.shapes.jelly_mould`'s).
    size: largest bounding-box extent [m] after scaling (default: the mesh as it is).
    up: the mesh's axis that points up (``"z"`` for most CAD / STL files), turned to +y.
    points: number of points to sample inside (``radius``/``delaunay``: exactly this many
        before surface points are added; ``marching``/``tetgen``: a target that sets the
        grid size ``h`` / the maximum tet volume).
    connect: spring builder, see :class:`Connect`.
    sampling: how to place points (:class:`~jellysim.geometry.sampling.Sampling`).
    radius: connection radius [m] for ``radius`` (default: chosen for ``neighbours``).
    neighbours: target mean neighbour count when ``radius`` is not given.
    h: cube edge [m] for ``marching`` (default: (volume / points)^(1/3)).
    surface_vertices: add the mesh's vertices to the points so the faces are well defined
        (default: on for ``delaunay``, off for ``radius``).
    surface_samples: ``delaunay`` and ``radius``: put points on the surface about one spacing
        ``(volume / points)^(1/3)`` apart (its vertices, its sharp edges, its faces: see
        :func:`~jellysim.geometry.sampling.sample_surface`; the vertices are always among them,
        whatever ``surface_vertices`` says) and drop the sampled points closer
        than half a spacing to it, so the body's surface lies on the mesh with well-shaped tets
        (``delaunay``: on by default; ``False`` is the report's way, mesh vertices only, whose
        near-surface tets are slivers fanning out from a few vertices on coarse meshes such as
        a cube.  ``radius``: off by default, so the body has exactly ``points`` points, as the
        report's; turn it on for a physical body: without it the body has no flat faces and
        rests on its lowest points (a 10 cm gelatin cube on a plate sags 1.70x rho g L^2 / 2E
        instead of 1.10x, BENCHMARKS.md "Radius-builder sag")).
    density: [kg/m^3].
    seed: random seed.
    rule: inside rule (``auto``, ``parity``, ``winding``), see :func:`jellysim.geometry.inside`.
    epsilon, min_quality: Delaunay near-duplicate distance [m] and sliver threshold.
    max_volume: TetGen maximum tet volume [m^3] (default: volume / points).
    snap: ``marching``: warp the grid onto the surface (the nodes near it move onto it and
        the cubes it cuts keep their well-shaped tets, :func:`~jellysim.geometry.snap.
        warp_to_surface`), so the body fills the mesh; ``False`` keeps the report's staircase
        of whole inside tets.
    relax: ``delaunay``: passes of Lloyd-type relaxation of the sampled interior points before
        the tetrahedralization (:func:`~jellysim.geometry.sampling.relax_interior`; default
        :data:`RELAX_PASSES` with surface samples, 0 without: the report's random points).
        Relaxed points make far fewer flat tets, and the few left below
        :data:`RELAXED_MIN_QUALITY` are dropped too (within 0.2 % of the volume).  Measured
        (docs/physics.md section 0): a 600-point, 6 cm ball at 5 kPa dropped 50 cm ends frames
        with inverted tets unrelaxed (J -0.46) and none relaxed (frame ends >= 0.44; within
        a substep some relaxed balls still dip below 0 for an instant, and a relaxed cube or
        mould can still end a frame inverted: use ``marching`` for hard drops), and needs 93
        instead of 153 substeps per frame.
    """
    from ._forked import check as _check_fork

    _check_fork("build_body")  # (a forked pool worker: a clear error, not a hang)
    keep: dict = {}
    body = _build_body(mesh, points=points, connect=connect, sampling=sampling, radius=radius,
                       neighbours=neighbours, h=h, surface_vertices=surface_vertices,
                       surface_samples=surface_samples, density=density, seed=seed, rule=rule,
                       epsilon=epsilon, min_quality=min_quality, max_volume=max_volume,
                       size=size, snap=snap, relax=relax, keep=keep, up=up)
    if "mesh" in keep:  # the (scaled) mesh the body fills: its skin in body files
        from .geometry.texcoords import attach_skin

        attach_skin(body, keep["mesh"])
    body.meta["density"] = float(density)
    if size is not None:
        body.meta["size"] = float(size)
    name = str(getattr(keep.get("mesh"), "path", None) or "mesh")
    _say_parts(body, name)
    _say_point_count(body, name, connect, points, keep.get("mesh"))
    return body


def _say_point_count(body: Body, name: str, connect, points: int, mesh) -> None:
    """Warn when a ``delaunay`` body (all surface vertices kept: Spot, 500 asked, 3,206 made)
    or a radius one with surface samples has over twice the points asked (tetgen: below)."""
    connect = getattr(connect, "value", connect)
    radius = connect == "radius" and body.meta.get("surface_samples")
    if (connect != "delaunay" and not radius) or not points or body.point_count <= 2 * points:
        return
    why, fix = (f"the mesh's {len(mesh.vertices) if mesh is not None else 0:,} vertices are "
                "all kept", "a mesh with fewer vertices") if not radius else (  # (600 -> 3,297)
        "its surface samples, one spacing apart on the mesh, come on top of them: a slender or "
        "detailed shape has much surface for its volume", "surface_samples=False (exactly the "
        "points asked, the report's way)")
    warnings.warn(f"{name}: the {connect!r} body has {body.point_count:,} points for the "
                  f"{points:,} asked ({why}); for a coarser body use connect='marching' (its "
                  f"points follow points=) or {fix}", UserWarning, stacklevel=3)


def _say_parts(body: Body, name: str) -> None:
    """Warn when the body falls apart into pieces joined by no spring or tet: they do not
    collide with each other (there is no self-collision), so where they meet they pass through
    each other (session 14's trial: a ball beside a cube rolled into it, 1.9 cm deep, unsaid).
    Pieces of one point are the "no spring" warning's."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = body.point_count
    pairs = [np.asarray(body.springs, dtype=np.int64).reshape(-1, 2)]
    if body.tets is not None and len(body.tets):
        t = np.asarray(body.tets, dtype=np.int64)
        pairs += [t[:, [0, 1]], t[:, [0, 2]], t[:, [0, 3]]]
    e = np.concatenate(pairs)
    if n < 2 or not len(e):
        return
    _, label = connected_components(coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])),
                                               shape=(n, n)), directed=False)
    sizes = np.sort(np.bincount(label))[::-1]
    sizes = sizes[sizes > 1]
    if len(sizes) > 1:
        shown = ", ".join(str(k) for k in sizes[:5]) + (", ..." if len(sizes) > 5 else "")
        warnings.warn(f"{name}: the body is {len(sizes)} separate pieces ({shown} points) that "
                      "no spring or tet joins: they do not collide with each other (there is "
                      "no self-collision), so where they meet they pass through each other; "
                      "keep them apart, or join them into one closed surface", UserWarning,
                      stacklevel=3)


def _build_body(mesh, *, points, connect, sampling, radius, neighbours, h, surface_vertices,
                surface_samples, density, seed, rule, epsilon, min_quality, max_volume,
                size, snap=True, relax=None, keep=None, up="y") -> Body:
    from .geometry.connect import choose_radius, radius_springs
    from .geometry.inside import InsideQuery
    from .geometry.sampling import morton_order, relax_interior, sample_inside

    connect = _choice(Connect, connect, "connect")
    sampling = _choice(Sampling, sampling, "sampling")
    if surface_samples and connect not in (Connect.DELAUNAY, Connect.RADIUS):
        raise BuildError("surface_samples applies to connect='delaunay' or 'radius' only")
    if radius is not None and connect is not Connect.RADIUS:
        raise BuildError(f"radius (of the radius springs) applies to connect='radius' only, "
                         f"not {connect.value!r} (its springs are its tets' edges); remove it "
                         "or use connect='radius'")
    if h is not None and connect is not Connect.MARCHING:
        raise BuildError(f"h (the cube edge) applies to connect='marching' only, not "
                         f"{connect.value!r}; remove it")
    if not snap and connect is not Connect.MARCHING:
        raise BuildError(f"snap=False (the report's staircase grid) applies to "
                         f"connect='marching' only, not {connect.value!r}; remove it")
    if relax is not None:
        if isinstance(relax, bool) or not isinstance(relax, (int, np.integer)) or relax < 0:
            raise BuildError(f"relax must be a whole number of passes >= 0, got {relax!r}")
        if relax and connect is not Connect.DELAUNAY:
            raise BuildError(f"relax applies to connect='delaunay' only (got connect="
                             f"'{connect.value}'); remove it")
    if points < 4:
        raise BuildError(f"points must be >= 4, got {points}")
    if sampling is not Sampling.UNIFORM and connect in (Connect.MARCHING, Connect.TETGEN):
        raise BuildError(f"sampling={sampling.value!r} applies to connect='radius' or "
                         f"'delaunay' (their sampled points); connect='{connect.value}' places "
                         "its own (a grid / TetGen's): remove sampling")

    check_body_memory(points, neighbours=neighbours, tets=connect is not Connect.RADIUS,
                      what=f"build_body(points={points})")
    if not (np.isfinite(density) and density > 0):
        raise BuildError(f"density must be a positive number of kg/m^3, got {density}")
    m = _mesh_of(mesh, size)
    if up != "y":
        from dataclasses import replace

        from .geometry.mesh import rotate_up

        m = replace(m, vertices=rotate_up(m.vertices, up))
    name = str(m.path) if getattr(m, "path", None) else "mesh"
    from .geometry.mesh import outward

    m = outward(m, name)
    if keep is not None:
        keep["mesh"] = m
    _warn_defects(m, name)
    extent = float(np.ptp(m.vertices, axis=0).max())
    if size is None and not 1e-3 <= extent <= 10.0:
        warnings.warn(f"{name}: the mesh is {extent:.4g} m across (its coordinates are read as "
                      "metres): if it is in millimetres or another unit, scale it (size= in "
                      "Python, --size, [body] size = 0.1 for 10 cm)", UserWarning, stacklevel=3)
    if connect is Connect.TETGEN:
        from .geometry.tetra import tetgen_body

        vol = abs(float(m.defects.volume))
        query = None if m.defects.watertight else InsideQuery(m, rule=rule)
        body = tetgen_body(m.vertices, m.faces,
                           max_volume=max_volume if max_volume else vol / points,
                           inside_fn=None if query is None else query.query, density=density)
        body.meta.update(source=name, connect="tetgen")
        if body.point_count > 2 * points:
            e = m.vertices[m.faces] - m.vertices[m.faces[:, [1, 2, 0]]]
            edge = float(np.sqrt(np.einsum("ijk,ijk->ij", e, e)).min())
            why = (f"it keeps every vertex of the surface ({len(m.vertices)})"
                   if body.point_count < 2 * len(m.vertices) else
                   f"it keeps every vertex of the surface ({len(m.vertices)}, the shortest "
                   f"edge {edge * 1e3:.3g} mm) and adds points so the tets next to the small "
                   "triangles are well shaped")
            warnings.warn(
                f"{name}: connect='tetgen' made {body.point_count} points for points={points}: "
                f"{why}; small tets also shorten the physical path's substep.  Use connect="
                "'marching' (its points follow points=; 'delaunay' keeps every vertex too), "
                "or a coarser surface mesh", UserWarning, stacklevel=3)
        elif body.point_count < points / 2 and not max_volume:  # (scale trial: 10,466 for
            warnings.warn(  # 30,000, unsaid)
                f"{name}: connect='tetgen' made {body.point_count} points for points={points}: "
                f"points= sets its largest tet's volume (the mesh's / points), and TetGen's tets"
                " average a fraction of it; for more points give max_volume (m^3) smaller, or "
                "connect='marching' (its points follow points=)", UserWarning, stacklevel=3)
        return body
    query = InsideQuery(m, rule=rule)
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    volume, exact = enclosed_volume(m, query, seed=seed)
    if not exact and not m.defects.watertight:  # (closed, overlapping shells: warned above)
        warnings.warn(f"{name}: the surface is open, so its enclosed volume {volume:.6g} m^3 is a "
                      f"Monte-Carlo estimate ({VOLUME_SAMPLES} samples) with the "
                      f"{query.rule} rule", UserWarning, stacklevel=3)
    if volume <= 0:
        raise BuildError(f"{name}: the surface encloses no volume (no inside points found)")
    if connect is Connect.MARCHING:
        chosen = h is None
        if chosen:
            h = (volume / points) ** (1.0 / 3.0)
        body = _marching(m, query, h, density, snap, name)
        if chosen and snap and body.point_count > 1.1 * points:
            # the warped grid adds the nodes moved in from outside: a cube edge that makes
            # about ``points`` points in all
            h *= (body.point_count / points) ** (1.0 / 3.0)
            body = _marching(m, query, h, density, snap, name)
        if chosen and snap:
            # the grid is centred on the bounding box; one fitted to its height (cubic cells a
            # hair smaller, the bottom and top node layers just inside the mesh) can fill a
            # box-like shape that the centred grid misses by a cell per face (a 5 cm cube came
            # out 4 cm tall, its base 5 mm up): keep it where it fills far more of the mesh
            # and is no shorter (on Spot it is 5 % shorter: its hooves' tips are lost)
            big, small, more_points = FITTED_GRID_GAIN

            def better(other):  # far more of the mesh, or more for few more points; no shorter
                gain, more = other.volume / body.volume, other.point_count / body.point_count
                return (gain > big or (gain > small and more <= more_points)) and np.ptp(
                    other.points[:, 1]) >= (1 - 1e-4) * np.ptp(body.points[:, 1])

            aligned = aligned_edge(h, hi - lo)  # (its nodes reach all six faces of a box)
            if aligned != h and better(other := _marching(m, query, aligned, density, snap,
                                                           name)):
                body, edge = other, None  # (a 10 x 6 x 10 cm box at 800 points: 80 -> 100 %)
            else:
                edge = h
            for _ in range(2 if edge else 0):  # a fitted grid of too many points: once more
                fitted = _marching(m, query, fit_height(edge, float(hi[1] - lo[1])), density,
                                   snap, name)
                if better(fitted):
                    body = fitted
                    break
                gain = fitted.volume / body.volume
                if not gain > small or fitted.point_count <= more_points * body.point_count:
                    break
                edge = h * (fitted.point_count / body.point_count) ** (1.0 / 3.0)
        said = marching_fill_said(name, h, body.volume / volume,
                                  np.ptp(body.points, axis=0) / np.maximum(hi - lo, 1e-300))
        if said:
            warnings.warn(said, UserWarning, stacklevel=3)
        from .geometry.shells import joined_parts

        if m.defects.watertight and (joined := joined_parts(m.vertices, m.faces, body.points,
                                                            body.tets)):
            warnings.warn(f"{name}: {joined} tets of the marching grid (h = {h:.3g} m) join "
                          "separate parts of the mesh closer than a cell: they move as one "
                          "body; more points (a smaller h) or connect = 'delaunay' keep them "
                          "apart", UserWarning, stacklevel=3)
        return _rescale_masses(body, density, volume)
    try:
        pts = sample_inside(query.query, lo, hi, points, method=sampling, seed=seed, volume=volume)
    except ValueError as exc:
        raise BuildError(f"{name}: {exc}") from None
    add_surface = (connect is Connect.DELAUNAY) if surface_vertices is None else surface_vertices
    on_surface = (connect is Connect.DELAUNAY) if surface_samples is None else surface_samples
    if on_surface:
        from .geometry.sampling import sample_surface, surface_distance_fn

        spacing = (volume / points) ** (1.0 / 3.0)
        skin = sample_surface(m.vertices, m.faces, spacing, seed=seed)
        gap = SURFACE_GAP * spacing
        distance = surface_distance_fn(m.vertices, m.faces, spacing, seed=seed)
        inner = pts[distance(pts, 2.0 * gap) > gap]
        passes = (RELAX_PASSES if connect is Connect.DELAUNAY else 0) if relax is None else relax
        if passes:
            inner = relax_interior(inner, skin,
                                   lambda p: query.query(p) & (distance(p, 2.0 * gap) > gap),
                                   passes)
        pts = np.concatenate([skin, inner])
    else:
        passes = relax or 0
        if passes:
            fixed = m.vertices if add_surface else np.zeros((0, 3))
            pts = relax_interior(pts, fixed, query.query, passes)
        if add_surface:
            pts = _add_surface_vertices(pts, m.vertices)
    if connect is Connect.DELAUNAY:
        from .geometry.tetra import delaunay_body

        kw = {} if min_quality is None else {"min_quality": min_quality}
        if passes:
            kw["target_quality"] = RELAXED_MIN_QUALITY
        body = delaunay_body(pts, m.vertices, m.faces, query.query, epsilon=epsilon, seed=seed,
                             density=density, **kw)
        body.meta.update(source=name, connect="delaunay", sampling=sampling.value,
                         surface_samples=bool(on_surface), relax=int(passes))
        return _rescale_masses(body, density, volume)
    pts = pts[morton_order(pts)]
    pts, tets, tet_info = _radius_tets(pts, query.query, m.vertices, m.faces, seed=seed,
                                       name=name)
    chosen = radius is None
    if chosen:  # (averaged over the interior: the mesh's vertices may be far denser)
        radius = choose_radius(pts, neighbours, seed=seed, among=inner if on_surface else None,
                               reach_all=1.5)
    springs = radius_springs(pts, radius)
    deg = np.bincount(springs.ravel(), minlength=len(pts))
    if np.any(deg == 0):
        lonely = int(np.sum(deg == 0))
        warnings.warn(f"{name}: {lonely} of {len(pts)} points have no spring within r = "
                      f"{radius:.4g} m (raise radius or neighbours)", UserWarning, stacklevel=3)
    meta = {"source": name, "connect": "radius", "sampling": sampling.value, "seed": seed,
            "surface_samples": bool(on_surface),
            "radius": float(radius), "radius_chosen_for_neighbours": neighbours if chosen else None,
            "mean_neighbours": float(2 * len(springs) / len(pts)),
            "tet_volume": tet_info["tet_volume"], "cloud_tets": tet_info}
    return Body(points=pts, springs=springs, tets=tets, volume=volume, meta=meta)


def _marching(m, query, h, density, snap, name) -> Body:
    """The marching grid body of edge ``h`` [m], warped onto the surface with ``snap``."""
    try:
        body = marching_grid(m.vertices, m.faces, query.query, h=h, density=density, warp=snap)
    except BuildError as exc:  # (a 1 mm plate: name the file, and the builder that follows it)
        raise BuildError(f"{name}: {exc}; connect = 'delaunay' follows thin parts") from None
    body.meta.update(source=name, connect="marching", h=float(h), snapped=bool(snap))
    return body


def _choice(enum, value, what: str):
    """``enum(value)``, or a :class:`BuildError` naming the parameter and its choices."""
    try:
        return enum(value)
    except ValueError:
        names = [e.value for e in enum]
        raise BuildError(f"{what} must be one of {', '.join(repr(n) for n in names)}, got "
                         f"{value!r}{did_you_mean(value, names, '{!r}')}") from None


def _radius_tets(pts, inside_fn, vertices=None, faces=None, *, seed: int = 0,
                 name: str = "body") -> tuple[np.ndarray, np.ndarray, dict]:
    """(points, tets, info) of a radius body: :func:`~jellysim.geometry.tetra.cloud_tets` of its
    points (Delaunay, slivers dropped, carved by ``inside_fn``, ``None`` for a box), for the
    tetrahedral elasticity; the springs stay the radius springs.  Orphans (points in no tet,
    which would get no elastic force from the tets with ``[material] model = 'fem'``; rare)
    are kept: the body has the points asked for, and they keep their springs;
    ``info["orphans"]`` counts them."""
    from .geometry.tetra import cloud_tets

    if len(pts) < 4:  # (2 or 3 points: springs only; no tet spans them)
        return pts, np.zeros((0, 4), dtype=np.int64), {"tet_volume": 0.0, "orphans": len(pts)}
    try:
        tets, orphans, info = cloud_tets(pts, inside_fn, vertices, faces, seed=seed)
    except BuildError as exc:
        raise BuildError(f"{name}: tets of the radius body: {exc}") from None
    return pts, tets, info


def _add_surface_vertices(pts: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Sampled points plus the mesh vertices; sampled points closer to a vertex than a
    quarter of the median sample spacing are dropped (they would make near-degenerate tets)."""
    from scipy.spatial import cKDTree

    spacing = np.median(cKDTree(pts).query(pts, k=2)[0][:, 1]) if len(pts) > 1 else 0.0
    d, _ = cKDTree(vertices).query(pts, k=1)
    return np.concatenate([vertices, pts[d > 0.25 * spacing]])


def body_stats(body: Body, *, density: float = REPORT_DENSITY) -> dict:
    """Counts, degree and rest-length statistics, volume and mass of a body; for a body
    with tets also the volume they hold [m^3] and ``density`` x that [kg] (the mass the
    physical path lumps on the corners)."""
    n = body.point_count
    springs = np.asarray(body.springs)
    deg = np.bincount(springs.ravel(), minlength=n) if len(springs) else np.zeros(n, int)
    rest = (np.asarray(body.rest_length) if body.rest_length is not None else
            np.linalg.norm(body.points[springs[:, 1]] - body.points[springs[:, 0]], axis=1))
    if body.masses is not None:
        mass = float(np.sum(body.masses))
    elif body.volume is not None:
        mass = density * float(body.volume)
    else:
        mass = None
    q = (lambda a, f: float(f(a)) if len(a) else float("nan"))
    tet_volume = None
    if body.tets is not None and len(body.tets):
        t = np.asarray(body.tets)
        p0 = body.points[t[:, 0]]
        d = np.stack([body.points[t[:, c]] - p0 for c in (1, 2, 3)], axis=1)
        tet_volume = float(np.abs(np.linalg.det(d)).sum() / 6.0)
    return {
        "tet_volume": tet_volume,
        "tet_mass": None if tet_volume is None else density * tet_volume,
        "points": n, "springs": int(len(springs)),
        "tets": 0 if body.tets is None else int(len(body.tets)),
        "triangles": 0 if body.triangles is None else int(len(body.triangles)),
        "degree_min": int(deg.min()) if n else 0, "degree_mean": float(deg.mean()) if n else 0.0,
        "degree_max": int(deg.max()) if n else 0,
        "rest_length_min": q(rest, np.min), "rest_length_mean": q(rest, np.mean),
        "rest_length_max": q(rest, np.max),
        "volume": None if body.volume is None else float(body.volume), "mass": mass,
        "bounds": [body.points.min(axis=0).tolist(), body.points.max(axis=0).tolist()],
    }
