"""TetGen builder (constrained tetrahedralization of a closed surface) and surface-defect
counts, split from :mod:`jellysim.geometry.tetra` (import them from there).  Conventions: see
that module."""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from jellysim.body import Body
from jellysim.errors import BuildError
from jellysim.geometry.tetra import (DEFAULT_DENSITY, InsideFn, _as_faces, _as_vertices,
                                     _check_inside, _finish, _unique_rows_sorted,
                                     tet_signed_volumes)


# ----------------------------------------------------------------------------------------------
# TetGen
# ----------------------------------------------------------------------------------------------
def _winding_numbers(v: np.ndarray, f: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Generalized winding number of a few query points (exact solid-angle sum, O(n f))."""
    out = np.empty(q.shape[0], dtype=np.float64)
    for s in range(0, q.shape[0], 64):
        qq = q[s:s + 64]
        a = v[f[:, 0]][None] - qq[:, None]
        b = v[f[:, 1]][None] - qq[:, None]
        c = v[f[:, 2]][None] - qq[:, None]
        la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
        det = np.einsum("ijk,ijk->ij", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ijk,ijk->ij", a, b) * lc
               + np.einsum("ijk,ijk->ij", a, c) * lb + np.einsum("ijk,ijk->ij", b, c) * la)
        out[s:s + 64] = (2.0 * np.arctan2(det, den)).sum(axis=1) / (4.0 * math.pi)
    return out


def surface_defects(faces: np.ndarray) -> dict:
    """Edge-topology defects of a triangle surface (vertices already merged by position).

    Returns counts: ``boundary_edges`` (used by one face), ``nonmanifold_edges`` (used by more
    than two), ``misoriented_edges`` (two faces traverse it in the same direction) and
    ``degenerate_faces`` (a repeated vertex index).
    """
    f = np.asarray(faces, dtype=np.int64)
    degenerate = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    f = f[~degenerate]
    directed = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    n = int(f.max()) + 1 if f.size else 0
    und = np.sort(directed, axis=1)
    _, _, cnt = _unique_rows_sorted(und, n, return_counts=True)
    _, _, dcnt = _unique_rows_sorted(directed, n, return_counts=True)
    return {
        "boundary_edges": int((cnt == 1).sum()),
        "nonmanifold_edges": int((cnt > 2).sum()),
        "misoriented_edges": int((dcnt > 1).sum()),
        "degenerate_faces": int(degenerate.sum()),
    }


def _count_skipped_faces(path: Path) -> int:
    try:
        with open(path) as fh:
            return int(fh.readline().split()[0])
    except (OSError, ValueError, IndexError):
        return 0


def tetgen_body(vertices, faces, *, max_volume: float | None = None, quality: bool = True,
                closed_check: bool = True, inside_fn: InsideFn | None = None,
                holes=None, density: float = DEFAULT_DENSITY) -> Body:
    """Constrained tetrahedralization of a closed surface with TetGen.

    The tets fill the surface exactly (boundary conforming; with ``quality=True`` TetGen adds
    Steiner points, on the surface only inside its facets), so ``Body.volume`` equals the
    enclosed volume up to rounding.  Points = TetGen's nodes (the surface vertices first).

    Requirements: a closed, consistently oriented, non-self-intersecting surface.  Vertices
    are merged by exact position first.  With ``closed_check`` the edge topology is checked
    before TetGen runs (open boundary edges, non-manifold edges, inconsistent orientation,
    degenerate faces); TetGen itself reports self-intersections.  Every failure is a
    :class:`~jellysim.errors.BuildError` naming the defect and suggesting
    ``connect="delaunay"`` (which only needs an inside test).

    Cavities: TetGen fills every region the surface encloses, including cavities (e.g. the
    inside of an inward-facing inner shell).  Each TetGen region (tets connected without
    crossing the surface) is therefore kept or dropped as a whole: by majority vote of
    ``inside_fn`` over its tets' centroids when ``inside_fn`` is given, otherwise by the
    generalized winding number of the surface at the centroid of the region's largest tet
    (nonzero rule, ``w > 0.5``, the same rule as libigl).  ``holes`` (points [m], (h, 3))
    are passed to TetGen as hole seeds in addition.

    Parameters
    ----------
    vertices, faces: the surface, (n, 3) float [m] and (f, 3) int.
    max_volume: TetGen's maximum tet volume [m^3] (``-a``), ``None`` for no limit.  TetGen's
        final mesh smoothing may leave a few tets somewhat (observed: < 2x) above it.
    quality: TetGen quality refinement (``-q``; radius-edge ratio <= 2).
    closed_check: check the edge topology before calling TetGen.
    inside_fn: optional point-in-mesh test to decide which regions are solid.
    holes: optional hole seed points.
    density: mass density [kg/m^3].
    """
    v = _as_vertices(vertices)
    f = _as_faces(faces, v.shape[0])
    if max_volume is not None and not (math.isfinite(float(max_volume)) and max_volume > 0):
        raise BuildError(f"max_volume must be a positive volume [m^3], got {max_volume!r}")
    # merge vertices by exact position; drop unused vertices
    uv, inv = np.unique(v, axis=0, return_inverse=True)
    f = inv.reshape(-1)[f]
    used = np.unique(f)
    remap = np.full(uv.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    v, f = uv[used], remap[f]

    hint = ("use the delaunay builder instead (points inside + an inside test: --connect "
            "delaunay, connect = 'delaunay' in a scene, connect=\"delaunay\" in Python)")
    if closed_check:
        d = surface_defects(f)
        bad = [f"{val} {key.replace('_', ' ')}" for key, val in d.items() if val]
        if bad:
            raise BuildError(
                "tetgen needs a closed, manifold, consistently oriented surface; this one has "
                + ", ".join(bad) + f"; repair the mesh or {hint}"
            )
    import importlib.util

    if importlib.util.find_spec("tetgen") is None:  # (the child process imports it to run it)
        raise BuildError(  # pragma: no cover - depends on the environment
            "tetgen_body needs the optional package 'tetgen' (pip install 'jellysim[mesh]'); "
            f"or {hint}")

    # TetGen runs in a child process: refusing a self-intersecting surface corrupts its heap
    # (tetgen 0.8.4), and the process that called it aborted later ("free(): invalid
    # pointer", exit 134: a notebook's kernel would die; session 26's hostile-mesh trial).
    # The child runs in a scratch directory, where TetGen writes the faces it found
    # intersecting (_skipped.face: their count goes into the message).
    options = dict(quality=quality, regionattrib=True,
                   maxvolume=float(max_volume) if max_volume is not None else -1.0,
                   fixedvolume=max_volume is not None,  # without it TetGen ignores maxvolume
                   nomergefacet=True,  # merged near-coplanar facets would move the surface
                   quiet=True, nowarning=True)
    holes = np.asarray(holes if holes is not None else np.empty((0, 3)), float).reshape(-1, 3)
    with tempfile.TemporaryDirectory(prefix="jellysim-tetgen-") as scratch:
        try:
            res = _tetrahedralize(Path(scratch), v, f, holes, options)
        except RuntimeError as exc:
            msg = str(exc)
            if "self-intersection" in msg:
                defect = "the surface intersects itself (TetGen: " + msg.strip()
                n_bad = _count_skipped_faces(Path(scratch) / "_skipped.face")
                defect += f"; {n_bad} faces involved)" if n_bad else ")"
            elif msg.startswith("it crashed"):  # (seen on a self-intersecting sphere)
                defect = ("TetGen crashed on it (" + msg[len("it crashed ("):].rstrip(")")
                          + "), as it does on some self-intersecting surfaces")
            elif "manifold" in msg:
                defect = "the surface is not a closed manifold (TetGen: " + msg.strip() + ")"
            else:
                defect = "TetGen failed: " + msg.strip()
            raise BuildError(f"tetgen could not tetrahedralize the surface: {defect}; "
                             f"{hint}") from None
    nodes = np.asarray(res[0], dtype=np.float64)
    elem = np.asarray(res[1], dtype=np.int64)
    attr = np.asarray(res[2]).reshape(elem.shape[0], -1)
    region = attr[:, 0] if attr.shape[1] else np.zeros(elem.shape[0])
    if elem.shape[0] == 0:
        raise BuildError(f"tetgen produced no tetrahedra; {hint}")

    cent = nodes[elem].mean(axis=1)
    vol = np.abs(tet_signed_volumes(nodes, elem))
    reg_ids, reg_of = np.unique(region, return_inverse=True)
    if inside_fn is not None:
        ins = _check_inside(inside_fn, cent, "tet centroids").astype(np.float64)
        frac = np.bincount(reg_of, weights=ins) / np.bincount(reg_of)
        solid = frac > 0.5
        rule = "inside_fn majority per region"
    else:
        order = np.lexsort((-vol, reg_of))
        first = order[np.searchsorted(reg_of[order], np.arange(reg_ids.size))]
        solid = _winding_numbers(v, f, cent[first]) > 0.5
        rule = "winding number > 0.5 per region"
    keep = solid[reg_of]

    meta = {
        "builder": "tetgen",
        "max_volume": None if max_volume is None else float(max_volume),
        "quality": bool(quality),
        "closed_check": bool(closed_check),
        "regions": int(reg_ids.size),
        "regions_dropped": int((~solid).sum()),
        "region_rule": rule,
        "holes": int(np.asarray(holes).reshape(-1, 3).shape[0]) if holes is not None else 0,
        "surface_vertices": int(v.shape[0]),
        "surface_faces": int(f.shape[0]),
    }
    return _finish(nodes, elem[keep], density, meta)


_CHILD = """
import json, os, sys
import numpy as np
import tetgen
d = np.load("in.npz")
tg = tetgen.TetGen(d["v"], d["f"])
for hole in d["holes"]:
    tg.add_hole(hole)
try:
    res = tg.tetrahedralize(**json.load(open("options.json")))
except RuntimeError as exc:  # (then out at once: TetGen's teardown may crash after it)
    sys.stderr.write(str(exc))
    sys.stderr.flush()
    os._exit(3)
np.savez("out.npz", *[np.asarray(r) for r in res[:3]])
sys.stdout.flush()
os._exit(0)
"""


def _tetrahedralize(scratch: Path, v, f, holes, options: dict):
    """TetGen's ``tetrahedralize(**options)`` on the surface ``(v, f)`` in a child process
    working in ``scratch``: its (nodes, tets, attributes), or a ``RuntimeError`` with TetGen's
    message (or the child's end, if it crashed)."""
    import json
    import subprocess
    import sys

    np.savez(scratch / "in.npz", v=np.asarray(v, np.float64), f=np.asarray(f, np.int32),
             holes=holes)
    (scratch / "options.json").write_text(json.dumps(options))
    run = subprocess.run([sys.executable, "-c", _CHILD], cwd=scratch, capture_output=True,
                         text=True)
    if run.returncode != 0:
        said = (run.stderr.strip().splitlines() or [f"exit status {run.returncode}"])[-1]
        raise RuntimeError(said if run.returncode == 3 else
                           f"it crashed (exit status {run.returncode}: {said})")
    with np.load(scratch / "out.npz") as out:
        return [out[f"arr_{i}"] for i in range(3)]
