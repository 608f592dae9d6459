"""Partitioning the points among ranks, and the ghost (halo) layers each rank needs.

Pure numpy (pymetis only for ``method = "metis"``); no MPI here, so everything in this module
runs and is tested without mpi4py.

* :func:`partition_points` gives every point one owner rank: contiguous ranges along the
  Z-order (Morton) curve of the rest positions, or a METIS graph partition of the spring graph.
* :func:`halo_layers` gives, for one rank, the points at hop distance 1..depth from its owned
  points in the spring graph (its ghosts).  A rank that holds its owned points plus ``depth``
  ghost layers, with every spring between them, computes its owned points exactly through
  ``depth`` neighbour-reading passes without any communication (see :mod:`.local`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["partition_points", "halo_layers", "halo_stats", "point_graph", "METHODS"]

METHODS = ("morton", "metis")


def point_graph(n: int, spring_ij: np.ndarray):
    """Symmetric CSR adjacency of the spring graph: ``(xadj, adjncy)``, shapes (n + 1,) and
    (2 k,), int64; the neighbours of p are ``adjncy[xadj[p]:xadj[p + 1]]`` (sorted)."""
    ij = np.asarray(spring_ij, dtype=np.int64).reshape(-1, 2)
    src = np.concatenate([ij[:, 0], ij[:, 1]])
    dst = np.concatenate([ij[:, 1], ij[:, 0]])
    order = np.lexsort((dst, src))
    xadj = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=xadj[1:])
    return xadj, dst[order]


def partition_points(points: np.ndarray, spring_ij: np.ndarray, parts: int, *,
                     method: str = "morton") -> np.ndarray:
    """Owner rank of every point [-], shape (n,), int32, values in ``[0, parts)``.

    ``method = "morton"``: sort the rest positions [m], shape (n, 3), along the Z-order curve
    and cut the curve into ``parts`` ranges of (almost) equal point counts.
    ``method = "metis"``: METIS k-way partition of the spring graph (``pymetis``, the ``[mpi]``
    extra), balanced point counts, fewest cut springs.  Deterministic for given inputs.
    """
    points = np.asarray(points, dtype=np.float64)
    n = points.shape[0]
    parts = int(parts)
    if parts < 1:
        raise ValueError(f"parts must be >= 1, got {parts}")
    if parts > n:
        raise ValueError(f"cannot split {n} points among {parts} ranks: use at most {n} ranks")
    if parts == 1:
        return np.zeros(n, dtype=np.int32)
    if method == "morton":
        from ..geometry.sampling import morton_order

        order = morton_order(points)
        owner = np.empty(n, dtype=np.int32)
        owner[order] = (np.arange(n, dtype=np.int64) * parts // n).astype(np.int32)
        return owner
    if method == "metis":
        try:
            import pymetis
        except ImportError:
            raise ImportError("partition method 'metis' needs pymetis: "
                              "pip install 'jellysim[mpi]'") from None
        xadj, adjncy = point_graph(n, spring_ij)
        opts = pymetis.Options(seed=0)
        adjacency = pymetis.CSRAdjacency(adj_starts=xadj, adjacent=adjncy)
        _, membership = pymetis.part_graph(parts, adjacency=adjacency, options=opts)
        owner = np.asarray(membership, dtype=np.int32)
        if np.unique(owner).size != parts:
            raise ValueError(f"METIS left a rank without points ({n} points, {parts} ranks)")
        return owner
    raise ValueError(f"unknown partition method {method!r}; use one of {METHODS}")


def halo_layers(owner: np.ndarray, rank: int, xadj: np.ndarray, adjncy: np.ndarray,
                depth: int) -> list[np.ndarray]:
    """Ghost layers of ``rank``: list of ``depth`` sorted global index arrays, layer d holding
    the points at hop distance exactly d + 1 from the owned points (a breadth-first search
    over the spring graph ``(xadj, adjncy)``)."""
    n = owner.shape[0]
    seen = owner == rank
    frontier = np.flatnonzero(seen)
    layers = []
    for _ in range(int(depth)):
        if frontier.size == 0:
            layers.append(np.zeros(0, dtype=np.int64))
            continue
        starts, stops = xadj[frontier], xadj[frontier + 1]
        lens = stops - starts
        idx = np.repeat(starts - np.concatenate([[0], np.cumsum(lens)[:-1]]), lens) + \
            np.arange(lens.sum())
        nb = np.unique(adjncy[idx])
        nb = nb[~seen[nb]]
        seen[nb] = True
        layers.append(nb)
        frontier = nb
    assert len(layers) == depth and n == seen.shape[0]
    return layers


def halo_stats(points, spring_ij, parts: int, *, method: str = "morton",
               depth: int = 1) -> dict:
    """Sizes of a partition: owned points per rank, ghost points per rank (``depth`` layers),
    springs cut between ranks.  For the measurements in docs/mpi.md."""
    n = np.asarray(points).shape[0]
    owner = partition_points(points, spring_ij, parts, method=method)
    xadj, adjncy = point_graph(n, spring_ij)
    ij = np.asarray(spring_ij).reshape(-1, 2)
    ghosts = [int(sum(layer.size for layer in halo_layers(owner, r, xadj, adjncy, depth)))
              for r in range(parts)]
    return {"method": method, "parts": parts, "depth": depth, "points": int(n),
            "owned": np.bincount(owner, minlength=parts).tolist(), "ghosts": ghosts,
            "ghosts_total": int(sum(ghosts)),
            "cut_springs": int(np.count_nonzero(owner[ij[:, 0]] != owner[ij[:, 1]]))}
