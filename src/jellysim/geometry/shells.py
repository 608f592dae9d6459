"""Shells of a closed mesh wound inward on their own.

:func:`jellysim.geometry.mesh.outward` turns a whole mesh that is inside out; a mesh of several
separate parts can also have ONE part wound inward (two files concatenated, one exported
inside out).  Its signed volume then subtracts that part, its skin shows the part inside out,
and the shell check (:func:`jellysim.build.shell_overlap`) mistakes it for overlapping shells.
:func:`outward_shells` turns each such part: a shell with a negative signed volume inside an
even number of other shells (inside an odd number it is a cavity, wound inward on purpose;
shells that overlap are left alone).  Whether a
shell encloses a point is its generalised winding number there (the solid angle it subtends
over 4 pi: 1 inside, 0 outside; Van Oosterom & Strackee, IEEE Trans. Biomed. Eng. 30, 1983).
"""
from __future__ import annotations

import numpy as np

__all__ = ["outward", "outward_shells", "winding_number"]

MAX_SHELLS = 256
"""Meshes of more shells are left as they are (the check is O(shells x faces))."""


def winding_number(vertices: np.ndarray, faces: np.ndarray, point) -> float:
    """Generalised winding number of the closed triangle surface ``faces`` (m, 3) over
    ``vertices`` (n, 3) at ``point`` (3,): 1 inside a shell wound outward, -1 inside one
    wound inward, 0 outside."""
    return float(_winding_many(np.asarray(vertices, dtype=np.float64), np.asarray(faces),
                               np.asarray(point, dtype=np.float64).reshape(1, 3))[0])


def face_volumes_x6(vertices: np.ndarray, faces: np.ndarray,
                    label: np.ndarray | None = None) -> np.ndarray:
    """Six times each triangle's signed volume [units^3] (f,): of the tetrahedron it spans
    with the centre of its shell's bounding box (``label``: each face's shell, from
    :func:`_shell_of_faces`; default: one box for all).  Their sum over a closed, outward
    shell is six times its enclosed volume (the divergence theorem; divide the sum, not each
    term: [-1, 1]^3 then gives exactly 8.0).  Taken about the box's centre, not the origin, so
    a mesh far from the origin keeps its digits (a 10 cm cube 100 km away summed about the
    origin came out 12x its volume, 1000 km away negative, and two shells far apart need a
    centre each); a mesh centred on the origin gets exactly the figures it had (an open
    surface's "volume" depends on that point)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if label is None or len(f) == 0:
        centre = 0.5 * (v.min(axis=0) + v.max(axis=0)) if len(v) else np.zeros(3)
        a, b, c = v[f[:, 0]] - centre, v[f[:, 1]] - centre, v[f[:, 2]] - centre
    else:
        count = int(label.max()) + 1
        tri = v[f]                                          # (f, 3, 3)
        lo = np.full((count, 3), np.inf)
        hi = np.full((count, 3), -np.inf)
        np.minimum.at(lo, label, tri.min(axis=1))
        np.maximum.at(hi, label, tri.max(axis=1))
        centre = (0.5 * (lo + hi))[label][:, None, :]
        tri = tri - centre
        a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    return np.einsum("ij,ij->i", a, np.cross(b, c))


def _shell_of_faces(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """(The number of shells, each face's shell (f,)): faces joined through shared edges.
    Two parts that touch at a vertex only (a bowtie) are two shells: a winding cannot turn
    from one to the other there, so each may be wound its own way."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(faces, dtype=np.int64)
    e = np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = e[:, 0] * max(int(n_vertices), 1) + e[:, 1]
    owner = np.repeat(np.arange(len(f)), 3)
    order = np.argsort(key, kind="stable")
    k, o = key[order], owner[order]
    same = k[1:] == k[:-1]                     # consecutive uses of one edge: faces joined
    g = coo_matrix((np.ones(int(same.sum())), (o[:-1][same], o[1:][same])),
                   shape=(len(f), len(f)))
    n, label = connected_components(g, directed=False)
    return int(n), label


def _probe_inside(v: np.ndarray, f: np.ndarray, label: np.ndarray, count: int) -> np.ndarray:
    """``inside[s, t]`` (count, count): is shell s's first face's centre inside shell t
    (either winding; False on the diagonal)."""
    # a face's centre, on shell s and off every other (a vertex may be shared: a bowtie)
    probe = np.array([v[f[np.argmax(label == s)]].mean(axis=0) for s in range(count)])
    inside = np.zeros((count, count), dtype=bool)
    for t in range(count):
        inside[:, t] = np.abs(_winding_many(v, f[label == t], probe)) > 0.5
    np.fill_diagonal(inside, False)
    return inside


def outward_shells(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, list]:
    """``faces`` with every separate shell that is wound inward turned outward, and the
    turned shells' signed volumes [mesh units^3] (empty when none was)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    count, label = _shell_of_faces(f, len(v))
    if count < 2 or count > MAX_SHELLS:
        return f, []
    vol = np.bincount(label, weights=face_volumes_x6(v, f, label), minlength=count) / 6.0
    inside = _probe_inside(v, f, label, count)
    turned, out = [], f.copy()
    for s in np.flatnonzero(vol < 0):
        holders = np.flatnonzero(inside[s])
        if inside[holders, s].any():
            continue  # overlapping shells: no telling which side is meant
        if len(holders) % 2:
            continue  # inside an odd number of shells: a cavity, wound inward as it should be
        # (an even number: a solid part, e.g. a yolk inside the cavity of a hollow ball)
        out[label == s] = out[label == s][:, [0, 2, 1]]
        turned.append(float(vol[s]))
    return out, turned


def outward(mesh, name: str = "mesh"):
    """``mesh`` with its faces wound outward: a consistently oriented mesh (no edge traversed
    the same way by its two faces) whose signed volume is negative (inside out, as some
    exporters write them) gets every face reversed, with a warning, so that TetGen, the
    winding-number inside test of open meshes and the skin (its normals in renders and
    exports) see it the right way out.  (For a closed mesh the parity inside test does not
    depend on the winding: its body's points do not change.)  Then each separate shell
    wound inward on its own (:func:`outward_shells`; a cavity stays as it is) is turned too,
    with a warning."""
    import warnings
    from dataclasses import replace

    from .texcoords import align

    d = mesh.defects
    if d.inconsistent_edges:
        return mesh
    if d.volume < 0:
        warnings.warn(f"{name}: its faces are wound inward (the mesh is inside out, signed "
                      f"volume {d.volume:.4g}): read turned outward (the file is left as it is)",
                      UserWarning, stacklevel=3)
        mesh = replace(mesh, faces=np.ascontiguousarray(mesh.faces[:, [0, 2, 1]]),
                       defects=replace(d, volume=-d.volume),
                       uv=None if mesh.uv is None else mesh.uv[:, [0, 2, 1]])
    faces, turned = outward_shells(mesh.vertices, mesh.faces) if d.watertight else (None, [])
    if turned:  # (one part of several wound inward: .shells)
        warnings.warn(f"{name}: {len(turned)} of its {d.shells} separate shells wound inward "
                      f"(signed volume {sum(turned):.4g}): read turned outward (the file is left as "
                      "it is)", UserWarning,
                      stacklevel=3)
        mesh = replace(mesh, faces=faces, uv=align(mesh.faces, mesh.uv, faces), defects=replace(
            mesh.defects, volume=mesh.defects.volume - 2.0 * sum(turned)))
    return mesh


def _winding_many(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """:func:`winding_number` of one closed surface at each of ``points`` (p, 3), in blocks of
    points that keep each temporary array near 2e5 entries (a few MB)."""
    block = max(1, 200_000 // max(len(faces), 1))
    out = np.empty(len(points))
    tri = vertices[faces]
    for s in range(0, len(points), block):
        p = points[s:s + block, None, :]
        a, b, c = (tri[None, :, k, :] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc
               + np.einsum("pfi,pfi->pf", a, c) * lb + np.einsum("pfi,pfi->pf", b, c) * la)
        out[s:s + block] = 2.0 * np.arctan2(det, den).sum(axis=1) / (4.0 * np.pi)
    return out


def joined_parts(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray,
                 tets: np.ndarray, *, max_work: float = 3e7) -> int:
    """How many of ``tets`` (t, 4) join body ``points`` (n, 3) inside two separate parts of
    the closed mesh (shells apart from each other, neither inside the other): a grid coarser
    than the gap between two parts fuses them into one body.  0 for one part, nested or
    overlapping shells, or a mesh too large to check (``max_work`` point x face tests)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    count, label = _shell_of_faces(f, len(v))
    if not 2 <= count <= 16 or len(points) * len(f) > max_work or len(tets) == 0:
        return 0
    if _probe_inside(v, f, label, count).any():  # nested or overlapping: not checked
        return 0
    part = np.full(len(points), -1)
    for t in range(count):
        part[np.abs(_winding_many(v, f[label == t], points)) > 0.5] = t
    outside = np.flatnonzero(part < 0)  # points snapped onto a surface (a hair outside it):
    if len(outside):                    # the shell of the nearest vertex or face centre
        from scipy.spatial import cKDTree

        sites = np.concatenate([v[f[:, 0]], v[f].mean(axis=1)])
        _, near = cKDTree(sites).query(points[outside])
        part[outside] = np.concatenate([label, label])[near]
    corner = part[np.asarray(tets, dtype=np.int64)]
    known = corner.min(axis=1) >= 0
    return int(np.sum(known & (corner.min(axis=1) != corner.max(axis=1))))
