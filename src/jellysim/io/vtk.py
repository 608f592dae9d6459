"""ParaView output: one ``.vtu`` per frame (points + springs as lines, and a body's tets with
their volume ratio J) and a ``.pvd`` index.

A skin (:mod:`jellysim.skin`) is written as its own series (``skin.pvd``) because its vertices
are not the body's points.  :func:`export_pvd` writes both series from a saved trajectory.

The ``.pvd`` index grows by one in-place write per frame, after that frame's ``.vtu`` is
complete, so a run that stops early (even killed) leaves a valid series of the frames so far.
"""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .atomic import atomic_path

__all__ = ["FrameWriter", "PVDSeries", "export_pvd", "export_pvd_file", "write_vtu"]


def write_vtu(path, points: np.ndarray, springs: np.ndarray, *, point_data=None,
              triangles: np.ndarray | None = None, tets: np.ndarray | None = None,
              rest: np.ndarray | None = None, atomic: bool = True,
              tet_fields: dict | None = None) -> None:
    """One frame: points [m] (n, 3), springs (k, 2) as VTK lines (+ optional triangles, and
    tets (t, 4) as VTK tetrahedra with, given the ``rest`` positions [m] (n, 3), the cell
    field ``volume_ratio`` J = volume / rest volume [-] per tet: < 1 squeezed, < 0 inside
    out; NaN on the lines and triangles).  ``tet_fields``: more per-tet cell fields, each
    shape (t,) or (t, k) (the physical path's ``von_mises`` and ``stress`` [Pa]).
    ``atomic=False`` writes ``path`` directly (a series lists it only once complete)."""
    import meshio

    x = np.asarray(points, dtype=np.float64)
    cells = [("line", np.asarray(springs, dtype=np.int64))]
    if triangles is not None and len(triangles):
        cells.append(("triangle", np.asarray(triangles, dtype=np.int64)))
    if not len(cells[0][1]) and (len(cells) > 1 or tets is not None and len(tets)):
        cells = cells[1:]  # no springs (a tet body): meshio cannot write an empty block
    cell_data = {}
    if tets is not None and len(tets):
        t = np.asarray(tets, dtype=np.int64)
        cells.append(("tetra", t))
        if rest is not None:
            def volumes(p):
                a, b, c, d = (p[t[:, i]] for i in range(4))
                return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0

            r = volumes(np.asarray(rest, dtype=np.float64))
            ratio = np.divide(volumes(x), r, out=np.full(len(t), np.nan), where=r != 0)
            cell_data["volume_ratio"] = [np.full(len(c[1]), np.nan) for c in cells[:-1]] + [
                ratio]
        for name, field in (tet_fields or {}).items():
            field = np.asarray(field, dtype=np.float64)
            cell_data[name] = [np.full((len(c[1]),) + field.shape[1:], np.nan)
                               for c in cells[:-1]] + [field]
    mesh = meshio.Mesh(x, cells, point_data=point_data or {}, cell_data=cell_data)
    if not atomic:
        meshio.write(path, mesh, file_format="vtu")
        return
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


_PVD_HEAD = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
             'byte_order="LittleEndian">\n  <Collection>\n')
_PVD_TAIL = "  </Collection>\n</VTKFile>\n"


class FrameWriter:
    """Writes a run's ParaView frames in one background thread, in the order given, while
    the run goes on (the kernels and zlib release the GIL): a frame's ``.vtu`` took 14-19 ms
    for the 1,331-point gelatin cube, a third of its run (BENCHMARKS.md "Memory vs frames",
    session 24).  Arguments must not change after :meth:`submit` (pass copies).  A write's
    error (a full disk) is raised by the next :meth:`submit` or :meth:`flush`, with the
    failed frame's ``tag`` as its ``frame_tag`` attribute; at most ``depth`` frames wait (a
    slow disk holds the run back instead of filling memory)."""

    def __init__(self, depth: int = 4):
        self.depth = depth
        self._pool = None
        self._pending: list = []

    def submit(self, tag, fn, *args, **kwargs) -> None:
        """Run ``fn(*args, **kwargs)`` after the writes before it (``tag``: the frame's
        step, given back with an error)."""
        self._raise_finished()
        while len(self._pending) >= self.depth:
            self._wait_first()
        if self._pool is None:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="jellysim-vtu")
        self._pending.append((tag, self._pool.submit(fn, *args, **kwargs)))

    def _wait_first(self) -> None:
        tag, future = self._pending.pop(0)
        exc = future.exception()
        if exc is not None:
            exc.frame_tag = tag
            raise exc

    def _raise_finished(self) -> None:
        while self._pending and self._pending[0][1].done():
            self._wait_first()

    def flush(self) -> None:
        """Wait for every frame submitted; raise the first failed write's error."""
        while self._pending:
            self._wait_first()

    def close(self) -> None:
        """Wait for the writes in flight and stop the thread; errors are not raised (a
        run that flushed has seen them; one already failing keeps its own error)."""
        self._pending = []
        if self._pool is not None:  # (shutdown waits for the writes in flight)
            self._pool.shutdown(wait=True)
            self._pool = None


class PVDSeries:
    """A ParaView time series ``<dir>/<name>.pvd`` + ``<dir>/<pieces>/<piece>_NNNNN.vtu``.

    Each frame's ``.vtu`` is written first, then its entry is added to the ``.pvd`` by one
    in-place write that replaces the closing tags with the entry and the closing tags: the
    index is valid after every frame, lists only complete frames, costs O(1) per frame and
    needs no temporary file.  ``keep``: continue an existing series after its first ``keep``
    frames (resume).  ``pieces``: a sub-folder of ``directory`` for the ``.vtu`` files
    (default: none, they lie next to the ``.pvd``); ``piece``: their name stem (default:
    ``name``)."""

    def __init__(self, directory, name: str = "body", *, keep: int | None = None,
                 pieces: str = "", piece: str | None = None):
        import os
        import re

        self.directory = Path(directory)
        self.name = name
        self.pieces = pieces
        self.piece = name if piece is None else piece
        rows: list[str] = []
        if keep is not None and self.pvd_path.exists():
            text = self.pvd_path.read_text(encoding="utf-8")
            rows = re.findall(r"^    <DataSet .*/>\n", text, flags=re.M)[:keep]
        self.count = len(rows)
        if keep is not None:  # frames past the kept ones (a resume cut them off): removed
            k = self.count
            while True:
                stale = self._next_path(k)
                if not stale.is_file():
                    break
                stale.unlink()
                k += 1
        data = (_PVD_HEAD + "".join(rows)).encode("utf-8")
        self._tail = len(data)
        self.directory.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.pvd_path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
        try:
            os.write(fd, data + _PVD_TAIL.encode("utf-8"))
        finally:
            os.close(fd)

    @property
    def pvd_path(self) -> Path:
        return self.directory / f"{self.name}.pvd"

    def _frame_name(self, k: int) -> str:
        """Frame ``k``'s file, relative to the ``.pvd``."""
        fname = f"{self.piece}_{k:05d}.vtu"
        return f"{self.pieces}/{fname}" if self.pieces else fname

    def _next_path(self, k: int) -> Path:
        return self.directory / self._frame_name(k)

    def _next(self) -> tuple[str, Path]:
        fname = self._frame_name(self.count)
        if self.pieces:
            (self.directory / self.pieces).mkdir(parents=True, exist_ok=True)
        return fname, self.directory / fname

    def add(self, t: float, points, springs, *, velocities=None, triangles=None, tets=None,
            rest=None, tet_fields=None, point_fields=None) -> Path:
        """One frame: see :func:`write_vtu`; ``point_fields``: more per-point fields, each
        shape (n,) or (n, k) (a run's handles: ``pinned``, ``point_force`` [N],
        ``gravity_scale``)."""
        fname, path = self._next()
        data = {} if velocities is None else {"velocity": np.asarray(velocities)}
        data.update({k: np.asarray(v, dtype=np.float64) for k, v in (point_fields or {}).items()})
        write_vtu(path, points, springs, point_data=data, triangles=triangles, tets=tets,
                  rest=rest, atomic=False, tet_fields=tet_fields)
        self._append(t, fname)
        return path

    def add_surface(self, t: float, vertices, faces) -> Path:
        """One frame of a triangle surface: vertices [m] (m, 3), faces (f, 3)."""
        import meshio

        fname, path = self._next()
        mesh = meshio.Mesh(np.asarray(vertices, dtype=np.float64),
                           [("triangle", np.asarray(faces, dtype=np.int64))])
        meshio.write(path, mesh, file_format="vtu")
        self._append(t, fname)
        return path

    def _append(self, t: float, fname: str) -> None:
        import os

        row = (f'    <DataSet timestep="{float(t)!r}" group="" part="0" '
               f'file={quoteattr(fname)}/>\n').encode("utf-8")
        fd = os.open(self.pvd_path, os.O_RDWR)
        try:
            os.pwrite(fd, row + _PVD_TAIL.encode("utf-8"), self._tail)
        finally:
            os.close(fd)
        self._tail += len(row)
        self.count += 1


def export_pvd(traj, directory, name: str = "body", *, pieces: str = "") -> list[Path]:
    """Write a loaded :class:`~jellysim.io.trajectory.Trajectory` as ParaView series:
    ``<name>.pvd`` (points, springs as lines, surface triangles) and, when it has a skin,
    ``<name>_skin.pvd``.  The ``.vtu`` frames go into ``directory/pieces`` (default: next to
    the ``.pvd``).  Returns the ``.pvd`` paths."""
    body = PVDSeries(directory, name, pieces=pieces)
    tri = traj.triangles if len(traj.triangles) else None
    tets = traj.tets if len(traj.tets) else None
    springs = traj.springs
    fem = (traj.params or {}).get("fem") if tets is not None else None
    if fem:  # a physical run: its tets alone, with their elastic stress (named so: the run's
        # own frames' 'stress' adds the damping branch's, which the trajectory cannot give)
        from ..geometry.tetra import orient_tets
        from ..physics.fem import fem_arrays, stress_fields, tet_stresses

        springs, tri = springs[:0], None
        rest = np.asarray(traj.rest_positions, dtype=np.float64)
        tets = orient_tets(rest, tets)
        arrays = fem_arrays(rest, tets, youngs_modulus=fem["youngs_modulus"],
                            poisson_ratio=fem["poisson_ratio"])
    for f in range(traj.frame_count):
        body.add(traj.times[f], traj.positions[f], springs,
                 velocities=traj.velocities[f], triangles=tri, tets=tets,
                 rest=traj.rest_positions, tet_fields=stress_fields(tet_stresses(
                     arrays, traj.positions[f]), "elastic_") if fem else None)
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
