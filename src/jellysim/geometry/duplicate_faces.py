"""Duplicate faces of a surface mesh: one face is kept per vertex set, oriented like its
neighbours (a step of :func:`jellysim.geometry.mesh.load_mesh`'s cleaning)."""
from __future__ import annotations

import numpy as np

__all__ = ["remove_duplicates"]


def remove_duplicates(f: np.ndarray):
    """``(faces, duplicates, reversed duplicates, kept)``: one face kept per vertex set,
    oriented like its neighbours; ``kept`` the kept faces' indices into ``f`` (increasing)."""
    key = np.sort(f, axis=1)
    _, first, inv, counts = np.unique(key, axis=0, return_index=True, return_inverse=True,
                                      return_counts=True)
    inv = inv.reshape(-1)
    if np.all(counts == 1):
        return f, 0, 0, np.arange(len(f))
    keep = np.zeros(len(f), bool)
    keep[first] = True
    dup_groups = np.flatnonzero(counts > 1)
    in_dup = np.isin(inv, dup_groups)
    # directed half-edges of faces outside duplicate groups
    others = f[~in_dup]
    half = {
        (int(a), int(b))
        for a, b in np.concatenate([others[:, [0, 1]], others[:, [1, 2]], others[:, [2, 0]]])
    }

    def score(tri):
        """+1 per edge whose reverse a neighbour traverses, -1 per edge a neighbour repeats."""
        s = 0
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            s += ((int(b), int(a)) in half) - ((int(a), int(b)) in half)
        return s

    n_same = n_rev = 0
    members_of = {}
    for idx in np.flatnonzero(in_dup):
        members_of.setdefault(int(inv[idx]), []).append(int(idx))
    out = f.copy()
    for members in members_of.values():
        ref = f[members[0]]
        tri = ref if score(ref) >= score(ref[::-1]) else ref[::-1]
        out[members[0]] = tri
        kept_parity = _perm_parity(tri)
        # of the k copies one is kept; each removed copy is a duplicate when it has the kept
        # orientation and a reversed duplicate otherwise
        n_kept_orient = sum(_perm_parity(f[m]) == kept_parity for m in members)
        n_same += max(n_kept_orient - 1, 0)
        n_rev += len(members) - n_kept_orient - (1 if n_kept_orient == 0 else 0)
    return out[keep], n_same, n_rev, np.flatnonzero(keep)


def _perm_parity(tri) -> int:
    a, b, c = (int(x) for x in tri)
    # even permutation of the sorted triple <=> cyclic rotation of (lo, mid, hi)
    lo = min(a, b, c)
    if lo == a:
        return 0 if b < c else 1
    if lo == b:
        return 0 if c < a else 1
    return 0 if a < b else 1
