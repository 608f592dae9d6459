"""ParaView output: one ``.vtu`` per frame (points + springs as lines) and a ``.pvd`` index.

A skin (:mod:`jellysim.skin`) is written as its own series (``skin.pvd``) because its vertices
are not the body's points.  :func:`export_pvd` writes both series from a saved trajectory.

The ``.pvd`` file is rewritten (atomically) after every frame, so a run that stops early still
leaves a valid series of the frames written so far.
"""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .atomic import atomic_path

__all__ = ["PVDSeries", "export_pvd", "export_pvd_file", "write_vtu"]


def write_vtu(path, points: np.ndarray, springs: np.ndarray, *, point_data=None,
              triangles: np.ndarray | None = None) -> None:
    """One frame: points [m] (n, 3), springs (k, 2) as VTK lines (+ optional triangles)."""
    import meshio

    cells = [("line", np.asarray(springs, dtype=np.int64))]
    if triangles is not None and len(triangles):
        cells.append(("triangle", np.asarray(triangles, dtype=np.int64)))
    mesh = meshio.Mesh(np.asarray(points, dtype=np.float64), cells,
                       point_data=point_data or {})
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


class PVDSeries:
    """A ParaView time series ``<dir>/<name>.pvd`` + ``<dir>/<pieces><piece>_NNNNN.vtu``.

    ``pieces``: a sub-folder of ``directory`` for the ``.vtu`` files (default: none, they lie
    next to the ``.pvd``); ``piece``: their name stem (default: ``name``)."""

    def __init__(self, directory, name: str = "body", *, pieces: str = "",
                 piece: str | None = None):
        self.directory = Path(directory)
        self.name = name
        self.pieces = pieces
        self.piece = name if piece is None else piece
        self.entries: list[tuple[float, str]] = []

    @property
    def pvd_path(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    def _next(self) -> tuple[str, Path]:
        fname = f"{self.piece}_{len(self.entries):05d}.vtu"
        if self.pieces:
            fname = f"{self.pieces}/{fname}"
        return fname, self.directory / fname

    def add(self, t: float, points, springs, *, velocities=None, triangles=None) -> Path:
        fname, path = self._next()
        data = {} if velocities is None else {"velocity": np.asarray(velocities)}
        write_vtu(path, points, springs, point_data=data, triangles=triangles)
        self.entries.append((float(t), fname))
        self._write_index()
        return path

    def add_surface(self, t: float, vertices, faces) -> Path:
        """One frame of a triangle surface: vertices [m] (m, 3), faces (f, 3)."""
        import meshio

        fname, path = self._next()
        mesh = meshio.Mesh(np.asarray(vertices, dtype=np.float64),
                           [("triangle", np.asarray(faces, dtype=np.int64))])
        with atomic_path(path) as tmp:
            meshio.write(tmp, mesh, file_format="vtu")
        self.entries.append((float(t), fname))
        self._write_index()
        return path

    def _write_index(self) -> None:
        rows = "\n".join(
            f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(f)}/>'
            for t, f in self.entries)
        xml = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
               'byte_order="LittleEndian">\n  <Collection>\n' + rows +
               "\n  </Collection>\n</VTKFile>\n")
        with atomic_path(self.pvd_path) as tmp:
            tmp.write_text(xml, encoding="utf-8")


def export_pvd(traj, directory, name: str = "body", *, pieces: str = "") -> list[Path]:
    """Write a loaded :class:`~jellysim.io.trajectory.Trajectory` as ParaView series:
    ``<name>.pvd`` (points, springs as lines, surface triangles) and, when it has a skin,
    ``<name>_skin.pvd``.  The ``.vtu`` frames go into ``directory/pieces`` (default: next to
    the ``.pvd``).  Returns the ``.pvd`` paths."""
    body = PVDSeries(directory, name, pieces=pieces)
    tri = traj.triangles if len(traj.triangles) else None
    for f in range(traj.frame_count):
        body.add(traj.times[f], traj.positions[f], traj.springs,
                 velocities=traj.velocities[f], triangles=tri)
    out = [body.pvd_path]
    if traj.skin is not None:
        skin = PVDSeries(directory, f"{name}_skin", pieces=pieces)
        for f in range(traj.frame_count):
            skin.add_surface(traj.times[f], traj.skin_positions(f), traj.skin.faces)
        out.append(skin.pvd_path)
    return out


def export_pvd_file(traj, path) -> list[Path]:
    """:func:`export_pvd` to the file ``path`` (``run.pvd``): its ``.vtu`` frames go into the
    sibling folder ``run/`` (``run/run_00000.vtu``, ``run/run_skin_00000.vtu``), never loose
    next to it.  Returns the ``.pvd`` paths."""
    path = Path(path)
    return export_pvd(traj, path.parent, path.stem, pieces=path.stem)
