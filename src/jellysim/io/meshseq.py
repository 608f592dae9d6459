"""The skin as a sequence of OBJ or PLY files, one per frame (``<stem>_NNNNN.obj``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import JellysimError
from .atomic import atomic_path, guard_folder, staged_output
from .usd import surface_of

__all__ = ["export_mesh_sequence"]


def export_mesh_sequence(traj, directory, *, fmt: str = "obj", stem: str = "skin",
                         overwrite: bool = False) -> list[Path]:
    """Write ``directory/<stem>_NNNNN.<fmt>`` for every frame; ``fmt`` is ``obj`` or ``ply``.

    Vertices [m] are the skin's (or the body surface's) positions of each frame.  A folder
    already holding ``<stem>_NNNNN.<fmt>`` files (an earlier export, whose extra frames would
    stay mixed with the new ones) is refused unless ``overwrite``; then the old files are
    replaced only once every new frame is written (an interrupted export keeps them)."""
    import meshio


    fmt = fmt.lower().lstrip(".")
    if fmt not in ("obj", "ply"):
        raise JellysimError(f"mesh sequence format must be 'obj' or 'ply', got '{fmt}'")
    frames, faces = surface_of(traj)
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise JellysimError(f"{directory}: is a file; a mesh sequence is written into a "
                            "folder (one file per frame): give a folder name")
    pattern = f"{stem}_[0-9]*.{fmt}"
    guard_folder(directory, [pattern], overwrite, flag="overwrite=True")
    with staged_output(directory, [pattern]) as stage:
        for k, verts in enumerate(frames):
            mesh = meshio.Mesh(np.asarray(verts, dtype=np.float64),
                               [("triangle", np.asarray(faces, dtype=np.int32))])
            with atomic_path(stage / f"{stem}_{k:05d}.{fmt}") as tmp:
                meshio.write(tmp, mesh, file_format=fmt)
    return [directory / f"{stem}_{k:05d}.{fmt}" for k in range(len(frames))]
