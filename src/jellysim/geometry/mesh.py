"""Surface meshes: loading, welding, cleaning and a defects report.

:func:`load_mesh` reads OBJ, PLY, STL, OFF and GLB/GLTF through ``trimesh`` and VTK, VTU and VTP
through ``meshio`` (both imported inside the function, never at package import), then

1. splits polygons (quads) into triangles (fans where convex, else ear clipping:
   :mod:`.polygons`; an OBJ with UVs or materials is fanned by trimesh: a concave one is said),
2. welds vertices that have exactly the same position (``-0.0`` and ``0.0`` are the same),
3. drops vertices no face uses,
4. removes faces that repeat a vertex index, faces with zero area (collinear vertices, decided
   exactly) and duplicate faces (a face with the same three vertices as another, in the same or in
   the reversed orientation; of a group one face is kept, oriented like its neighbours).

Removing zero-area faces never changes the solid: they bound no volume, contribute no ray crossing
and no solid angle. They can only hide zero-width cracks, which then show up as boundary edges in
the report (and :func:`jellysim.geometry.inside` then uses the winding-number rule, which is
insensitive to zero-width cracks).

Every step is counted in :class:`MeshDefects`, whose :meth:`MeshDefects.describe` is what
``jellysim inspect`` prints.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jellysim.errors import MeshError
from jellysim.geometry import texcoords
from jellysim.geometry.duplicate_faces import remove_duplicates
from jellysim.geometry.polygons import obj_source, triangulate
from jellysim.params import _user_stacklevel
from jellysim.geometry.shells import _shell_of_faces, outward  # (outward: re-exported)

__all__ = ["Mesh", "MeshDefects", "MESH_SUFFIXES", "SHIPPED", "UP_AXES", "load_mesh", "outward",
           "rotate_up", "shipped"]

UP_AXES = {"y": ((1, 0, 0), (0, 1, 0), (0, 0, 1)), "z": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
           "x": ((0, -1, 0), (1, 0, 0), (0, 0, 1)), "-y": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),
           "-z": ((1, 0, 0), (0, 0, -1), (0, 1, 0)), "-x": ((0, 1, 0), (-1, 0, 0), (0, 0, 1))}
"""For each axis a mesh may have pointing up (CAD and STL files are often z-up), the rotation
(a proper one: faces keep their winding) that turns it to jellysim's +y up."""


def rotate_up(vertices, up: str = "y"):
    """``vertices`` [m] (n, 3) rotated so the mesh's ``up`` axis (:data:`UP_AXES`) is +y."""
    if up not in UP_AXES:
        raise MeshError(f"up must be one of {', '.join(repr(a) for a in UP_AXES)} (the mesh's "
                        f"axis that points up), got {up!r}")
    v = np.asarray(vertices, dtype=np.float64)
    return v if up == "y" else v @ np.asarray(UP_AXES[up], dtype=np.float64).T

_TRIMESH_SUFFIXES = {".obj", ".ply", ".stl", ".off", ".glb", ".gltf"}
_MESHIO_SUFFIXES = {".vtk", ".vtu", ".vtp"}
MESH_SUFFIXES = frozenset(_TRIMESH_SUFFIXES | _MESHIO_SUFFIXES)
"""The file name endings :func:`load_mesh` reads."""

WELD_REL = 1e-10
"""Default weld distance, relative to the bounding-box diagonal."""
SLIVER_REL = 1e-12
"""A face is degenerate when 2 x area <= SLIVER_REL x (longest edge)^2."""


@dataclass
class MeshDefects:
    """What :func:`load_mesh` found (and repaired) in a surface mesh.

    Counts refer to the file as read (after quads were split) unless said otherwise; the edge,
    shell, volume and watertightness entries describe the cleaned mesh that is returned.
    """

    welded_vertices: int = 0
    """Vertices merged into another vertex with exactly the same position."""
    unreferenced_vertices: int = 0
    """Vertices no face uses (dropped)."""
    repeated_index_faces: int = 0
    """Faces that use one vertex twice, after welding (removed)."""
    zero_area_faces: int = 0
    """Faces with three distinct but collinear vertices, decided exactly (removed)."""
    duplicate_faces: int = 0
    """Extra copies of a face with the same vertices and orientation (removed)."""
    reversed_duplicate_faces: int = 0
    """Extra copies of a face with the same vertices and the opposite orientation (removed)."""
    turned_faces: int = 0
    """Faces wound against their neighbours, turned to agree (:mod:`.orient`)."""
    boundary_edges: int = 0
    """Undirected edges used by exactly one face."""
    non_manifold_edges: int = 0
    """Undirected edges used by more than two faces."""
    inconsistent_edges: int = 0
    """Edges shared by two faces that traverse it in the same direction (orientation flips)."""
    shells: int = 0
    """Connected components (faces connected through shared vertices)."""
    volume: float = 0.0
    """Signed volume [mesh units^3] enclosed, sum over faces of det(a, b, c) / 6."""
    face_count: int = 0
    """Triangles in the cleaned mesh."""
    vertex_count: int = 0
    """Vertices in the cleaned mesh."""

    @property
    def watertight(self) -> bool:
        """Every edge is shared by exactly two faces that traverse it in opposite directions."""
        return (
            self.boundary_edges == 0
            and self.non_manifold_edges == 0
            and self.inconsistent_edges == 0
            and self.face_count > 0
        )

    def problems(self) -> list[str]:
        """Short phrases naming what keeps the mesh from being a closed oriented manifold."""
        out = []
        if self.boundary_edges:
            out.append(f"{self.boundary_edges} boundary edges")
        if self.non_manifold_edges:
            out.append(f"{self.non_manifold_edges} non-manifold edges")
        if self.inconsistent_edges:
            out.append(f"{self.inconsistent_edges} inconsistently oriented edges")
        return out

    def repairs(self) -> list[str]:
        """Short phrases naming the faces :func:`load_mesh` had to remove or turn."""
        out = []
        for count, what in ((self.duplicate_faces, "duplicate faces"),
                            (self.reversed_duplicate_faces, "reversed duplicate faces"),
                            (self.repeated_index_faces, "faces repeating a vertex"),
                            (self.zero_area_faces, "zero-area faces")):
            if count:
                out.append(f"{count} {what} removed")
        if self.turned_faces:
            out.append(f"{self.turned_faces} faces wound against their neighbours (turned)")
        return out

    def describe(self) -> str:
        """A human-readable multi-line report (what ``jellysim inspect`` prints)."""
        lines = [
            f"vertices / faces:        {self.vertex_count} / {self.face_count}",
            f"watertight:              {'yes' if self.watertight else 'no'}",
            f"shells:                  {self.shells}",
            f"volume (signed) [m^3]:   {self.volume:.6g}" + (
                "" if self.watertight else "  (an open surface encloses no volume: the "
                "divergence-theorem figure depends on where it is open; jellysim build "
                "estimates the inside by Monte Carlo)") + (
                "  (negative: the faces are wound inward, the mesh is inside out; the "
                "inside test does not mind, TetGen does)"
                if self.watertight and self.volume < 0 else ""),
            f"boundary edges:          {self.boundary_edges}",
            f"non-manifold edges:      {self.non_manifold_edges}",
            f"inconsistent edges:      {self.inconsistent_edges}",
            f"duplicate faces:         {self.duplicate_faces} (removed)",
            f"reversed duplicates:     {self.reversed_duplicate_faces} (removed)",
            f"repeated-index faces:    {self.repeated_index_faces} (removed)",
            f"zero-area faces:         {self.zero_area_faces} (removed)",
            f"faces turned to agree:   {self.turned_faces}",
            f"welded vertices:         {self.welded_vertices}",
            f"unreferenced vertices:   {self.unreferenced_vertices} (dropped)",
        ]
        return "\n".join(lines)


@dataclass
class Mesh:
    """A cleaned triangle surface mesh.

    Attributes
    ----------
    vertices:
        Vertex positions [mesh units], shape (n, 3), float64.
    faces:
        Vertex indices of each triangle, shape (m, 3), int64, counter-clockwise seen from outside
        for a correctly oriented closed mesh.
    path:
        The file the mesh came from, or ``None`` for :meth:`from_arrays`.
    defects:
        What was found and repaired, see :class:`MeshDefects`.
    uv:
        Texture coordinates of each face corner [-], shape (m, 3, 2), float64 (the file's,
        kept per corner across welding: :mod:`jellysim.geometry.texcoords`), or ``None``.
    materials:
        Which of the file's materials each face uses
        (:class:`~jellysim.geometry.texcoords.Materials`), for a file of several, or ``None``.
    """

    vertices: np.ndarray
    faces: np.ndarray
    path: Path | None = None
    defects: MeshDefects = field(default_factory=MeshDefects)
    uv: np.ndarray | None = None
    materials: texcoords.Materials | None = None

    @classmethod
    def from_arrays(
        cls, vertices, faces, *, name: str = "<arrays>", weld_tol: float = WELD_REL
    ) -> "Mesh":
        """Build a cleaned mesh from arrays: vertices (n, 3) float, faces (m, 3) or (m, 4) int."""
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces)
        if v.ndim != 2 or v.shape[1] != 3:
            raise MeshError(f"{name}: vertices must have shape (n, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] < 3 or (f.size and not np.issubdtype(f.dtype, np.integer)):
            raise MeshError(
                f"{name}: faces must be an (m, k>=3) integer array, got {f.shape} {f.dtype}"
            )
        tris = triangulate(list(f), v) if f.shape[1] > 3 else f.astype(np.int64)
        return _clean(v, tris, name, None, weld_tol)

    @property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounding box, shape (2, 3): min and max corner."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def diagonal(self) -> float:
        """Length of the bounding-box diagonal [mesh units]."""
        b = self.bounds
        return float(np.linalg.norm(b[1] - b[0]))


SHIPPED = "jellysim:"
"""A path starting so names a mesh shipped in jellysim/data/ (a scene works wherever copied)."""


def shipped(path) -> Path:
    """``path`` as a :class:`~pathlib.Path`; ``jellysim:NAME`` is the shipped mesh NAME
    (:class:`MeshError` when there is none of that name)."""
    text, data = str(path), Path(__file__).resolve().parents[1] / "data"
    if not text.startswith(SHIPPED):
        return Path(path)
    name = text[len(SHIPPED):]
    p = data / name
    if not name or "/" in name or "\\" in name or not p.is_file():
        have = sorted(f.name for f in data.iterdir() if f.suffix.lower() in MESH_SUFFIXES)
        raise MeshError(f"{text}: jellysim ships no mesh named {name!r}; it ships "
                        f"{', '.join(SHIPPED + h for h in have)}")
    return p


def load_mesh(path, *, weld_tol: float = WELD_REL) -> Mesh:
    """Read, weld, clean and validate a triangle surface mesh.

    Supported: ``.obj .ply .stl .off .glb .gltf`` (trimesh) and ``.vtk .vtu .vtp`` (meshio);
    ``jellysim:spot.obj`` is the mesh shipped with the package (:func:`shipped`).
    Raises :class:`jellysim.errors.MeshError` naming the file and the problem for a missing,
    empty or unparsable file, non-finite coordinates, or a file without (non-degenerate) faces.

    ``weld_tol`` is relative to the bounding-box diagonal: vertices closer than
    ``weld_tol * diagonal`` are merged (0 merges only identical positions). The default,
    1e-10, closes the cracks of float32 STL exports (0.0 next to -2.7e-16) and nothing else.
    """
    p = shipped(path)
    name = str(path) if str(path).startswith(SHIPPED) else str(p)
    if not p.exists():
        raise MeshError(f"{name}: file not found")
    if not p.is_file():
        raise MeshError(f"{name}: not a regular file")
    if p.stat().st_size == 0:
        raise MeshError(f"{name}: file is empty")
    suffix = p.suffix.lower()
    uv = materials = None
    if suffix in _TRIMESH_SUFFIXES:
        v, polys, (uv, materials) = _read_trimesh(p, name)
    elif suffix in _MESHIO_SUFFIXES:
        v, polys = _read_meshio(p, name)
    else:
        convert = (" (export it from your DCC tool as glTF .glb or OBJ, which keep its UVs)"
                   if suffix in (".fbx", ".blend", ".dae", ".3ds", ".max", ".ma", ".mb",
                                 ".usd", ".usda", ".usdc", ".usdz", ".abc") else "")
        raise MeshError(
            f"{name}: unsupported file type {suffix!r} "
            f"(supported: {', '.join(sorted(_TRIMESH_SUFFIXES | _MESHIO_SUFFIXES))}){convert}"
        )
    return _clean(v, polys, name, Path(name), weld_tol, uv, materials)  # (path: as given)


# --------------------------------------------------------------------------- readers


def _read_trimesh(p: Path, name: str):
    from .._interrupts import import_trimesh

    try:
        trimesh = import_trimesh()  # optional dependency, imported where used
    except ImportError:
        raise MeshError(f"{name}: reading {p.suffix.lower()} files needs the optional package "
                        "'trimesh': pip install 'jellysim[mesh]' (or convert the mesh to .vtk "
                        "or .vtu, which meshio reads)") from None
    try:
        # maintain_order keeps the OBJ's vertex list as written, so that vertices no face uses
        # are counted (and then dropped) here rather than silently by the loader
        kwargs = {"maintain_order": True} if p.suffix.lower() == ".obj" else {}
        lines = _lines(p) if p.suffix.lower() == ".obj" else []  # (read once: checks below)
        source, concave = obj_source(p, lines)  # (concave polygons split: trimesh fans them)
        if not isinstance(source, str):
            kwargs["file_type"] = "obj"
        with warnings.catch_warnings():  # (its texture code's NaN medians: not the user's)
            warnings.simplefilter("ignore", RuntimeWarning)
            loaded = trimesh.load(source, force="mesh", process=False, **kwargs)
    except Exception as exc:  # trimesh raises many different types
        where = _obj_problem(lines) if p.suffix.lower() == ".obj" else None
        if where is not None:
            raise MeshError(f"{name}:{where}") from None
        if isinstance(exc, ImportError):  # e.g. PIL for an OBJ's texture coordinates
            what = repr(exc.name) if exc.name else f"that is missing ({exc})"
            raise MeshError(f"{name}: reading this file needs the optional package {what}: "
                            "pip install 'jellysim[mesh]'") from None
        raise MeshError(f"{name}: could not parse the file ({type(exc).__name__}: {exc})") from exc
    where = _obj_problem(lines) if p.suffix.lower() == ".obj" else None
    if where is not None:  # e.g. 0-based face indices, which the loader wraps around silently
        raise MeshError(f"{name}:{where}")
    if concave and isinstance(source, str):  # (with UVs or materials: trimesh's fans kept)
        warnings.warn(f"{name}:{concave[0]}: {concave[1]} polygon face(s) not convex, read as "
                      "fans from their first corner, which overlap outside the outline (the "
                      "surface intersects itself: TetGen refuses it); triangulate them before "
                      "export (Blender: Triangulate Faces, Beauty)", UserWarning,
                      stacklevel=_user_stacklevel())
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshError(f"{name}: the file holds no triangle mesh (got {type(loaded).__name__})")
    v = np.asarray(loaded.vertices, dtype=np.float64)
    f = np.asarray(loaded.faces, dtype=np.int64)
    return v, f, texcoords.trimesh_corner_uv(trimesh, loaded, p, name)


def _lines(p: Path) -> list[str]:
    try:
        return p.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []


def _obj_problem(lines: list[str]) -> str | None:
    """The first of an OBJ file's ``lines`` that cannot be read, as ``"LINE: what, fix"``
    (1-based line and vertex numbers, as the format counts them), or ``None``."""
    count = 0
    for k, line in enumerate(lines, start=1):
        words = line.split("#", 1)[0].split()
        if not words:
            continue
        if words[0] == "v":
            try:
                xyz = [float(w) for w in words[1:4]]
            except ValueError:
                xyz = []
            if len(xyz) != 3:
                return (f"{k}: a vertex needs three numbers (v x y z), got {line.strip()!r}")
            if not all(abs(c) < 1e30 for c in xyz):  # (NaN, inf, 1e200: nothing finite to build)
                return (f"{k}: vertex {count + 1} has a non-finite or huge coordinate (NaN, "
                        f"inf or beyond 1e30: {line.strip()!r}): fix or remove it")
            count += 1
        elif words[0] == "f":
            if len(words) < 4:
                return f"{k}: a face needs at least three vertices, got {line.strip()!r}"
            for w in words[1:]:
                try:
                    i = int(w.split("/")[0])
                except ValueError:
                    return f"{k}: {w!r} is not a vertex number (f 1 2 3, or f 1/1/1 ...)"
                if not (1 <= i <= count or -count <= i <= -1):
                    return (f"{k}: face vertex {i} does not exist (the file has {count} "
                            f"vertices before this line; OBJ numbers them from 1)")
    return None


def _read_meshio(p: Path, name: str):
    if p.suffix.lower() == ".vtp":  # meshio reads .vtk and .vtu but not XML PolyData
        return _read_vtp(p, name)
    import meshio  # imported where used

    try:
        m = meshio.read(str(p))
    except Exception as exc:
        raise MeshError(f"{name}: could not parse the file ({type(exc).__name__}: {exc})") from exc
    v = np.asarray(m.points, dtype=np.float64)
    if v.ndim == 2 and v.shape[1] == 2:
        v = np.column_stack([v, np.zeros(len(v))])
    polys = []
    for block in m.cells:
        data = np.asarray(block.data)
        if block.type in ("triangle", "quad") or block.type.startswith("polygon"):
            polys.extend(list(data))
    tris = triangulate(polys, v) if polys else np.zeros((0, 3), np.int64)
    return v, tris


_VTK_TYPES = {
    "Int8": np.int8, "UInt8": np.uint8, "Int16": np.int16, "UInt16": np.uint16,
    "Int32": np.int32, "UInt32": np.uint32, "Int64": np.int64, "UInt64": np.uint64,
    "Float32": np.float32, "Float64": np.float64,
}


def _read_vtp(p: Path, name: str):
    """Minimal VTK XML PolyData reader: Points and Polys, ascii or inline base64 binary
    (optionally zlib-compressed). Appended data is not supported."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(p).getroot()
        if root.get("type") != "PolyData":
            raise ValueError(f"VTKFile type is {root.get('type')!r}, not 'PolyData'")
        order = "<" if root.get("byte_order", "LittleEndian") == "LittleEndian" else ">"
        header = np.dtype(order + ("u8" if root.get("header_type") == "UInt64" else "u4"))
        compressed = root.get("compressor") is not None
        pts, polys = [], []
        for piece in root.iter("Piece"):
            pts_arr = piece.find("Points/DataArray")
            if pts_arr is None:
                raise ValueError("a Piece has no Points")
            offset = sum(len(x) for x in pts)
            pts.append(_vtp_array(pts_arr, order, header, compressed).reshape(-1, 3))
            arrays = {a.get("Name"): a for a in piece.findall("Polys/DataArray")}
            if "connectivity" in arrays and "offsets" in arrays:
                conn = _vtp_array(arrays["connectivity"], order, header, compressed)
                offs = _vtp_array(arrays["offsets"], order, header, compressed)
                begin = np.concatenate([[0], offs[:-1]])
                polys.extend(conn[b:e] + offset for b, e in zip(begin, offs))
        v = np.concatenate(pts).astype(np.float64) if pts else np.zeros((0, 3))
    except Exception as exc:
        raise MeshError(f"{name}: could not parse the file ({type(exc).__name__}: {exc})") from exc
    return v, (triangulate(polys, v) if polys else np.zeros((0, 3), np.int64))


def _vtp_array(el, order: str, header: np.dtype, compressed: bool) -> np.ndarray:
    import base64
    import zlib

    dtype = np.dtype(order + np.dtype(_VTK_TYPES[el.get("type")]).str[1:])
    fmt = el.get("format", "ascii")
    text = (el.text or "").strip()
    if fmt == "ascii":
        return np.array(text.split(), dtype=np.float64).astype(dtype)
    if fmt != "binary":
        raise ValueError(f"DataArray format {fmt!r} is not supported (ascii or binary only)")
    raw = base64.b64decode(text)
    hs = header.itemsize
    if not compressed:
        nbytes = int(np.frombuffer(raw[:hs], header)[0])
        return np.frombuffer(raw[hs:hs + nbytes], dtype).copy()
    nblocks = int(np.frombuffer(raw[:hs], header)[0])
    # the header is base64-encoded separately from the blocks in VTK's writer: decode in two steps
    head_len = hs * (3 + nblocks)
    head_b64 = 4 * ((head_len + 2) // 3)
    head = np.frombuffer(base64.b64decode(text[:head_b64])[:head_len], header)
    sizes = head[3:]
    body = base64.b64decode(text[head_b64:])
    out, pos = [], 0
    for size in sizes:
        out.append(zlib.decompress(body[pos:pos + int(size)]))
        pos += int(size)
    return np.frombuffer(b"".join(out), dtype).copy()


# --------------------------------------------------------------------------- cleaning


def _clean(v: np.ndarray, f: np.ndarray, name: str, path: Path | None, weld_tol: float,
           corner_uv=None, materials=None) -> Mesh:
    d = MeshDefects()
    f = np.asarray(f, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        raise MeshError(
            f"{name}: no faces (nothing in the file could be read as a triangle or polygon)"
        )
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise MeshError(f"{name}: no vertices")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshError(f"{name}: face vertex index out of range (0..{len(v) - 1})")
    used = v[np.unique(f)]
    if not np.all(np.isfinite(used)):
        raise MeshError(f"{name}: non-finite (NaN or infinite) vertex coordinates")
    if np.abs(used).max() >= 1e30:  # (1e200 ended in a scipy traceback: a slip of units)
        raise MeshError(f"{name}: vertex coordinates up to {np.abs(used).max():.3g}: beyond "
                        "what the exact inside test and the builders handle (1e30); the mesh "
                        "is likely in the wrong units, or corrupt")

    # weld by exact position (+0.0 turns -0.0 into 0.0)
    used = np.zeros(len(v), bool)
    used[f.ravel()] = True
    d.unreferenced_vertices = int((~used).sum())
    vu = v[used] + 0.0
    old_to_used = np.cumsum(used) - 1
    uniq, inv = _weld(vu, weld_tol)
    d.welded_vertices = int(len(vu) - len(uniq))
    uv, src = texcoords.checked(corner_uv, len(f)), np.arange(len(f))   # (src: the file's face)
    f = inv[old_to_used[f]]
    v = uniq

    # repeated indices
    rep = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    d.repeated_index_faces = int(rep.sum())
    f, src, uv = f[~rep], src[~rep], None if uv is None else uv[~rep]
    # exact zero area
    zero = _degenerate(v, f)
    d.zero_area_faces = int(zero.sum())
    f, src, uv = f[~zero], src[~zero], None if uv is None else uv[~zero]
    # duplicates (the kept face of a group may be re-oriented: its UVs follow its corners)
    f_all = f
    f, d.duplicate_faces, d.reversed_duplicate_faces, kept = remove_duplicates(f)
    uv = None if uv is None else texcoords.align(f_all[kept], uv[kept], f)
    materials = None if materials is None else materials.rows(src[kept])
    if len(f) == 0:
        raise MeshError(f"{name}: no faces with non-zero area")

    # drop vertices that became unreferenced by face removal
    used = np.zeros(len(v), bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    v = v[used]
    f = remap[f].astype(np.int64)

    _edge_report(f, d)
    if d.inconsistent_edges:  # (a few flipped faces: wound to agree, then the rule is exact)
        from .orient import consistent_winding

        turn = consistent_winding(f)
        f[turn] = f[turn, ::-1]
        uv = None if uv is None or not turn.any() else np.where(turn[:, None, None],
                                                                uv[:, ::-1], uv)
        d.turned_faces = int(turn.sum())
        _edge_report(f, d)
    d.shells, shell = _shell_of_faces(f, len(v))
    from .shells import face_volumes_x6

    d.volume = float(face_volumes_x6(v, f, shell).sum() / 6.0)
    d.face_count = int(len(f))
    d.vertex_count = int(len(v))
    return Mesh(vertices=np.ascontiguousarray(v), faces=np.ascontiguousarray(f), path=path,
                defects=d, uv=uv, materials=materials)


def _weld(v: np.ndarray, rel_tol: float):
    """Merge vertices closer than rel_tol x diagonal (clusters joined transitively).

    Returns the unique positions (the lowest-index vertex of each cluster, or the exact position
    for rel_tol = 0) and the old -> new index map.
    """
    if rel_tol <= 0 or len(v) < 2:
        uniq, inv = np.unique(v, axis=0, return_inverse=True)
        return uniq, inv.reshape(-1)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    r = rel_tol * float(np.linalg.norm(v.max(0) - v.min(0)))
    pairs = cKDTree(v).query_pairs(r, output_type="ndarray") if r > 0 else np.zeros((0, 2), int)
    # identical positions are always merged, also when the diagonal is 0
    _, ex = np.unique(v, axis=0, return_inverse=True)
    ex = ex.reshape(-1)
    n = len(v)
    rows = np.concatenate([pairs[:, 0], np.arange(n)])
    cols = np.concatenate([pairs[:, 1], ex + n])
    g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(2 * n, 2 * n))
    _, lab = connected_components(g, directed=False)
    lab = lab[:n]
    # number clusters by their lowest vertex index; the representative is that vertex
    order = np.argsort(lab, kind="stable")
    first_of = np.full(lab.max() + 1, -1)
    first_of[lab[order[::-1]]] = order[::-1]
    reps = np.unique(first_of[lab])
    new_index = np.full(n, -1)
    new_index[reps] = np.arange(len(reps))
    inv = new_index[first_of[lab]]
    return v[reps], inv


def _degenerate(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Faces of (numerically) zero area: twice the area <= SLIVER_REL x (longest edge)^2.

    This catches exactly collinear vertices and slivers such as (a, midpoint(a, b), b) whose
    midpoint was rounded when written to the file (relative height ~1e-17).
    """
    if len(f) == 0:
        return np.zeros(0, bool)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    longest = np.max(
        np.stack([((b - a) ** 2).sum(1), ((c - b) ** 2).sum(1), ((a - c) ** 2).sum(1)]), axis=0
    )
    return cross <= SLIVER_REL * longest


def _edge_report(f: np.ndarray, d: MeshDefects) -> None:
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    forward = e[:, 0] < e[:, 1]
    und = np.sort(e, axis=1)
    _, inv, counts = np.unique(und, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    d.boundary_edges = int((counts == 1).sum())
    d.non_manifold_edges = int((counts > 2).sum())
    n_fwd = np.bincount(inv, weights=forward, minlength=len(counts))
    two = counts == 2
    d.inconsistent_edges = int((two & (n_fwd != 1)).sum())

