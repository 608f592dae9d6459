"""Pictures and videos of saved trajectories (pyvista off screen; no display needed).

Read-only consumers of saved frames: nothing here changes a simulation.

* :mod:`.camera`: automatic framing that keeps the whole motion in view.
* :mod:`.offscreen`: :class:`~.offscreen.Renderer` (floor, lights, translucent skin, optional
  points and springs) producing one RGB image per trajectory frame.
* :mod:`.video`: writers for MP4 (H.264, imageio-ffmpeg), GIF and PNG frames, and
  :func:`~.video.render_trajectory`, the one call behind ``jellysim render``.

pyvista, vtk and imageio are imported only inside the functions that need them.
"""
__all__ = ["RenderOptions", "render_trajectory"]


def __getattr__(name):
    if name == "RenderOptions":
        from .offscreen import RenderOptions

        return RenderOptions
    if name == "render_trajectory":
        from .video import render_trajectory

        return render_trajectory
    raise AttributeError(name)
