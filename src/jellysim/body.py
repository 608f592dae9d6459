"""Body: the geometry of a jello before it becomes a simulation :class:`~jellysim.model.Model`.

A :class:`Body` is what every builder produces (random box fields, points sampled inside a
surface mesh, the ``.jello`` file reader) and what :func:`jellysim.model.finalize` consumes.
It is plain data: arrays plus a few optional extras.  Nothing here knows about time stepping.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .params import REPORT_DENSITY, _user_stacklevel
from .errors import ParameterError


class _Default(float):
    """A default value that can be told apart from the same number passed on purpose."""


_DEFAULT_SIZE = _Default(0.1)
"""[m] :meth:`Body.from_mesh`'s default ``size``."""

__all__ = ["Body"]

_OWN = ("points", "connect", "seed", "density")
"""build_body's parameters that :meth:`Body.from_mesh` takes by name itself."""


def _check_values(pts: np.ndarray, springs: np.ndarray, body) -> None:
    """Refuse, naming the first bad row, what no later step could use: a point that is not
    finite, a spring or a tet / triangle corner that is not a point, a spring from a point to
    itself or given twice, and ``rest_length`` of the wrong shape (masses and stiffness:
    checked next)."""
    n = len(pts)
    bad = ~np.all(np.isfinite(pts), axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ParameterError(f"Body: points[{i}] is {pts[i].tolist()}: every point must be 3 "
                             "finite coordinates [m]")
    for name, idx in (("springs", springs), ("tets", body.tets), ("triangles", body.triangles)):
        if idx is None:
            continue
        a = np.asarray(idx)
        if a.size and (a.dtype.kind not in "iu" or a.min() < 0 or a.max() >= n):
            rows = a.reshape(len(a), -1) if a.ndim else a.reshape(1, -1)
            out = (np.any((rows < 0) | (rows >= n), axis=1) if a.dtype.kind in "iu"
                   else np.ones(len(rows), dtype=bool))
            i = int(np.flatnonzero(out)[0])
            raise ParameterError(f"Body: {name}[{i}] = {rows[i].tolist()}: every index must be "
                                 f"an integer point index in [0, {n - 1}] (the body has {n} "
                                 "points)")
    if len(springs):
        loop = springs[:, 0] == springs[:, 1]
        if loop.any():
            i = int(np.flatnonzero(loop)[0])
            raise ParameterError(f"Body: springs[{i}] = {springs[i].tolist()} joins a point to "
                                 "itself")
        key = springs[:, 0].astype(np.int64) * n + springs[:, 1]
        order = np.argsort(key, kind="stable")
        twice = np.flatnonzero(key[order][1:] == key[order][:-1])
        if len(twice):
            a, b = sorted((int(order[twice[0]]), int(order[twice[0] + 1])))
            raise ParameterError(f"Body: springs[{a}] and springs[{b}] both join points "
                                 f"{springs[a].tolist()} ((j, i) is the spring (i, j)): give "
                                 "each spring once, e.g. np.unique(np.sort(springs, axis=1), "
                                 "axis=0)")
    if body.rest_length is not None and np.shape(body.rest_length) != (len(springs),):
        raise ParameterError(f"Body: rest_length must have shape ({len(springs)},) [m], one per "
                             f"spring, got shape {np.shape(body.rest_length)} (or None: the "
                             "springs' start lengths)")


@dataclass(eq=False)   # (== is identity: comparing two bodies' arrays element-wise is ambiguous)
class Body:
    """Points and springs of one jello body (SI units throughout).

    Attributes
    ----------
    points:
        Rest positions [m], shape (n, 3), float64.
    springs:
        Spring end-point indices, shape (k, 2), integers, each row ``i < j`` (a row given as
        ``(j, i)`` is turned), rows unique (:func:`~jellysim.model.finalize` sorts them).
    rest_length:
        Spring rest lengths [m], shape (k,), float64, or ``None`` for "the distance between the
        end points in ``points``".
    stiffness:
        Per-spring stiffness [N/m], shape (k,), float64, or ``None`` for "the scene's ``k``".
    masses:
        Point masses [kg], shape (n,), float64, or ``None`` for "density x volume, split evenly".
    tets:
        Tetrahedra (indices into ``points``), shape (t, 4), int64, or ``None``.
    triangles:
        Surface triangles (indices into ``points``), shape (f, 3), int64, or ``None``.
    volume:
        Enclosed volume [m^3], or ``None`` when unknown.
    meta:
        Free-form provenance (builder name, parameters), JSON-serialisable values only.
    skin_vertices:
        Vertices [m] of the surface mesh the body was built from, placed as the body, shape
        (m, 3), float64, or ``None``: body files carry it so that a run of the file gets the
        smooth mesh as its skin (:func:`jellysim.skin.default_skin`).
    skin_faces:
        That mesh's triangles (indices into ``skin_vertices``), shape (f, 3), int64, or
        ``None`` (given together with ``skin_vertices``).
    skin_uv:
        The mesh file's texture coordinates [-] of each corner of ``skin_faces``, shape
        (f, 3, 2), float64, or ``None`` (:mod:`jellysim.geometry.texcoords`): exports of the
        run carry them.
    skin_material:
        For a mesh file of several materials, the one each skin face uses: an index into
        ``meta["skin_material_names"]``, shape (f,), int64, or ``None`` (:attr:`materials`).
    """

    points: np.ndarray
    springs: np.ndarray
    rest_length: np.ndarray | None = None
    stiffness: np.ndarray | None = None
    masses: np.ndarray | None = None
    tets: np.ndarray | None = None
    triangles: np.ndarray | None = None
    volume: float | None = None
    meta: dict = field(default_factory=dict)
    skin_vertices: np.ndarray | None = None
    skin_faces: np.ndarray | None = None
    skin_uv: np.ndarray | None = None
    skin_material: np.ndarray | None = None

    @property
    def materials(self):
        """:attr:`skin_material` with its names, as a
        :class:`~jellysim.geometry.texcoords.Materials` (``None`` without)."""
        from .geometry.texcoords import Materials

        n = 0 if self.skin_material is None else int(np.max(self.skin_material, initial=-1)) + 1
        names = list(self.meta.get("skin_material_names", []))
        return Materials.of(self.skin_material, names + [f"material_{k}" for k in
                                                         range(len(names), n)])

    def __post_init__(self):  # a list or a (3,) array for points was an error much later
        try:
            raw = np.asarray(self.points)
            pts = raw.astype(np.float64) if raw.dtype.kind in "iufO" else None
            springs = np.asarray(self.springs)
        except (TypeError, ValueError):
            raise ParameterError("Body: points must be an (n, 3) array of positions [m] and springs "
                             "a (k, 2) array of point indices") from None
        if pts is None:  # (bool, complex, text: not coordinates)
            raise ParameterError(f"Body: points must be real coordinates [m], shape (n, 3), "
                                 f"got an array of {raw.dtype}")
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise ParameterError(f"Body: points must have shape (n, 3) [m] with n >= 1, got "
                                 f"{pts.shape}")
        if springs.size == 0:
            springs = springs.reshape(0, 2).astype(np.int64)
        if springs.ndim != 2 or springs.shape[1] != 2 or springs.dtype.kind not in "iu":
            raise ParameterError(f"Body: springs must be a (k, 2) array of integer point indices, "
                             f"got shape {springs.shape} of {springs.dtype}")
        if self.volume is not None and not (np.isfinite(self.volume) and self.volume > 0):
            raise ParameterError(f"Body: volume must be > 0 [m^3] (or None: unknown), got "
                             f"{self.volume!r}")
        if len(springs) and np.any(springs[:, 0] > springs[:, 1]):  # (j, i): the spring
            springs = np.sort(springs, axis=1)                     # (i, j), as docs say
        self.points, self.springs = pts, springs
        _check_values(pts, springs, self)
        for name, shape, unit in (("masses", (len(pts),), "kg"),
                                  ("stiffness", (len(springs),), "N/m")):
            value = getattr(self, name)
            if value is not None and np.shape(value) != shape:
                raise ParameterError(f"Body: {name} must have shape {shape} [{unit}], one per "
                                 f"{'point' if name == 'masses' else 'spring'}, got shape "
                                 f"{np.shape(value)}" + (
                                     " (one value for all: finalize(body, point_mass=...))"
                                     if name == "masses" and np.ndim(value) == 0 else
                                     " (one value for all: finalize(body, stiffness=...))"
                                     if np.ndim(value) == 0 else ""))

        for name, value, low, unit in (("masses", self.masses, "> 0", "kg"),
                                       ("stiffness", self.stiffness, ">= 0", "N/m"),
                                       ("rest_length", self.rest_length, ">= 0", "m")):
            if value is None:
                continue
            v = np.asarray(value, dtype=np.float64).ravel()
            ok = np.isfinite(v) & ((v > 0) if low == "> 0" else (v >= 0))
            if not ok.all():
                i = int(np.flatnonzero(~ok)[0])
                raise ParameterError(f"Body: {name}[{i}] is {float(v[i])!r}: every value must be finite "
                                     f"and {low} [{unit}]" + (
                                         "" if name == "masses" else
                                         " (or None: the scene's k)" if name == "stiffness" else
                                         " (or None: the springs' start lengths)"))

    @classmethod
    def from_mesh(cls, mesh, *, size: float | None = _DEFAULT_SIZE, points: int = 5000,
                  connect: str = "marching", seed: int = 0, density: float | None = None,
                  base=None, up: str = "y", **options) -> "Body":
        """A jello body filling a surface mesh (a path, in any format
        :func:`~jellysim.geometry.load_mesh` reads, a loaded mesh, or a ``(vertices,
        faces)`` pair such as :func:`~jellysim.geometry.shapes.jelly_mould`'s).

        ``size``: the largest bounding-box extent [m] the mesh is scaled to (about the
        origin; default 0.1 m, said in a warning whenever that changes the mesh's own extent);
        ``None`` keeps the mesh's coordinates, which are then read as metres
        (as ``build_body``, the CLI and scenes do).
        Its defaults are for a jello body (``size=0.1``, ``connect="marching"``, and with
        ``connect="radius"`` points on the surface too, ``surface_samples=True``);
        :func:`jellysim.build.build_body`'s are the report's (the mesh's own size,
        ``connect="radius"``, points only inside), so the same mesh gives another body there
        unless these are given.  Without surface points a radius body rests and lands on its
        lowest inside points, rough at the spacing: a 10 cm gelatin ball of 800 points dropped
        3 cm rolled 71 mm sideways within 1.5 s, 11 mm with them (marching: 0.0 mm).
        ``points``: about this many points (``marching``: the grid warped onto the surface;
        ``radius``/``delaunay``: sampled inside, ``delaunay`` adding points on the surface).
        ``connect``: ``"marching"`` (default), ``"radius"``, ``"delaunay"`` or ``"tetgen"``.
        For the physical path (``physical_model``) ``"marching"`` gives the best-shaped tets
        and so the fewest substeps (a 6 cm ball: 48 per frame at 5 kPa, Delaunay 95, TetGen
        176) and no tet inverted at a frame's end on hard drops (a 5 kPa ball dropped
        50 cm); parts thinner than about a grid cell are lost (it warns below 80 % of the
        mesh's volume, or where the body spans under 0.9 of the mesh's width along an axis:
        ears, spouts): ``"delaunay"`` follows them.
        ``density``: [kg/m^3] (default :data:`~jellysim.params.REPORT_DENSITY`): the masses
        are density x the scaled body's enclosed volume (tet bodies: lumped on the corners).
        ``base``: if given, move the body so the bottom centre of its bounding box is here [m]
        (y is up).  ``up``: the mesh's axis that points up (``"z"`` for most CAD / STL files;
        ``"y"``, ``"x"``, or negated), turned to +y first.  Other keywords go to
        :func:`jellysim.build.build_body`.
        """
        import inspect
        from dataclasses import replace

        from .build import _mesh_of, build_body
        from .geometry.mesh import rotate_up

        takes = set(inspect.signature(build_body).parameters) - {"mesh", "size", "up"}
        unknown = sorted(set(options) - takes)
        if unknown:
            raise ParameterError(f"Body.from_mesh: unknown keyword {unknown[0]!r}; it takes "
                                 "size, points, connect, seed, density, base, up and "
                                 f"build_body's {', '.join(sorted(takes - set(_OWN)))}")
        if isinstance(points, (float, np.floating)) and float(points).is_integer():
            points = int(points)  # (3e3: a whole number of points)
        if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 4:
            raise ParameterError(f"Body.from_mesh: points must be a whole number of points "
                                 f"(>= 4), got {points!r}")
        if base is not None:
            b = np.asarray(base, dtype=object).ravel()
            try:
                ok = b.size == 3 and np.all(np.isfinite(b.astype(np.float64)))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ParameterError(f"Body.from_mesh: base must be 3 finite coordinates [m] "
                                     f"(x, y, z) of the body's bottom centre, got {base!r}")
        if size is not None and np.isfinite(size):
            _warn_size(float(size), "Body.from_mesh: size")
        m = _mesh_of(mesh, None)
        if size is _DEFAULT_SIZE:
            own = float(np.ptp(m.vertices, axis=0).max())
            if abs(own / float(size) - 1.0) > 1e-6:  # (an 8 cm mesh made 10 cm: 2x the mass)
                import warnings

                warnings.warn(f"Body.from_mesh: the mesh's largest extent, {own:.4g} in its own "
                              f"units, is scaled to {float(size):g} m (size's default); pass "
                              "size=... [m] for the body's size, or size=None to keep the "
                              "mesh's coordinates as metres", UserWarning,
                              stacklevel=_user_stacklevel())
        m = _mesh_of(m, None if size is None else float(size))
        if up != "y":
            m = replace(m, vertices=rotate_up(m.vertices, up))
        if base is not None:
            lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
            bottom = np.array([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])])
            shift = np.asarray(base, dtype=np.float64).reshape(3) - bottom
            m = replace(m, vertices=m.vertices + shift)
        if str(getattr(connect, "value", connect)).lower() == "radius":
            options.setdefault("surface_samples", True)  # flat faces to rest on: a jello's
        body = build_body(m, points=points, connect=connect, seed=seed,
                          density=REPORT_DENSITY if density is None else density, **options)
        if size is not None:
            body.meta["size"] = float(size)
        if density is not None:  # said when a material with another density is applied
            body.meta["density_given"] = float(density)
        return body

    @classmethod
    def box(cls, lower=(0.0, 0.0, 0.0), upper=(0.1, 0.1, 0.1), *, points: int = 1000,
            distribution: str = "grid", radius: float | None = None, seed: int = 0,
            name: str = "box") -> "Body":
        """A box of jello between corners ``lower`` and ``upper`` [m] (default: a 10 cm cube
        on the ground), as a scene's ``[body] type = "box"`` builds it.

        ``distribution = "grid"`` (default): a cubic lattice of about ``points`` *cells*,
        corners included (1000: 10^3 cells, 11^3 = 1,331 points; 343: 8^3 = 512 points),
        with its mirrored Kuhn tets (6 per cell: the physical path's best-shaped tets) and
        springs to every point within ``radius`` (default 1.8 spacings: the 26 nearest).
        ``"uniform"`` or ``"edge"`` (the report's random fields, ``seed``): ``points`` random
        points joined within ``radius`` (required), with the Delaunay tets of the points for
        ``Material(model="fem")``.  Masses come from the material (``physical_model(body,
        material)``), or for the report's springs from ``finalize(body, stiffness=...,
        density=...)``.
        """
        from .build import _radius_tets
        from .geometry.connect import radius_springs
        from .geometry.sampling import box_field

        corners = []
        for what, corner in (("lower", lower), ("upper", upper)):
            try:
                corners.append(np.asarray(corner, dtype=np.float64).reshape(3))
            except (TypeError, ValueError):
                raise ParameterError(f"{name}: {what} must be a corner (x, y, z) [m], three "
                                     f"numbers, got {corner!r}") from None
        lo, hi = corners
        if not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)) or not np.all(hi > lo):
            raise ParameterError(f"{name}: the box needs upper > lower in x, y and z [m], got "
                             f"lower = {lo.tolist()}, upper = {hi.tolist()}")
        if distribution not in ("grid", "uniform", "edge"):
            raise ParameterError(f"{name}: distribution must be 'grid', 'uniform' or 'edge', got "
                             f"{distribution!r}")
        if distribution == "grid":
            from .geometry.lattice import grid_points, grid_radius, grid_tets

            pts = grid_points(points, lo, hi)
            radius = grid_radius(points, lo, hi) if radius is None else radius
            tets, info = grid_tets(pts), None
        else:
            if radius is None:
                raise ParameterError(f"{name}: a random box ({distribution!r}) needs a spring "
                                 "radius [m] (radius=...), or distribution='grid'")
            pts = box_field(points, lo, hi, distribution=distribution, seed=seed)
            # Delaunay tets of the points (a box is convex: nothing to carve), for
            # Material(model='fem'); the springs stay the radius springs
            pts, tets, info = _radius_tets(pts, None, seed=seed, name=name)
        _warn_size(float(np.max(hi - lo)), f"{name}: the box")
        meta = {"builder": "box", "distribution": distribution, "seed": seed,
                "connect": "radius", "radius": radius}
        if info is not None:
            meta.update(tet_volume=info["tet_volume"], cloud_tets=info)
        return cls(points=pts, springs=radius_springs(pts, radius), tets=tets,
                   volume=float(np.prod(hi - lo)), meta=meta)

    @classmethod
    def from_points(cls, points, *, radius: float | None = None, neighbours: float = 24.0,
                    seed: int = 0, name: str = "points") -> "Body":
        """A body from a point cloud ``points`` [m], shape (n, 3), n >= 4, not all in a plane:
        springs to every point within ``radius`` [m] (default: chosen for ``neighbours`` on
        average) and the Delaunay tets of the points, slivers dropped, for the physical path
        (``physical_model(body, material)``).  The tets fill the cloud's convex hull: a
        concave shape's hollows would be filled, so give such a shape as a mesh
        (:meth:`from_mesh`).  The points are kept, in the order given (a few on the hull may
        lie in no tet: ``meta["cloud_tets"]["orphans"]`` counts them).  Random points give
        less even tets than a mesh's marching grid: an ellipsoid cloud dropped 8.5 cm turned
        one inside out for an instant (J -0.22, with a StabilityWarning) where a marching body
        of the same shape stayed above J 0.66 (session 28's re-trial).  API trial, session
        28: a cloud had no documented way to become a body with tets."""
        from .build import _radius_tets
        from .geometry.connect import choose_radius, radius_springs

        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 4:
            raise ParameterError(f"{name}: points must be an array (n, 3) [m] with n >= 4, got "
                                 f"shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ParameterError(f"{name}: points hold NaN or infinite coordinates")
        pts, tets, info = _radius_tets(pts, None, seed=seed, name=name)
        chosen = radius is None
        if chosen:
            radius = choose_radius(pts, neighbours, seed=seed)
        elif not (isinstance(radius, (int, float, np.number)) and np.isfinite(radius)
                  and radius > 0):
            raise ParameterError(f"{name}: radius must be a length > 0 [m], got {radius!r}")
        _warn_size(float(np.max(np.ptp(pts, axis=0))), f"{name}: the point cloud")
        meta = {"builder": "points", "connect": "radius", "radius": float(radius),
                "radius_chosen_for_neighbours": neighbours if chosen else None,
                "tet_volume": info["tet_volume"], "cloud_tets": info}
        return cls(points=pts, springs=radius_springs(pts, float(radius)), tets=tets,
                   volume=float(info["tet_volume"]), meta=meta)

    def __repr__(self) -> str:
        """One line: counts and size, not the arrays (``body.points`` etc. hold them)."""
        tets = 0 if self.tets is None else len(self.tets)
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        size = " x ".join(f"{e:.4g}" for e in hi - lo)
        how = self.meta.get("connect") or self.meta.get("builder") or ""
        if self.meta.get("distribution") == "grid":  # (its tets are the grid's own)
            how = f"grid box, {how} springs"
        volume = "unknown" if self.volume is None else f"{self.volume:.4g} m^3"
        return (f"Body({self.point_count} points, {len(self.springs)} springs, {tets} tets, "
                f"{size} m, volume {volume}" + (f", {how}" if how else "") + ")")

    @property
    def point_count(self) -> int:
        return int(self.points.shape[0])

    @property
    def spring_count(self) -> int:
        return int(self.springs.shape[0])


LARGE_BODY = 3.0
"""A body larger than this [m] is said (sizes are in metres: a slip of units is likely)."""


ABSURD_BODY = 1e6
"""A body larger than this [m] (1,000 km) is refused: a slip of units, and its distances'
squares would overflow the neighbour search (a 1e300 m box failed inside cKDTree)."""


def _warn_size(extent: float, what: str, limit: float = LARGE_BODY) -> None:
    if not extent <= ABSURD_BODY:
        raise ParameterError(f"{what} is {extent:g} m across: sizes are in metres (10 cm = "
                             f"0.1); more than {ABSURD_BODY:g} m is refused")
    if extent > limit:
        import warnings

        warnings.warn(f"{what} is {extent:g} m across: sizes are in metres (10 cm = 0.1); a "
                      f"jello this large is likely a slip of units", UserWarning,
                      stacklevel=_user_stacklevel())
