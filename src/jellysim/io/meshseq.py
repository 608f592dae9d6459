"""The skin as a sequence of OBJ or PLY files, one per frame (``<stem>_NNNNN.obj``).

OBJ files carry each frame's smooth normals as ``vn`` lines, one per vertex (area-weighted, as
:func:`.usd.vertex_normals`), each face corner naming its vertex's (``f a//a``): without them
Blender's importer shades every face flat.  One per vertex keeps the files readable by meshio
(which takes normals per vertex); a box's edges then shade soft, where the USD and glTF exports
split the normals along creases.  A skin with texture coordinates (its mesh file had UVs)
writes them as ``vt`` lines, each face corner naming its own (``f a/ta/a``), so the vertices
stay welded and the UV seams stay seams.  meshio's OBJ writer gives a vertex one UV only, so
the OBJ files are written here (the few lines of the format); PLY files carry positions
only."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import JellysimError
from .atomic import atomic_path, guard_folder, staged_output
from .usd import surface_of, surface_uv, vertex_normals

__all__ = ["export_mesh_sequence"]


def export_mesh_sequence(traj, directory, *, fmt: str = "obj", stem: str = "skin",
                         overwrite: bool = False, texture=None) -> list[Path]:
    """Write ``directory/<stem>_NNNNN.<fmt>`` for every frame; ``fmt`` is ``obj`` or ``ply``.

    Vertices [m] are the skin's (or the body surface's) positions of each frame.  A folder
    already holding ``<stem>_NNNNN.<fmt>`` files (an earlier export, whose extra frames would
    stay mixed with the new ones) is refused unless ``overwrite``; then the old files are
    replaced only once every new frame is written (an interrupted export keeps them).
    ``texture`` (OBJ only): a PNG/JPEG image, or ``{material name: image}`` for a skin of
    several materials, copied into the folder and named by a ``<stem>.mtl`` that every frame
    uses (so the folder holds all a DCC tool needs, and tools that read only files beside the
    .mtl find them); a skin of several materials writes its faces in one ``usemtl`` run per
    material (:mod:`jellysim.io.texture`)."""
    import meshio


    fmt = fmt.lower().lstrip(".")
    if fmt not in ("obj", "ply"):
        raise JellysimError(f"mesh sequence format must be 'obj' or 'ply', got '{fmt}'")
    frames, faces = surface_of(traj)
    import shutil

    from .texture import JELLO_RGBA, face_groups, identifiers, textures_of

    if texture is not None and fmt != "obj":
        raise JellysimError("a texture goes with OBJ frames (their .mtl names it); PLY files "
                            "carry positions only")
    images, groups = textures_of(traj, texture), face_groups(traj)
    uv = surface_uv(traj) if fmt == "obj" else None
    vt = None
    if fmt == "obj":  # each corner's vertex, UV (the distinct ones) and normal, 1-based
        tri = np.asarray(faces, np.int64)
        columns = [tri.reshape(-1)]
        if uv is not None:
            vt, vt_index = np.unique(np.asarray(uv, np.float64).reshape(-1, 2), axis=0,
                                     return_inverse=True)
            columns.append(vt_index.reshape(-1))
        columns.append(tri.reshape(-1))
        corners = np.stack(columns, axis=1).reshape(len(tri), -1) + 1
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise JellysimError(f"{directory}: is a file; a mesh sequence is written into a "
                            "folder (one file per frame): give a folder name")
    pattern = f"{stem}_[0-9]*.{fmt}"
    guard_folder(directory, [pattern], overwrite, flag="overwrite=True")
    mtl = f"{stem}.mtl" if uv is not None and (images or len(groups) > 1) else None
    runs = list(zip(identifiers(n for n, _ in groups), (r for _, r in groups)))  # (no spaces)
    copies = {}                                  # image -> its file name in the folder
    for image in images.values():
        if image not in copies:
            taken = image.name in copies.values()
            copies[image] = f"{stem}_{len(copies)}_{image.name}" if taken else image.name
    with staged_output(directory, [pattern] + ([mtl] if mtl else []) + list(copies.values())
                       ) as stage:
        for image, copy in copies.items():
            shutil.copyfile(image, stage / copy)
        if mtl:
            (stage / mtl).write_text("# written by jellysim: the skin's materials\n" + "".join(
                f"newmtl {run}\n" + (f"map_Kd {copies[images[name]]}\n"
                                     if name in images else "Kd {:g} {:g} {:g}\nd {:g}\n"
                                     .format(*JELLO_RGBA))
                for (run, _), (name, _) in zip(runs, groups)), encoding="utf-8")
        for k, verts in enumerate(frames):
            if fmt == "obj":
                verts = np.asarray(verts, dtype=np.float64)
                with atomic_path(stage / f"{stem}_{k:05d}.{fmt}") as tmp:
                    _write_obj(tmp, verts, vt, vertex_normals(verts, tri), corners, mtl, runs)
                continue
            mesh = meshio.Mesh(np.asarray(verts, dtype=np.float64),
                               [("triangle", np.asarray(faces, dtype=np.int32))])
            with atomic_path(stage / f"{stem}_{k:05d}.{fmt}") as tmp:
                meshio.write(tmp, mesh, file_format=fmt)
    return [directory / f"{stem}_{k:05d}.{fmt}" for k in range(len(frames))]


def _write_obj(path, verts: np.ndarray, vt: np.ndarray | None, vn: np.ndarray,
               corners: np.ndarray, mtl: str | None = None, runs=()) -> None:
    """An OBJ file of ``verts`` [m] (m, 3), texture coordinates ``vt`` (t, 2) or ``None``,
    unit normals ``vn`` (n, 3) and faces ``corners``, 1-based: (f, 9) ``a ta na b tb nb c tc
    nc`` with ``vt``, else (f, 6) ``a na b nb c nc``; ``mtl``: the material library its faces
    use, in ``runs`` ``(material name, face rows)``."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("# written by jellysim: the skin of one frame, metres\n")
        if mtl:
            fh.write(f"mtllib {mtl}\n")
        np.savetxt(fh, verts, fmt="v %.17g %.17g %.17g")  # (round-trips every float64)
        if vt is not None:
            np.savetxt(fh, vt, fmt="vt %.9g %.9g")
        np.savetxt(fh, vn, fmt="vn %.6f %.6f %.6f")
        corner = "%d/%d/%d" if vt is not None else "%d//%d"
        for name, rows in (runs if mtl else [(None, slice(None))]):
            if name is not None:
                fh.write(f"usemtl {name}\n")
            np.savetxt(fh, corners[rows], fmt="f " + " ".join([corner] * 3))
