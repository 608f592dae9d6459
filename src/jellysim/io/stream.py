"""Streaming trajectories: frames appended to disk as they are produced.

A run writes its frames into the directory ``<out>/trajectory.stream/``::

    meta.npz          static arrays (rest positions, masses, springs, ..., scene, parameters,
                      skin): the same names and units as ``trajectory.npz``, written once
    positions.npy     (F, n, 3) f8  positions per frame [m]
    velocities.npy    (F, n, 3) f8  velocities per frame [m/s]
    times.npy         (F,) f8       simulated time of each frame [s]
    steps.npy         (F,) i8       time-step index of each frame
    status.txt        ``running``, ``interrupted at step N (...)`` (resumable) or ``failed: ...``

Each ``.npy`` is an ordinary NumPy file (``np.load`` reads it, also with ``mmap_mode``) that
grows in place: a frame's bytes are appended after the data, then the fixed-size header's frame
count is rewritten in place (one small ``pwrite``).  A frame is *flushed* once its four headers
say so.  A process killed at any moment (SIGKILL too) leaves every flushed frame readable: bytes
of an unflushed frame lie past the header's count and are ignored (and cut off on resume); the
frame count of the stream is the smallest of the four headers.  No temporary file is involved,
so nothing hidden is left behind.

When the run ends (complete or failed) the stream is copied, block by block, into the usual
``trajectory.npz`` (uncompressed members, same names as before; old readers keep working) and
the directory is removed.  An interrupted or killed run keeps the directory;
:func:`jellysim.io.trajectory.load_trajectory` reads it (given the directory, the run directory
or the missing ``trajectory.npz`` next to it).

Why not HDF5 or Zarr: HDF5 files are not safe against a kill during a write (its metadata can be
left inconsistent unless SWMR mode is used, which h5py supports only for appends under extra
rules), and both add a dependency; the layout above needs only NumPy, costs one ``pwrite`` of
data plus one of about 128 bytes per array and frame, and every piece of it is a plain ``.npy``.
"""
from __future__ import annotations

import ast
import os
import shutil
import zipfile
from pathlib import Path

import numpy as np

from ..errors import CheckpointError

__all__ = ["STREAM_DIR", "GrowingNpy", "TrajectoryStream", "read_stream", "stream_frames",
           "stream_steps",
           "finalize_stream", "reopen_stream", "write_replace"]

STREAM_DIR = "trajectory.stream"
"""Name of the stream directory inside a run's output directory."""

HEADER_BYTES = 128
"""Size of every growing ``.npy`` header (magic + version + length + padded dict)."""

BLOCK_BYTES = 1 << 20
"""Bytes copied per block when a stream is turned into ``trajectory.npz``."""


def _header(dtype: np.dtype, shape: tuple) -> bytes:
    dims = [str(int(s)) for s in shape]
    text = "(" + ", ".join(dims) + ("," if len(dims) == 1 else "") + ")"
    d = "{'descr': %r, 'fortran_order': False, 'shape': %s, }" % (
        np.lib.format.dtype_to_descr(dtype), text)
    body = d.encode("latin1")
    room = HEADER_BYTES - 10 - 1
    if len(body) > room:
        raise ValueError(f"shape {shape} does not fit a {HEADER_BYTES}-byte npy header")
    body = body + b" " * (room - len(body)) + b"\n"
    return b"\x93NUMPY\x01\x00" + len(body).to_bytes(2, "little") + body


def _read_header(fd) -> tuple[np.dtype, tuple]:
    raw = os.pread(fd, HEADER_BYTES, 0)
    if len(raw) < HEADER_BYTES or raw[:8] != b"\x93NUMPY\x01\x00":
        raise ValueError("not a growing .npy file (bad header)")
    n = int.from_bytes(raw[8:10], "little")
    d = ast.literal_eval(raw[10:10 + n].decode("latin1"))
    return np.dtype(d["descr"]), tuple(d["shape"])


def _pwrite_all(fd, data: memoryview, offset: int, path) -> None:
    """``os.pwrite`` until every byte of ``data`` is written at ``offset``; a write that
    makes no progress (a full disk) is an ``OSError`` (ENOSPC) naming ``path``."""
    import errno

    done = 0
    while done < len(data):
        n = os.pwrite(fd, data[done:], offset + done)
        if n <= 0:
            raise OSError(errno.ENOSPC, f"No space left on device: wrote {done} of "
                          f"{len(data)} bytes", str(path))
        done += n


class GrowingNpy:
    """An ``.npy`` file of shape ``(F,) + row_shape`` whose first axis grows.

    ``append`` writes rows after the data; ``commit`` makes them visible by rewriting the
    header.  ``keep``: open an existing file and keep its first ``keep`` rows (the rest is cut
    off); ``None`` creates a new, empty file."""

    def __init__(self, path, dtype, row_shape: tuple, *, keep: int | None = None):
        self.path = Path(path)
        self.dtype = np.dtype(dtype).newbyteorder("<")
        self.row_shape = tuple(int(s) for s in row_shape)
        self.row_bytes = int(np.prod(self.row_shape, dtype=np.int64)) * self.dtype.itemsize
        if keep is None:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
            self.rows = 0
            os.pwrite(self.fd, _header(self.dtype, (0,) + self.row_shape), 0)
        else:
            self.fd = os.open(self.path, os.O_RDWR)
            dtype_, shape = _read_header(self.fd)
            if dtype_ != self.dtype or tuple(shape[1:]) != self.row_shape or shape[0] < keep:
                os.close(self.fd)
                raise ValueError(f"{self.path}: holds {shape} {dtype_}, expected at least "
                                 f"{keep} rows of {self.row_shape} {self.dtype}")
            held = (os.fstat(self.fd).st_size - HEADER_BYTES) // max(1, self.row_bytes)
            if held < keep:  # cut short (a crash, a copy): extending it would read as zeros
                os.close(self.fd)
                raise ValueError(f"{self.path}: is cut short: its data hold {max(0, held)} of "
                                 f"the {keep} frames the checkpoint needs (a crash or a copy cut "
                                 "short)")
            self.rows = int(keep)
            os.ftruncate(self.fd, HEADER_BYTES + self.rows * self.row_bytes)
            self.commit()
        self.committed = self.rows

    def append(self, rows: np.ndarray) -> None:
        """Write ``rows`` after the data (every byte, or an ``OSError``: a full disk's short
        write is not taken for a whole frame; the rows count only once written)."""
        a = np.ascontiguousarray(rows, dtype=self.dtype).reshape((-1,) + self.row_shape)
        _pwrite_all(self.fd, memoryview(a).cast("B"), HEADER_BYTES + self.rows * self.row_bytes,
                    self.path)
        self.rows += a.shape[0]

    def commit(self) -> None:
        _pwrite_all(self.fd, memoryview(_header(self.dtype, (self.rows,) + self.row_shape)), 0,
                    self.path)
        self.committed = self.rows

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def write_replace(path, data: bytes) -> None:
    """Write ``path`` through a visible ``<path>.partial`` file and an atomic rename (a kill
    leaves at most the ``.partial`` file, which the next run removes)."""
    path = Path(path)
    part = path.with_name(path.name + ".partial")
    try:
        with open(part, "wb") as fh:
            fh.write(data)
        os.replace(part, path)
    except OSError:  # (a full disk: leave no empty .partial behind)
        part.unlink(missing_ok=True)
        raise


_FRAME_ARRAYS = (("positions", "<f8", 3), ("velocities", "<f8", 3), ("times", "<f8", None),
                 ("steps", "<i8", None))


class TrajectoryStream:
    """Writes a run's frames into ``directory`` (see the module doc).

    ``meta``: the static arrays (``rest_positions`` ... skin), written once as ``meta.npz``.
    ``keep``: reopen an existing stream and keep its first ``keep`` frames (resume)."""

    def __init__(self, directory, point_count: int, meta: dict | None = None, *,
                 keep: int | None = None):
        self.directory = Path(directory)
        n = int(point_count)
        if keep is None:
            if self.directory.exists():
                shutil.rmtree(self.directory)
            self.directory.mkdir(parents=True)
            import io

            buf = io.BytesIO()
            np.savez(buf, **(meta or {}))
            write_replace(self.directory / "meta.npz", buf.getvalue())
        else:
            for stale in self.directory.glob("*.partial"):
                stale.unlink()
        self.files = {name: GrowingNpy(self.directory / f"{name}.npy", dt,
                                       (n, w) if w else (), keep=keep)
                      for name, dt, w in _FRAME_ARRAYS}
        self.set_status("running")

    @property
    def frames(self) -> int:
        return self.files["times"].committed

    def record(self, state) -> None:
        """Append one frame (``state.x``, ``state.v``, ``state.t``, ``state.step``) and flush."""
        f = self.files
        f["positions"].append(state.x)
        f["velocities"].append(state.v)
        f["steps"].append(np.array([state.step], dtype=np.int64))
        f["times"].append(np.array([state.t], dtype=np.float64))
        for name in ("positions", "velocities", "steps", "times"):
            f[name].commit()

    def set_status(self, status: str) -> None:
        write_replace(self.directory / "status.txt", status.encode("utf-8"))

    def sync(self) -> None:
        """Force the flushed frames to the disk (only needed against power loss)."""
        for g in self.files.values():
            os.fsync(g.fd)

    def close(self) -> None:
        for g in self.files.values():
            g.close()


def stream_frames(directory) -> int:
    """Number of flushed frames in a stream directory: the smallest header count, and no more
    than each file's data hold (a file cut short, by a full disk or a copy, is read up to its
    last whole frame)."""
    counts = []
    for name, _, _ in _FRAME_ARRAYS:
        fd = os.open(Path(directory) / f"{name}.npy", os.O_RDONLY)
        try:
            dtype, shape = _read_header(fd)
            row = int(np.prod(shape[1:], dtype=np.int64)) * dtype.itemsize
            held = (os.fstat(fd).st_size - HEADER_BYTES) // max(1, row)
            counts.append(max(0, min(int(shape[0]), int(held))))
        finally:
            os.close(fd)
    return min(counts)


def stream_steps(directory) -> int:
    """The steps the run writing stream ``directory`` was asked for (its recorded
    ``[integrator] steps``: an extension records its new length when it starts), read to
    check the stream: a damaged ``meta.npz`` raises :class:`~jellysim.errors.CheckpointError`
    (a resume says so before it steps, not after every step: the reliability trial)."""
    import json

    meta = Path(directory) / "meta.npz"
    try:
        with np.load(meta, allow_pickle=False) as z:
            return int(json.loads(str(z["params_json"]))["integrator"]["steps"])
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
        raise CheckpointError(f"{meta}: damaged ({type(exc).__name__}: {exc}): the run's "
                              "frames cannot be continued; run it again with --overwrite"
                              ) from None


def read_stream(directory, *, mmap: bool = False) -> dict:
    """Every array of a stream directory as in ``trajectory.npz`` (frames cut to the flushed
    count); ``status`` says ``incomplete`` when the run was killed while running."""
    directory = Path(directory)
    with np.load(directory / "meta.npz", allow_pickle=False) as z:
        d = {k: z[k] for k in z.files}
    frames = stream_frames(directory)
    for name, _, _ in _FRAME_ARRAYS:
        path = directory / f"{name}.npy"
        fd = os.open(path, os.O_RDONLY)
        try:
            dtype, shape = _read_header(fd)
        finally:
            os.close(fd)
        shape = (frames,) + tuple(shape[1:])
        if frames == 0:
            a = np.empty(shape, dtype=dtype)
        else:  # (mapped at the flushed count: the header may promise a row a full disk cut)
            a = np.memmap(path, dtype=dtype, mode="r", offset=HEADER_BYTES, shape=shape)
        d[name] = a if mmap else np.array(a)
    try:
        status = (directory / "status.txt").read_text(encoding="utf-8")
    except FileNotFoundError:
        status = "running"
    if status == "running":
        from .lock import writer_of

        writer = writer_of(directory.parent)  # (a live run's, or one that was killed)
        status = (f"running: {writer} is writing it ({frames} frames so far)" if writer else
                  f"incomplete: the run stopped without finishing (killed, or its disk full?) "
                  f"after {frames} frames")
    d["status"] = np.array(status)
    return d


def finalize_stream(directory, npz_path, status: str) -> Path:
    """Copy a stream into one ``.npz`` (uncompressed), then remove the stream directory.

    The per-frame arrays are copied as raw bytes in blocks of :data:`BLOCK_BYTES` with plain
    reads (no memory map, whose pages would count in the resident set): memory does not grow
    with the frame count.  Written through ``<npz>.partial`` and an atomic rename."""
    directory = Path(directory)
    npz_path = Path(npz_path)
    with np.load(directory / "meta.npz", allow_pickle=False) as z:
        meta = {k: z[k] for k in z.files}
    frames = stream_frames(directory)
    part = npz_path.with_name(npz_path.name + ".partial")

    def header(fh, dtype, shape):
        np.lib.format.write_array_header_1_0(
            fh, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)),
                 "fortran_order": False, "shape": tuple(shape)})

    view = memoryview(bytearray(BLOCK_BYTES))   # one buffer, whatever the frame count
    with zipfile.ZipFile(part, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, a in meta.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                header(fh, a.dtype, a.shape)
                fh.write(np.ascontiguousarray(a).tobytes())
        for name, dt, w in _FRAME_ARRAYS:
            src = directory / f"{name}.npy"
            fd = os.open(src, os.O_RDONLY)
            try:
                dtype, shape = _read_header(fd)
                rows = tuple(shape[1:])
                row_bytes = int(np.prod(rows, dtype=np.int64)) * dtype.itemsize
                left = frames * row_bytes
                offset = HEADER_BYTES
                with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                    header(fh, dtype, (frames,) + rows)
                    while left > 0:
                        got = os.preadv(fd, [view[:min(BLOCK_BYTES, left)]], offset)
                        if got <= 0:
                            raise OSError(f"{src}: shorter than its header says")
                        fh.write(view[:got])
                        offset += got
                        left -= got
            finally:
                os.close(fd)
        with zf.open("status.npy", "w") as fh:
            np.lib.format.write_array(fh, np.array(status), allow_pickle=False)
    os.replace(part, npz_path)
    shutil.rmtree(directory)
    return Path(npz_path)


def reopen_stream(npz_path, directory, meta: dict | None = None) -> int:
    """Turn a finished ``trajectory.npz`` back into a stream ``directory`` holding all its
    frames (a completed run being extended); returns the frame count.  The arrays are copied
    block by block (memory does not grow with the frame count) into
    ``<directory>.partial``, which is renamed into place only when complete; the ``.npz`` is
    left as it is (the extended run's end replaces it atomically).  ``meta``: static arrays
    to write instead of the ``.npz``'s (the extension's scene text and parameters)."""
    npz_path, directory = Path(npz_path), Path(directory)
    part = directory.with_name(directory.name + ".partial")
    if part.exists():
        shutil.rmtree(part)
    part.mkdir()
    frame_names = {f"{name}.npy": (name, dt, w) for name, dt, w in _FRAME_ARRAYS}
    with np.load(npz_path, allow_pickle=False) as z:  # members are read only when asked
        old = {k: z[k] for k in z.files if f"{k}.npy" not in frame_names and k != "status"}
    meta = {**old, **(meta or {})}
    frames = None
    with zipfile.ZipFile(npz_path) as zf:
        for member, (_, dt, w) in frame_names.items():
            with zf.open(member) as fh:
                version = np.lib.format.read_magic(fh)
                read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                        else np.lib.format.read_array_header_2_0)
                shape, _, dtype = read(fh)
                g = GrowingNpy(part / member, dt, (shape[1], w) if w else ())
                row = max(1, int(np.prod(shape[1:], dtype=np.int64)) * dtype.itemsize)
                step = max(1, BLOCK_BYTES // row)
                left = shape[0]
                while left > 0:
                    take = min(step, left)
                    g.append(np.frombuffer(fh.read(take * row), dtype=dtype))
                    left -= take
                g.commit()
                g.close()
                frames = shape[0] if frames is None else min(frames, shape[0])
    import io

    buf = io.BytesIO()
    np.savez(buf, **meta)
    write_replace(part / "meta.npz", buf.getvalue())
    write_replace(part / "status.txt", b"running")
    if directory.exists():
        shutil.rmtree(directory)
    os.replace(part, directory)
    return int(frames or 0)
