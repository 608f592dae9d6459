"""ParaView output: one ``.vtu`` per frame (points + springs as lines) and a ``.pvd`` index.

The ``.pvd`` file is rewritten (atomically) after every frame, so a run that stops early still
leaves a valid series of the frames written so far.
"""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .atomic import atomic_path

__all__ = ["PVDSeries", "write_vtu"]


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
    """A ParaView time series ``<dir>/<name>.pvd`` + ``<dir>/<name>_NNNNN.vtu``."""

    def __init__(self, directory, name: str = "body"):
        self.directory = Path(directory)
        self.name = name
        self.entries: list[tuple[float, str]] = []

    @property
    def pvd_path(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    def add(self, t: float, points, springs, *, velocities=None, triangles=None) -> Path:
        index = len(self.entries)
        fname = f"{self.name}_{index:05d}.vtu"
        data = {} if velocities is None else {"velocity": np.asarray(velocities)}
        write_vtu(self.directory / fname, points, springs, point_data=data,
                  triangles=triangles)
        self.entries.append((float(t), fname))
        self._write_index()
        return self.directory / fname

    def _write_index(self) -> None:
        rows = "\n".join(
            f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(f)}/>'
            for t, f in self.entries)
        xml = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
               'byte_order="LittleEndian">\n  <Collection>\n' + rows +
               "\n  </Collection>\n</VTKFile>\n")
        with atomic_path(self.pvd_path) as tmp:
            tmp.write_text(xml, encoding="utf-8")
