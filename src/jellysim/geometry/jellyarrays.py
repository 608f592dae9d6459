"""Validation of a body's arrays, shared by the ``.jello`` and ``.npz`` readers and both writers
(:mod:`jellysim.geometry.jellyfile`): dtypes, shapes, finite values, index ranges, no repeated
index in a row, springs sorted and unique, positive masses, lengths and stiffnesses."""
from __future__ import annotations

import math

import numpy as np

from jellysim.errors import JelloFileError

__all__ = ["validate_arrays"]


def validate_arrays(src: str, points, springs, rest_length=None, stiffness=None, masses=None,
                    tets=None, triangles=None, volume=None, skin_vertices=None,
                    skin_faces=None, skin_uv=None, skin_material=None) -> dict:
    """Check body arrays; return them normalised (dtype, contiguous).  ``src`` names the file."""

    def err(array: str, msg: str) -> JelloFileError:
        return JelloFileError(f"{src}: array '{array}': {msg}")

    def floats(name, a, shape):
        a = np.asarray(a)
        if a.dtype.kind not in "fiu":
            raise err(name, f"dtype {a.dtype}; expected float64")
        a = a.astype(np.float64)
        if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
            want = tuple("n" if s is None else s for s in shape)
            raise err(name, f"shape {a.shape}; expected {want}")
        bad = np.flatnonzero(~np.isfinite(a.reshape(a.shape[0], -1)).all(axis=1)) if a.size else []
        if len(bad):
            raise err(name, f"row {bad[0]} is NaN or infinite; expected finite values")
        return np.ascontiguousarray(a)

    def ints(name, a, width, n):
        a = np.asarray(a)
        if a.dtype.kind not in "iu":
            raise err(name, f"dtype {a.dtype}; expected an integer array")
        if a.ndim != 2 or a.shape[1] != width:
            raise err(name, f"shape {a.shape}; expected (rows, {width})")
        a = a.astype(np.int64)
        bad = np.flatnonzero(((a < 0) | (a >= n)).any(axis=1))
        if bad.size:
            raise err(name, f"row {bad[0]} has an index out of range 0..{n - 1}")
        s = np.sort(a, axis=1)
        rep = np.flatnonzero((s[:, 1:] == s[:, :-1]).any(axis=1))
        if rep.size:
            what = ("self-spring" if name == "springs" else "repeated vertex index"
                    if name == "skin_faces" else "repeated point index")
            raise err(name, f"row {rep[0]} is a {what} ({a[rep[0]].tolist()})")
        return np.ascontiguousarray(a)

    def positive(name, a, k):
        if a is None:
            return None
        a = floats(name, a, (k,))
        bad = np.flatnonzero(a <= 0)
        if bad.size:
            raise err(name, f"row {bad[0]} is {a[bad[0]]!r}; expected > 0")
        return a

    points = floats("points", points, (None, 3))
    n = points.shape[0]
    if n == 0:
        raise err("points", "no rows; a body needs at least one point")
    springs = ints("springs", springs, 2, n)
    k = springs.shape[0]
    if k:
        if not (springs[:, 0] < springs[:, 1]).all():
            r = int(np.flatnonzero(springs[:, 0] >= springs[:, 1])[0])
            raise err("springs", f"row {r} {springs[r].tolist()}: expected i < j")
        key = springs[:, 0] * n + springs[:, 1]
        if (np.diff(key) == 0).any():
            r = int(np.flatnonzero(np.diff(key) == 0)[0]) + 1
            raise err("springs", f"row {r} duplicates row {r - 1} ({springs[r].tolist()})")
        if (np.diff(key) < 0).any():
            r = int(np.flatnonzero(np.diff(key) < 0)[0]) + 1
            raise err("springs", f"row {r}: rows must be sorted lexicographically")
    out = {
        "points": points,
        "springs": springs,
        "rest_length": positive("rest_length", rest_length, k),
        "stiffness": positive("stiffness", stiffness, k),
        "masses": positive("masses", masses, n),
        "tets": None if tets is None else ints("tets", tets, 4, n),
        "triangles": None if triangles is None else ints("triangles", triangles, 3, n),
        "volume": None,
        "skin_vertices": None,
        "skin_faces": None,
        "skin_uv": None,
        "skin_material": None,
    }
    if (skin_vertices is None) != (skin_faces is None):
        raise err("skin_faces" if skin_faces is None else "skin_vertices",
                  "missing: a skin needs both its vertices and its faces")
    if skin_vertices is not None:
        out["skin_vertices"] = floats("skin_vertices", skin_vertices, (None, 3))
        if out["skin_vertices"].shape[0] < 3:
            raise err("skin_vertices", "fewer than 3 rows; a skin is a triangle mesh")
        out["skin_faces"] = ints("skin_faces", skin_faces, 3, out["skin_vertices"].shape[0])
    if skin_uv is not None:
        if skin_faces is None:
            raise err("skin_uv", "given without a skin: texture coordinates belong to the "
                      "faces of skin_faces")
        out["skin_uv"] = floats("skin_uv", skin_uv, (out["skin_faces"].shape[0], 3, 2))
    if skin_material is not None:
        if skin_faces is None:
            raise err("skin_material", "given without a skin: it says which material each "
                      "face of skin_faces uses")
        m = np.asarray(skin_material)
        if m.shape != (out["skin_faces"].shape[0],):
            raise err("skin_material", f"shape {m.shape}; expected one per skin face "
                      f"({out['skin_faces'].shape[0]},)")
        out["skin_material"] = ints("skin_material", m.reshape(-1, 1), 1, 2**31).reshape(-1)
    if volume is not None:
        v = np.asarray(volume)
        if v.shape != () or v.dtype.kind not in "fiu" or not math.isfinite(float(v)) or v <= 0:
            raise err("volume", f"{volume!r}; expected one finite number > 0")
        out["volume"] = float(v)
    return out
