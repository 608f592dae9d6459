"""Frame timing shared by the exporters (:mod:`jellysim.io`) and the renderers."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["default_fps", "frame_rate", "gif_delay", "real_time_playback"]

MAX_VIDEO_FPS = 60.0
"""A faster run is played in real time by showing every k-th frame (players and screens do not
show more than ~60 frames/s)."""
MAX_GIF_FPS = 50.0
"""GIF delays are whole hundredths of a second and browsers slow a delay under 2 (1/100 s: a
60 frames/s GIF written at 1/100 s plays at 10 frames/s)."""
MIN_FPS = 5.0
"""A slower run plays faster than real time, at this rate."""


def gif_delay(fps: float) -> int:
    """The GIF frame delay [1/100 s] nearest ``fps``: whole hundredths, at least 2."""
    return max(2, round(100.0 / fps))


def frame_rate(times: np.ndarray) -> float | None:
    """The run's frames per simulated second (from the median frame spacing), or ``None``
    when it has under two frames or no spacing.  ``times``: frame times [s], shape (f,)."""
    if len(times) < 2:
        return None
    dt = float(np.median(np.diff(np.asarray(times, dtype=np.float64))))
    if not dt > 0:
        return None
    rate = 1.0 / dt
    # frame times are sums of steps: 1 / dt is 30.000000000000007 for dt = 1/30; a rate
    # within 1e-9 of a whole number is that number (video and USD headers show it)
    return float(round(rate)) if abs(rate - round(rate)) < 1e-9 * rate else float(rate)


def default_fps(times: np.ndarray) -> float:
    """Frames per second that play the run in real time, clamped to [5, 60] (30 if unknown).

    ``times``: frame times [s], shape (f,)."""
    rate = frame_rate(times)
    return 30.0 if rate is None else min(MAX_VIDEO_FPS, max(MIN_FPS, rate))


def real_time_playback(times: np.ndarray, frames: np.ndarray, *, gif: bool = False
                       ) -> tuple[np.ndarray, float]:
    """The frames to show and their rate so that the run plays in real time (within one shown
    frame): a run saved faster than 60 frames/s (50 for a GIF) shows every k-th frame, and
    always the last (the end state); a GIF's rate is a whole number of hundredths of a second
    per frame (within 1/200 s per frame of real time); a run slower than 5 frames/s plays at 5.  ``times``: every frame's time [s], shape (f,);
    ``frames``: the indices to play, shape (m,)."""
    frames = np.asarray(frames, dtype=int)
    rate = frame_rate(np.asarray(times)[frames])
    if rate is None:
        return frames, 30.0
    stride = max(1, math.ceil(rate / (MAX_GIF_FPS if gif else MAX_VIDEO_FPS) - 1e-9))
    fps = rate / stride
    if gif:
        fps = 100.0 / gif_delay(fps)
    shown = frames[::stride]
    if shown[-1] != frames[-1]:  # the end state is always shown (its last interval shorter)
        shown = np.append(shown, frames[-1])
    return shown, max(MIN_FPS, fps)
