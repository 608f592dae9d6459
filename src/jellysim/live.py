"""``jellysim view scene.toml``: simulate live in a window and pull the jello with the mouse.

**Right-drag** on the jello grabs the body point nearest to the cursor's ray, with its tet
neighbours, and pulls that patch towards the cursor with a spring shared among its points
(:meth:`jellysim.simulator.Simulator.drag`: a pinch, not a point load), the cursor moving
on the plane through the grabbed point that faces the camera; releasing lets go.  Left-drag
orbits, shift-drag pans, the wheel zooms, ``space`` pauses.  The physical path only (a body
with a FEM material, e.g. the gelatin preset).
"""
from __future__ import annotations

import numpy as np

from .errors import JellysimError
from .viewer import display_problem, has_display
from .render.offscreen import JELLO_RED, _faces

__all__ = ["DragController", "view_live"]


class DragController:
    """The mouse spring, independent of any window: rays in, ``sim.drag`` calls out.

    A ray is ``(origin, direction)`` [m], each shape (3,): the line under the cursor.
    """

    def __init__(self, sim, *, stiffness: float | None = None, reach: float | None = None):
        self.sim = sim
        self.stiffness = stiffness
        x0 = sim.model.point_x0
        self.reach = (0.1 * float(np.ptp(x0, axis=0).max())) if reach is None else reach
        """Largest distance [m] from the ray at which a point is grabbed."""
        self.point: int | None = None
        self._plane = None

    def press(self, origin, direction) -> int | None:
        """Grab the point nearest to the ray (within ``reach``, nearest to the camera among
        near ties); returns its index or ``None``."""
        o = np.asarray(origin, dtype=np.float64)
        d = np.asarray(direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        x = self.sim.state.x
        along = (x - o) @ d
        dist = np.linalg.norm((x - o) - along[:, None] * d, axis=1)
        near = np.flatnonzero((dist <= self.reach) & (along > 0))
        if near.size == 0:
            return None
        # among points within reach, the one in front (smallest depth), then the closest
        best = near[np.lexsort((dist[near], np.round(along[near] / self.reach, 0)))[0]]
        self.point = int(best)
        self._plane = (x[best].copy(), d)
        self.sim.drag(self.point, x[best], self.stiffness)
        return self.point

    def move(self, origin, direction) -> np.ndarray | None:
        """Move the target to where the ray meets the grab plane; returns the target [m]."""
        if self.point is None:
            return None
        o = np.asarray(origin, dtype=np.float64)
        d = np.asarray(direction, dtype=np.float64)
        p0, n = self._plane
        denom = float(d @ n)
        if abs(denom) < 1e-12:
            return None
        target = o + d * float((p0 - o) @ n) / denom
        self.sim.drag(self.point, target, self.stiffness)
        return target

    def release(self) -> None:
        self.point = None
        self._plane = None
        self.sim.drag(None)


def view_live(scene, *, size=(1024, 640), screenshot=None, frames: int = 0) -> None:
    """Open a window that simulates ``scene`` (a :class:`~jellysim.scene.Scene`) live.
    With ``screenshot`` (a ``.png`` path) it runs ``frames`` frames, saves and closes."""

    import os

    if not has_display():
        raise JellysimError(f"jellysim view needs a display ({display_problem()}); run "
                            "under xvfb-run, or 'jellysim run' and 'render' off screen")

    if os.environ.get("VTK_DEFAULT_OPENGL_WINDOW") == "vtkEGLRenderWindow":
        del os.environ["VTK_DEFAULT_OPENGL_WINDOW"]
    import pyvista as pv
    import vtk


    model = scene.build_model()
    sim = scene.simulator(model)
    if not sim.physical:
        raise JellysimError(f"{scene.name}: live dragging needs a FEM material (e.g. [material] "
                            "preset = 'gelatin' with a tet body)")
    tri = model.body.triangles
    if tri is None or len(tri) == 0:
        from .geometry.tetra import boundary_faces

        tri = boundary_faces(model.fem.tets, model.point_count)
    p = pv.Plotter(window_size=size, lighting="light kit")
    p.set_background("#f4f1ec")
    surf = pv.PolyData(sim.state.x.copy(), _faces(np.asarray(tri)))
    p.add_mesh(surf, color=JELLO_RED, opacity=0.85, smooth_shading=True, specular=0.6)
    lo, hi = sim.state.x.min(axis=0), sim.state.x.max(axis=0)
    ext = float(np.max(hi - lo))
    c = 0.5 * (lo + hi)
    floor = None
    ground = scene.params.get("ground", {})
    if ground.get("enabled", True):  # the renderer's floor: tiles, horizon, contact shadow
        from .render.floor import Floor
        from .render.offscreen import FLOOR_BELOW, _spacing

        floor = Floor(pv, p, float(ground.get("height", 0.0)) - FLOOR_BELOW * 3 * ext,
                      (c[0], c[2]), 3 * ext, ext, "#f4f1ec", shadow_span=2 * ext,
                      spacing=_spacing(sim.state.x))
        floor.update(sim.state.x)
    p.add_text("right-drag: pull the jello   space: pause", position="upper_left",
               font_size=9)
    ctl = DragController(sim)
    state = {"playing": True}
    ren = p.renderer

    def ray(xy):
        pts = []
        for z in (0.0, 1.0):
            ren.SetDisplayPoint(float(xy[0]), float(xy[1]), z)
            ren.DisplayToWorld()
            w = ren.GetWorldPoint()
            pts.append(np.array(w[:3]) / w[3])
        return pts[0], pts[1] - pts[0]

    style = vtk.vtkInteractorStyleTrackballCamera()

    def on_press(obj, _event):
        ctl.press(*ray(p.iren.interactor.GetEventPosition()))

    def on_move(obj, _event):
        if ctl.point is not None:
            ctl.move(*ray(p.iren.interactor.GetEventPosition()))
        else:
            obj.OnMouseMove()

    def on_release(obj, _event):
        ctl.release()

    style.AddObserver("RightButtonPressEvent", on_press)
    style.AddObserver("MouseMoveEvent", on_move)
    style.AddObserver("RightButtonReleaseEvent", on_release)
    p.iren.interactor.SetInteractorStyle(style)
    p.add_key_event("space", lambda: state.update(playing=not state["playing"]))

    def tick(_step=None):
        if state["playing"]:
            sim.advance(1)
            surf.points = sim.state.x
            if floor is not None:
                floor.update(sim.state.x)
            p.render()

    p.camera_position = "xy"
    p.camera.elevation = 25
    p.reset_camera(bounds=surf.bounds)  # frame the jello, not the floor
    p.camera.zoom(0.7)
    if screenshot is not None:
        for _ in range(int(frames)):
            tick()
        p.show(auto_close=False, interactive=False)
        p.screenshot(str(screenshot))
        p.close()
        return
    p.add_timer_event(max_steps=10**9, duration=max(1, int(1000 * scene.params["integrator"]
                                                            ["dt"])), callback=tick)
    p.show(title=f"jellysim view {scene.name}")
