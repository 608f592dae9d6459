"""Ready-made pin paths (handles trial, session 31: a sinusoidal shake of a jelly's base took
hand-written keyframes, 120-240 a second).

:func:`shake_path` gives the rows ``[t, dx, dy, dz]`` (s, m) of
:meth:`jellysim.Simulator.pin`'s ``path`` (and of a scene's ``[[handle]] shake`` table) for an
offset ``A sin(2 pi f (t - start))``.  The path is straight between keyframes, so with ``n``
keyframes a period its peaks reach ``A cos(pi / n)`` of ``A`` when a keyframe does not fall on
a peak (0.9952 A at the default 32), and it stops at ``start + seconds``, where the offset is
held (a whole number of half periods ends it back at zero).
"""
from __future__ import annotations

import numpy as np

from .errors import SceneError

__all__ = ["shake_path", "aliasing_notes"]


def shake_path(amplitude, frequency: float, *, seconds: float, start: float = 0.0,
               per_period: int = 32) -> np.ndarray:
    """Keyframes (k + 1, 4) of a sinusoidal shake: offset ``amplitude * sin(2 pi frequency
    (t - start))`` [m] for ``start <= t <= start + seconds`` [s] (the first row is the zero at
    ``start``: pinned earlier, the points stay still until then); ``amplitude`` [m], shape
    (3,) (the direction and size of the swing), ``frequency`` [Hz], ``per_period`` keyframes a
    period (at least 4).  Pin with it: ``sim.pin(base, path=js.shake_path((0.005, 0, 0), 3.0,
    seconds=2.0, start=sim.state.t))``."""
    def number(value, what, positive):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)) \
                or not np.isfinite(value) or value < 0 or (positive and value == 0):
            raise SceneError(f"shake_path: {what}, got {value!r}")
        return float(value)

    try:
        amp = np.asarray(amplitude, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise SceneError(f"shake_path: amplitude must be 3 numbers [m] (x, y, z: the "
                         f"swing's direction and size), got {amplitude!r}") from None
    if not np.all(np.isfinite(amp)):
        raise SceneError(f"shake_path: amplitude must be finite, got {amp.tolist()}")
    f = number(frequency, "frequency must be a number > 0 [Hz]", True)
    span = number(seconds, "seconds must be a time > 0 [s]", True)
    t0 = number(start, "start must be a time >= 0 [s]", False)
    if isinstance(per_period, bool) or not isinstance(per_period, (int, np.integer)) \
            or per_period < 4:
        raise SceneError(f"shake_path: per_period must be a whole number >= 4, got "
                         f"{per_period!r}")
    periods = span * f
    if not periods * per_period <= 1_000_000:  # (also inf: 1e308 Hz overflowed)
        raise SceneError(f"shake_path: {span:g} s at {f:g} Hz, {per_period} keyframes a "
                         f"period, is more than a million keyframes: shorten the shake or "
                         f"lower the frequency")
    if t0 + span > 1e9:
        raise SceneError(f"shake_path: start + seconds = {t0 + span:g} s: past any run "
                         f"(start and seconds are in seconds)")
    count = max(1, int(np.ceil(periods * per_period - 1e-9)))
    t = np.linspace(0.0, span, count + 1)  # (the first row: the zero offset at `start`, so a
    rows = np.empty((count + 1, 4))        # later start holds the points still until then)
    rows[:, 0] = t0 + t
    rows[:, 1:] = np.sin(2.0 * np.pi * f * t)[:, None] * amp
    rows[0, 1:] = 0.0
    return rows


def aliasing_notes(handles, frame_seconds: float) -> list[str]:
    """What to say of a scene's ``[[handle]]`` shakes faster than half the rate its frames
    are saved at (``frame_seconds`` [s] apart): the saved frames show a slower, false swing (a
    50 Hz shake saved at 60 frames/s reads as 10 Hz: resonance trial).  (The pin itself follows
    its path at the step ends: :func:`jellysim.handle_warnings.path_warnings` says when that
    is too coarse.)"""
    rate = 1.0 / float(frame_seconds)
    out = []
    for k, h in enumerate(handles or (), start=1):
        f = float((h.get("shake") or {}).get("frequency", 0.0))
        if f > 0.5 * rate:
            seen = abs(f - rate * round(f / rate))
            out.append(f"[[handle]] #{k} shakes at {f:g} Hz, faster than half the rate the "
                       f"frames are saved at ({rate:g} frames/s): the saved frames show a "
                       f"false {seen:.3g} Hz swing; save more frames ([output] every, or a "
                       f"smaller [integrator] dt, which the pin also needs: it follows its "
                       f"path at the step ends)")
    return out
