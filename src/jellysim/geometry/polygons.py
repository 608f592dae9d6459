"""Polygon faces of a mesh file split into triangles: fans where convex, ear clipping where not.

A fan from a polygon's first corner is right only when the polygon is convex: across a
concave outline (an L-shaped cap) some fan triangles lie outside the polygon and overlap the
others, so the surface intersects itself (TetGen refuses it) or, where a fan triangle comes
out collinear and is dropped as zero-area, opens a crack (session 26's hostile-mesh trial: an
L and a T prism).  :func:`triangulate` keeps fans for convex polygons (all of a file's quads,
usually, and the fast path) and splits the others with mapbox's earcut on the polygon's plane,
each triangle wound as the polygon is.  OBJ files are read by trimesh, which fans every
polygon: :func:`obj_source` gives it the file's text with those split here instead (unless
the file has texture coordinates or materials, which trimesh's own reading keeps: then the
loader says which line is concave).
"""
from __future__ import annotations

import numpy as np

__all__ = ["triangulate", "first_concave_obj_face", "split_concave_obj", "obj_source", "convex"]


def _newell(p: np.ndarray) -> np.ndarray:
    """Polygons' normals (not unit) by Newell's method, robust for any simple polygon:
    ``p`` (..., k, 3) -> (..., 3)."""
    q = np.roll(p, -1, axis=-2)
    return np.stack([np.sum((p[..., 1] - q[..., 1]) * (p[..., 2] + q[..., 2]), axis=-1),
                     np.sum((p[..., 2] - q[..., 2]) * (p[..., 0] + q[..., 0]), axis=-1),
                     np.sum((p[..., 0] - q[..., 0]) * (p[..., 1] + q[..., 1]), axis=-1)],
                    axis=-1)


def convex(p: np.ndarray) -> np.ndarray:
    """Whether each polygon of ``p`` (..., k, 3) turns the same way at every corner (a fan
    then covers it exactly): bool (...)."""
    n = _newell(p)
    e = np.roll(p, -1, axis=-2) - p
    turns = np.einsum("...kc,...c->...k", np.cross(e, np.roll(e, -1, axis=-2)), n)
    scale = np.maximum(np.abs(turns).max(axis=-1), 1e-300)
    return np.all(turns >= -1e-12 * scale[..., None], axis=-1)


def triangulate(polys, vertices) -> np.ndarray:
    """Triangles (m, 3) int64 of ``polys`` (a list of index sequences into ``vertices``
    (n, 3)): each convex polygon as a fan from its first corner, each other one by earcut
    on its plane, wound as the polygon (in the polygons' order)."""
    v = np.asarray(vertices, dtype=np.float64)
    polys = [np.asarray(poly, dtype=np.int64) for poly in polys]
    fan = np.ones(len(polys), dtype=bool)
    sizes = np.array([len(q) for q in polys])
    for k in np.unique(sizes[sizes > 3]):  # (vectorised per polygon size)
        rows = np.flatnonzero(sizes == k)
        idx = np.stack([polys[r] for r in rows])
        ok = (idx.min(axis=1) >= 0) & (idx.max(axis=1) < len(v))
        fan[rows[ok]] = convex(v[idx[ok]])
    out = []
    for poly, is_fan in zip(polys, fan):
        if is_fan:
            out.extend((poly[0], poly[j], poly[j + 1]) for j in range(1, len(poly) - 1))
        else:
            out.extend(_earcut(poly, v[poly]))
    return np.asarray(out, dtype=np.int64).reshape(-1, 3)


def _earcut(idx: np.ndarray, p: np.ndarray) -> list:
    import mapbox_earcut

    n = _newell(p)
    drop = int(np.argmax(np.abs(n)))
    flat = np.ascontiguousarray(np.delete(p, drop, axis=1), dtype=np.float64)
    tri = np.asarray(mapbox_earcut.triangulate_float64(flat, np.array([len(p)], np.uint32)),
                     dtype=np.int64).reshape(-1, 3)
    if len(tri) != len(p) - 2:  # (earcut could not: a self-crossing outline) -> the fan
        return [(idx[0], idx[j], idx[j + 1]) for j in range(1, len(p) - 1)]
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    wrong = np.cross(b - a, c - a) @ n < 0
    tri[wrong] = tri[wrong][:, ::-1]
    return [tuple(idx[t]) for t in tri]


def _obj_polygons(lines):
    """(vertices (n, 3), polygons as 0-based index lists, their 1-based lines, which are not
    convex) of an OBJ file's ``lines``; ``None`` when it cannot be read (the loader says)."""
    verts, polys, where = [], [], []
    try:
        for k, line in enumerate(lines, start=1):
            words = line.split("#", 1)[0].split()
            if words and words[0] == "v":
                verts.append([float(w) for w in words[1:4]])
            elif words and words[0] == "f" and len(words) > 4:
                idx = [int(w.split("/")[0]) for w in words[1:]]
                polys.append([i - 1 if i > 0 else len(verts) + i for i in idx])
                where.append(k)
        v = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
        bad = np.zeros(len(polys), dtype=bool)
        sizes = np.array([len(q) for q in polys])
        for n in np.unique(sizes):
            rows = np.flatnonzero(sizes == n)
            bad[rows] = ~convex(v[np.array([polys[r] for r in rows])])
    except (ValueError, IndexError):
        return None
    return v, polys, where, bad


def first_concave_obj_face(lines, read=None) -> tuple[int, int] | None:
    """(1-based line, count) of the first polygon face of an OBJ file's ``lines`` that is not
    convex, and how many there are; ``None`` when every polygon is convex (or the file is
    unreadable: the loader says that).  ``read``: :func:`_obj_polygons` of them, if made."""
    read = _obj_polygons(lines) if read is None else read
    if read is None or not read[3].any():
        return None
    return read[2][int(np.argmax(read[3]))], int(read[3].sum())


def split_concave_obj(lines, read=None) -> str:
    """The OBJ file's text with each concave polygon face replaced by its triangles
    (:func:`triangulate`; each corner keeps its ``v/vt/vn`` token), for a reader that would
    fan it.  ``read``: :func:`_obj_polygons` of ``lines``, if made."""
    v, polys, where, bad = _obj_polygons(lines) if read is None else read
    out = list(lines)
    for poly, k, concave in zip(polys, where, bad):
        if not concave:
            continue
        tokens = lines[k - 1].split("#", 1)[0].split()[1:]
        at = {i: t for i, t in zip(poly, tokens)}
        out[k - 1] = "\n".join("f " + " ".join(at[int(i)] for i in tri)
                               for tri in triangulate([poly], v))
    return "\n".join(out) + "\n"


def obj_source(p, lines):
    """What trimesh should read for the OBJ file ``p`` (a ``Path``) of text ``lines``, and
    its first concave polygon face (line, count) or ``None``: with concave polygons and no
    texture coordinates or materials, the text with those split inside their outline
    (:func:`split_concave_obj`, as a file object); else the path as a string (trimesh fans
    the polygons).  Files without polygons of four or more corners are not parsed here."""
    import io

    if p.suffix.lower() != ".obj" or not any(
            w[:2] == "f " and len(w.split("#", 1)[0].split()) > 4 for w in lines):
        return str(p), None
    read = _obj_polygons(lines)
    concave = first_concave_obj_face(lines, read)
    if concave is None or any(w.split()[:1] in (["vt"], ["usemtl"]) for w in lines):
        return str(p), concave
    return io.BytesIO(split_concave_obj(lines, read).encode()), concave
