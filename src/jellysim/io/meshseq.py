"""The skin as a sequence of OBJ or PLY files, one per frame (``<stem>_NNNNN.obj``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import JellysimError
from .atomic import atomic_path
from .usd import surface_of

__all__ = ["export_mesh_sequence"]


def export_mesh_sequence(traj, directory, *, fmt: str = "obj", stem: str = "skin") -> list[Path]:
    """Write ``directory/<stem>_NNNNN.<fmt>`` for every frame; ``fmt`` is ``obj`` or ``ply``.

    Vertices [m] are the skin's (or the body surface's) positions of each frame."""
    import meshio


    fmt = fmt.lower().lstrip(".")
    if fmt not in ("obj", "ply"):
        raise JellysimError(f"mesh sequence format must be 'obj' or 'ply', got '{fmt}'")
    frames, faces = surface_of(traj)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    out = []
    for k, verts in enumerate(frames):
        p = directory / f"{stem}_{k:05d}.{fmt}"
        mesh = meshio.Mesh(np.asarray(verts, dtype=np.float64),
                           [("triangle", np.asarray(faces, dtype=np.int32))])
        with atomic_path(p) as tmp:
            meshio.write(tmp, mesh, file_format=fmt)
        out.append(p)
    return out
