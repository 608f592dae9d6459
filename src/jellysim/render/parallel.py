"""Every other frame of a video rendered by a second process.

Off-screen rendering (VTK through Mesa's software OpenGL) keeps one core busy: 90-160 ms per
960x540 frame here, most of it inside ``vtkRenderWindow.Render``.  On a machine with a second
core, :class:`FrameHelper` starts a second Python process (``python -m
jellysim.render.parallel``: a fresh interpreter, so neither numba's threads nor the caller's
``__main__`` are copied or re-run) that builds the same renderer from the same trajectory and
options and renders the odd-numbered frames of the list while this process renders the even
ones; the images come back through a pipe, in order (the helper renders its next frame while
this process renders its own).  The pictures are the same pixel for pixel (the renderer is
deterministic; tested).  If the helper fails in any way, the frames it has not delivered are
rendered here, as before; ``JELLYSIM_RENDER_PROCESSES=1`` turns it off.
"""
from __future__ import annotations

import os
import pickle
import select
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

__all__ = ["FrameHelper", "MIN_FRAMES", "wanted"]

MIN_FRAMES = 24
"""Fewer frames than this are rendered in one process (the helper's start, about 2 s of
importing VTK and building the scene, would not pay)."""

TIMEOUT_S = 120.0
"""Longest wait for one frame from the helper before this process renders the rest itself."""

_HEADER = struct.Struct("<Q")

COMMAND = (sys.executable, "-m", "jellysim.render.parallel")
"""The helper's command line (its payload comes on stdin, its frames go to stdout)."""


def wanted(count: int) -> bool:
    """Whether ``count`` frames are worth a second process here."""
    if os.environ.get("JELLYSIM_RENDER_PROCESSES", "2").strip() in ("0", "1"):
        return False
    return count >= MIN_FRAMES and (os.cpu_count() or 1) >= 2


class FrameHelper:
    """A second process rendering ``frames`` (a list of frame numbers) of the runs ``runs``
    (the first and those shown beside it) with ``options`` and ``labels``; :meth:`next` gives
    the next one's image, or ``None`` once the helper has failed (render it yourself)."""

    def __init__(self, runs, options, labels, frames):
        self.failed = False
        env = dict(os.environ)
        src = str(Path(__file__).resolve().parents[2])  # this jellysim, not another one
        env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH")
                                   else "")
        try:
            payload = pickle.dumps((list(runs), options, list(labels),
                                    [int(f) for f in frames]), protocol=pickle.HIGHEST_PROTOCOL)
            self._proc = subprocess.Popen(list(COMMAND),
                                          env=env, stdin=subprocess.PIPE,
                                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
            self._proc.stdin.write(payload)
            self._proc.stdin.close()
        except Exception:  # (a trajectory that does not pickle, no process to be had)
            self._proc = None
            self.failed = True

    def _read(self, n: int) -> bytes:
        out = bytearray()
        fd = self._proc.stdout
        while len(out) < n:
            ready, _, _ = select.select([fd], [], [], TIMEOUT_S)
            if not ready:
                raise TimeoutError
            chunk = os.read(fd.fileno(), n - len(out))
            if not chunk:
                raise EOFError
            out += chunk
        return bytes(out)

    def next(self):
        if self.failed:
            return None
        try:
            (size,) = _HEADER.unpack(self._read(_HEADER.size))
            kind, value = pickle.loads(self._read(size))
        except Exception:  # died, hung, or sent something else
            kind, value = "error", None
        if kind != "frame":
            self.close()
            self.failed = True
            return None
        return value

    def close(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        proc.stdout.close()


def _work(stdin, stdout) -> None:
    """The helper process: the renderers of :func:`~jellysim.render.video.render_trajectory`,
    then each frame's image written as it is made."""
    import contextlib

    from .offscreen import Renderer
    from .video import _SideBySide

    runs, options, labels, frames = pickle.loads(stdin.read())

    def send(item):
        data = pickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)
        stdout.write(_HEADER.pack(len(data)) + data)
        stdout.flush()

    try:
        with contextlib.ExitStack() as opened:
            beside = len(runs) > 1
            renderers = [opened.enter_context(Renderer(
                t, options, frame_with=[u for u in runs if u is not t] if beside else (),
                label=labels[k])) for k, t in enumerate(runs)]
            r = renderers[0] if not beside else _SideBySide(renderers)
            for f in frames:
                send(("frame", np.ascontiguousarray(r.render(f))))
    except BrokenPipeError:
        pass  # the parent stopped listening (it finished, or failed over)
    except BaseException as exc:  # said to the parent, which renders the rest itself
        with contextlib.suppress(Exception):
            send(("error", f"{type(exc).__name__}: {exc}"))


if __name__ == "__main__":
    out = sys.stdout.buffer
    sys.stdout = sys.stderr  # (anything printed must not mix with the frames)
    _work(sys.stdin.buffer, out)
