"""Frame timing shared by the exporters (:mod:`jellysim.io`) and the renderers."""
from __future__ import annotations

import numpy as np

__all__ = ["default_fps"]


def default_fps(times: np.ndarray) -> float:
    """Frames per second that play the run in real time, clamped to [5, 60] (30 if unknown).

    ``times``: frame times [s], shape (f,)."""
    if len(times) < 2:
        return 30.0
    dt = float(np.median(np.diff(times)))
    if not dt > 0:
        return 30.0
    fps = min(60.0, max(5.0, 1.0 / dt))
    # frame times are sums of steps: 1 / dt is 30.000000000000007 for dt = 1/30; a rate
    # within 1e-9 of a whole number is that number (video and USD headers show it)
    return float(round(fps)) if abs(fps - round(fps)) < 1e-9 * fps else float(fps)
