"""Numba cell-grid search for all pairs within a radius, in CSR form (i < j, j sorted).

Used by :func:`jellysim.geometry.connect.radius_springs` for large point sets, where
``cKDTree.query_pairs`` (single-threaded, unordered output that then needs a global sort) is
the bottleneck.  Cells have edge ``r``, so every neighbour of a point lies in the 27 cells
around its own; the test is ``dx^2 + dy^2 + dz^2 <= r^2``, the same comparison cKDTree makes.
Two parallel passes (count, then fill) over points, then each point's short list is sorted.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from jellysim._numba_cache import check as _check_cache

_check_cache()


@njit(cache=True, parallel=True)
def _count_or_fill(points, r2, lo, inv_h, dims, cell_start, cell_points, fill, ptr, out):
    n = points.shape[0]
    counts = np.zeros(n, dtype=np.int64)
    for p in prange(n):
        px, py, pz = points[p, 0], points[p, 1], points[p, 2]
        cx = min(int((px - lo[0]) * inv_h), dims[0] - 1)
        cy = min(int((py - lo[1]) * inv_h), dims[1] - 1)
        cz = min(int((pz - lo[2]) * inv_h), dims[2] - 1)
        c = 0
        w = ptr[p] if fill else 0
        for ix in range(max(cx - 1, 0), min(cx + 2, dims[0])):
            for iy in range(max(cy - 1, 0), min(cy + 2, dims[1])):
                for iz in range(max(cz - 1, 0), min(cz + 2, dims[2])):
                    cell = (ix * dims[1] + iy) * dims[2] + iz
                    for t in range(cell_start[cell], cell_start[cell + 1]):
                        q = cell_points[t]
                        if q <= p:
                            continue
                        dx = points[q, 0] - px
                        dy = points[q, 1] - py
                        dz = points[q, 2] - pz
                        if dx * dx + dy * dy + dz * dz <= r2:
                            if fill:
                                out[w] = q
                                w += 1
                            c += 1
        counts[p] = c
        if fill:
            seg = out[ptr[p]:ptr[p] + c]
            seg.sort()
    return counts


def grid_pairs(points: np.ndarray, r: float, max_cells_per_point: float = 8.0):
    """CSR of all pairs within ``r``: (ptr (n+1,), j (k,)), or ``None`` if the grid would
    have more than ``max_cells_per_point`` cells per point (sparse data: use a kd-tree)."""
    points = np.ascontiguousarray(points, dtype=np.float64)
    n = points.shape[0]
    lo = points.min(axis=0)
    span = points.max(axis=0) - lo
    dims = np.maximum(np.floor(span / r).astype(np.int64) + 1, 1)
    if float(np.prod(dims.astype(np.float64))) > max_cells_per_point * n + 27:
        return None
    inv_h = 1.0 / r
    cell = np.minimum(((points - lo) * inv_h).astype(np.int64), dims - 1)
    cid = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    order = np.argsort(cid, kind="stable").astype(np.int64)
    cell_start = np.zeros(int(np.prod(dims)) + 1, dtype=np.int64)
    np.cumsum(np.bincount(cid, minlength=int(np.prod(dims))), out=cell_start[1:])
    r2 = float(r) * float(r)
    empty = np.zeros(0, dtype=np.int64)
    counts = _count_or_fill(points, r2, lo, inv_h, dims, cell_start, order, False,
                            np.zeros(n + 1, dtype=np.int64), empty)
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    out = np.empty(int(ptr[-1]), dtype=np.int64)
    _count_or_fill(points, r2, lo, inv_h, dims, cell_start, order, True, ptr, out)
    return ptr, out
