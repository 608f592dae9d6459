"""``jellysim view``: an interactive pyvista window over a saved trajectory.

Controls: the check box (bottom left) plays / pauses, the slider scrubs frames, the mouse
orbits (left drag), pans (shift + drag) and zooms (wheel); ``space`` also toggles play.
Needs a display (X11 / Wayland on Linux); without one it fails with a clear message.
"""
from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np

from .errors import JellysimError
from .render.offscreen import RenderOptions, Renderer
from .io.timing import real_time_playback

__all__ = ["display_problem", "has_display", "view_trajectory"]


def has_display() -> bool:
    """Whether an interactive window can be opened here: on Linux, an X display VTK's windows
    can connect to (``DISPLAY`` set and answering: a DISPLAY naming no server made VTK print
    "bad X server connection" and the viewer exit 0 having shown nothing, the reliability
    trial; ``WAYLAND_DISPLAY`` alone reaches VTK through XWayland's DISPLAY only)."""
    if not sys.platform.startswith("linux"):
        return True
    if not os.environ.get("DISPLAY"):
        return False
    return _x_answers()


def display_problem() -> str:
    """Why :func:`has_display` is False, in words."""
    display = os.environ.get("DISPLAY")
    return (f"DISPLAY = {display!r}: no X server answers there" if display else
            "no DISPLAY is set")


def _x_answers() -> bool:
    """Whether the X server of ``DISPLAY`` accepts a connection (True where libX11 cannot be
    loaded to ask: VTK then says what is wrong)."""
    import ctypes
    import ctypes.util

    try:
        x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    except OSError:
        return True
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = x11.XOpenDisplay(None)
    if not handle:
        return False
    x11.XCloseDisplay(handle)
    return True


def view_trajectory(traj, options=None, *, fps: float | None = None,
                    screenshot=None, autoplay: bool = False) -> None:
    """Open the viewer.  With ``screenshot`` (a ``.png`` path) the window is drawn at the
    first frame (or played once through with ``autoplay``), saved, and closed: for tests and
    thumbnails."""
    if not has_display():
        raise JellysimError(f"jellysim view needs a display ({display_problem()}). Use "
                            "'jellysim render TRAJECTORY -o video.mp4' to make a "
                            "video off screen, or run under xvfb-run.")
    if os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") == "vtkEGLRenderWindow":
        del os.environ["VTK_DEFAULT_OPENGL_WINDOW"]   # EGL windows cannot be interactive

    options = options or RenderOptions(size=(1024, 640))
    # the window's camera is the user's to orbit: one fixed framing, never moved per frame
    r = Renderer(traj, dataclasses.replace(options, camera="fixed"), offscreen=False)
    p = r.plotter
    last = traj.frame_count - 1
    stride = 1  # real time: a run saved faster than 60 frames/s steps k frames a tick
    if fps is None:
        shown, fps = real_time_playback(traj.times, np.arange(traj.frame_count))
        stride = int(shown[1] - shown[0]) if len(shown) > 1 else 1
    fps = float(fps)
    state = {"frame": 0, "playing": bool(autoplay)}
    text = p.add_text("", position="upper_left", font_size=10, name="time")

    def show(f: int) -> None:
        f = int(max(0, min(last, round(f))))
        state["frame"] = f
        r.set_frame(f)
        text.SetText(2, f"t = {traj.times[f]:.3f} s   frame {f} / {last}")

    slider = None
    if last > 0:
        slider = p.add_slider_widget(lambda v: show(v), [0, last], value=0, title="frame",
                                     pointa=(0.25, 0.06), pointb=(0.95, 0.06), fmt="%.0f",
                                     style="modern")

    def toggle(flag=None) -> None:
        state["playing"] = (not state["playing"]) if flag is None else bool(flag)

    p.add_checkbox_button_widget(toggle, value=state["playing"], position=(10, 10), size=30,
                                 color_on="#d81e3c", color_off="#999999")
    p.add_text("play", position=(48, 14), font_size=9)
    p.add_key_event("space", lambda: toggle())

    def tick(_step=None) -> None:
        if state["playing"] and last > 0:
            f = (state["frame"] + stride) % (last + 1)
            show(f)
            if slider is not None:
                slider.GetRepresentation().SetValue(f)
            p.render()

    show(0)
    if screenshot is not None:
        if autoplay:
            for _ in range(last):
                tick()
        p.show(auto_close=False, interactive=False)
        p.screenshot(str(screenshot))
        p.close()
        return
    p.add_timer_event(max_steps=10**9, duration=max(1, int(1000 / fps)), callback=tick)
    p.show(title="jellysim view")
