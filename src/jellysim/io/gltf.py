"""glTF 2.0 binary (``.glb``) export: the skin as one mesh with morph-target animation.

Layout: the base mesh holds frame 0's vertex positions and unit vertex normals (area-weighted,
so viewers shade it smooth; a vertex on a crease of the first frame, an edge sharper than
:data:`~jellysim.geometry.creases.CREASE_ANGLE`, has one copy per side, so a box keeps its
edges: :func:`~jellysim.geometry.creases.split_creases`, whose vertex order keeps the skin's
first); morph target ``k`` holds frame ``k`` (positions and normals)
minus frame 0 (target 0 is all zeros), so weights one-hot at ``k`` give frame ``k`` exactly
(in float32).  One animation drives the node's morph weights with ``STEP`` interpolation at the
frames' times (shifted so the first frame is at 0 s).  When the mesh file had texture
coordinates they are ``TEXCOORD_0``, a vertex on a UV seam having one copy per side
(:func:`~jellysim.geometry.texcoords.split_seams`; glTF's V axis points down the image, so
``v`` is written as ``1 - v``).  Written with the standard library only.
"""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from ..errors import JellysimError
from .atomic import atomic_path
from .usd import surface_of, surface_uv

__all__ = ["export_glb", "read_glb", "glb_frame_positions"]

_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def export_glb(traj, path, *, max_frames: int | None = None, overwrite: bool = False,
               texture=None) -> Path:
    """Write the skin of a loaded trajectory as an animated ``.glb`` (an existing ``path`` is
    refused unless ``overwrite``).

    ``max_frames``: keep at most this many frames (evenly spaced) to bound the file size;
    default all.  ``texture``: a PNG/JPEG image embedded as the material's
    ``baseColorTexture`` (opaque), mapped by the skin's UVs, or ``{material name: image}``
    for a skin of several materials, which is written as one primitive per material
    (:mod:`jellysim.io.texture`)."""

    path = Path(path)
    if path.suffix.lower() != ".glb":
        raise JellysimError(f"{path}: a binary glTF file name must end in .glb")
    from .atomic import guard_file

    guard_file(path, overwrite, flag="overwrite=True")
    frames, faces = surface_of(traj)
    from .texture import JELLO_RGBA, TEXTURE_SUFFIXES, face_groups, textures_of

    images, groups = textures_of(traj, texture), face_groups(traj)
    times = np.asarray(traj.times, dtype=np.float64)
    idx = np.arange(len(frames))
    if max_frames is not None and len(idx) > max_frames:
        idx = np.unique(np.linspace(0, len(frames) - 1, int(max_frames)).round().astype(int))
    from ..geometry.creases import split_creases

    # creases of the first frame (a box's edges) stay hard: a vertex there has one copy per
    # smooth side (session 14's trial: the averaged normals shaded a box as a soft blob)
    source, faces = split_creases(np.asarray(frames[0], dtype=np.float64), faces)
    frames = np.stack([np.asarray(frames[int(i)], dtype=np.float32)[source] for i in idx])
    # the normals on the crease-split surface: a UV seam is no crease (it shades smooth)
    normals = np.stack([_vertex_normals(f, faces) for f in frames])
    uv = surface_uv(traj)
    if uv is not None:  # one vertex per (vertex, UV): glTF has no per-corner attributes
        from ..geometry.texcoords import split_seams

        copy, uv, faces = split_seams(faces, uv)
        frames, normals = frames[:, copy], normals[:, copy]
        uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)
    times = (times[idx] - times[idx[0]]).astype(np.float32)
    n_frames, m = frames.shape[0], frames.shape[1]
    if n_frames == 0 or m == 0:
        raise JellysimError("nothing to export: no frames or an empty surface")

    blobs: list[bytes] = []
    views, accessors = [], []

    def add(data: np.ndarray, *, kind: str, ctype: int, target: int | None, minmax=False):
        raw = np.ascontiguousarray(data).tobytes()
        offset = sum(len(b) for b in blobs)
        blobs.append(raw + b"\0" * (-len(raw) % 4))
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        views.append(view)
        acc = {"bufferView": len(views) - 1, "componentType": ctype,
               "count": int(data.shape[0]), "type": kind}
        if minmax:
            flat = data.reshape(data.shape[0], -1)
            acc["min"] = flat.min(axis=0).astype(float).tolist()
            acc["max"] = flat.max(axis=0).astype(float).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    base = frames[0]
    pos = add(base, kind="VEC3", ctype=_FLOAT, target=_ARRAY_BUFFER, minmax=True)
    nrm = add(normals[0], kind="VEC3", ctype=_FLOAT, target=_ARRAY_BUFFER)
    targets = [{"POSITION": add(f - base, kind="VEC3", ctype=_FLOAT, target=_ARRAY_BUFFER,
                                minmax=True),
                "NORMAL": add(n - normals[0], kind="VEC3", ctype=_FLOAT, target=_ARRAY_BUFFER)}
               for f, n in zip(frames, normals)]
    attributes = {"POSITION": pos, "NORMAL": nrm}
    if uv is not None:
        attributes["TEXCOORD_0"] = add(uv, kind="VEC2", ctype=_FLOAT, target=_ARRAY_BUFFER)
    embedded = sorted(set(images.values()), key=str)   # each image once, its bytes as they are
    for image in embedded:
        raw = image.read_bytes()
        views.append({"buffer": 0, "byteOffset": sum(len(b) for b in blobs),
                      "byteLength": len(raw)})
        blobs.append(raw + b"\0" * (-len(raw) % 4))
    image_views = range(len(views) - len(embedded), len(views))
    # one primitive per material of the file (one, "jello", for a skin of one), all sharing
    # the vertices and the morph targets
    groups = [(name, rows) for name, rows in groups if len(rows)]
    primitives = [{"attributes": attributes, "material": k, "mode": 4, "targets": targets,
                   "indices": add(np.asarray(faces, dtype=np.uint32)[rows].reshape(-1),
                                  kind="SCALAR", ctype=_UINT, target=_ELEMENT_ARRAY_BUFFER)}
                  for k, (_, rows) in enumerate(groups)]
    materials = []
    for name, _ in groups:
        image = images.get(name)
        materials.append({"name": name, "doubleSided": True,
                          "alphaMode": "BLEND" if image is None else "OPAQUE",
                          "pbrMetallicRoughness": {
                              "baseColorFactor": list(JELLO_RGBA) if image is None
                              else [1.0, 1.0, 1.0, 1.0],
                              **({} if image is None else {"baseColorTexture": {
                                  "index": embedded.index(image), "texCoord": 0}}),
                              "metallicFactor": 0.0, "roughnessFactor": 0.25}})
    t_acc = add(times.reshape(-1), kind="SCALAR", ctype=_FLOAT, target=None, minmax=True)
    w_acc = add(np.eye(n_frames, dtype=np.float32).reshape(-1), kind="SCALAR", ctype=_FLOAT,
                target=None)
    doc = {
        "asset": {"version": "2.0", "generator": "jellysim"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "jello"}],
        "materials": materials,
        "meshes": [{"name": "skin", "weights": [1.0] + [0.0] * (n_frames - 1),
                    "primitives": primitives,
                    "extras": {"targetNames": [f"frame_{k}" for k in idx.tolist()]}}],
        **({} if not embedded else {
            "images": [{"bufferView": v, "mimeType": TEXTURE_SUFFIXES[p.suffix.lower()]}
                       for v, p in zip(image_views, embedded)],
            "samplers": [{"wrapS": 10497, "wrapT": 10497}],   # (REPEAT, as OBJ's vt)
            "textures": [{"sampler": 0, "source": k} for k in range(len(embedded))]}),
        "animations": [{"name": "simulation",
                        "samplers": [{"input": t_acc, "output": w_acc,
                                      "interpolation": "STEP"}],
                        "channels": [{"sampler": 0,
                                      "target": {"node": 0, "path": "weights"}}]}],
        "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": sum(len(b) for b in blobs)}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary = b"".join(blobs)
    total = 12 + 8 + len(js) + 8 + len(binary)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(struct.pack("<4sII", b"glTF", 2, total))
            fh.write(struct.pack("<I4s", len(js), b"JSON") + js)
            fh.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)
    return path


def _vertex_normals(vertices: np.ndarray, faces) -> np.ndarray:
    """Unit vertex normals (m, 3) float32, each the area-weighted mean of its faces' (a
    smooth jello: without NORMAL, glTF viewers shade every triangle flat)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # |n| = 2 area
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], face_n)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), [0.0, 1.0, 0.0])
    return n.astype(np.float32)  # (a vertex of no face, or of degenerate ones only: +y, unit)


def read_glb(path) -> tuple[dict, bytes]:
    """The JSON document and binary chunk of a ``.glb`` file."""
    data = Path(path).read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2 or length != len(data):
        raise JellysimError(f"{path}: not a glTF 2.0 binary file")
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    doc = json.loads(data[20:20 + jlen])
    off = 20 + jlen
    blen, btype = struct.unpack_from("<I4s", data, off)
    if jtype != b"JSON" or btype != b"BIN\0":
        raise JellysimError(f"{path}: malformed glb chunks")
    return doc, data[off + 8:off + 8 + blen]


def _accessor(doc, binary, i) -> np.ndarray:
    acc = doc["accessors"][i]
    view = doc["bufferViews"][acc["bufferView"]]
    dtype = {_FLOAT: np.float32, _UINT: np.uint32}[acc["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    a = np.frombuffer(binary, dtype=dtype, count=acc["count"] * width, offset=start)
    return a.reshape(acc["count"], width) if width > 1 else a


def glb_frame_positions(path, k: int) -> np.ndarray:
    """Vertex positions of animation key ``k`` of a ``.glb`` written by :func:`export_glb`:
    base positions plus the morph targets weighted by the animation's weights at key ``k``
    (the glTF morphing rule), float32 (m, 3)."""
    doc, binary = read_glb(path)
    prim = doc["meshes"][0]["primitives"][0]
    base = _accessor(doc, binary, prim["attributes"]["POSITION"]).astype(np.float64)
    sampler = doc["animations"][0]["samplers"][0]
    weights = _accessor(doc, binary, sampler["output"]).reshape(-1, len(prim["targets"]))[k]
    out = base.copy()
    for w, tgt in zip(weights, prim["targets"]):
        if w:
            out += w * _accessor(doc, binary, tgt["POSITION"])
    return out
