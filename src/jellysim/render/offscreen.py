"""Off-screen rendering of a saved trajectory with pyvista (EGL: no display needed)."""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import JellysimError
from .camera import Camera, frame_motion, view_direction

__all__ = ["RenderOptions", "Renderer", "ground_height"]

JELLO_RED = "#d81e3c"

FLOOR_BELOW = 0.003
"""The floor is drawn this fraction of the motion's extent below the ground height (0.3 mm
for a 10 cm jello), the contact shadow half as far: both then lie strictly under the skin,
whose points below the ground are lifted exactly onto it.  (0.001 still z-fought a resting
box's flat bottom at 2400 x 1350 pixels: the floor spans 100 extents, so the depth buffer's
steps there are coarse.)"""

FOLLOW_RATIO = 8.0
"""``camera = "auto"`` follows a body whose horizontal travel exceeds this many body sizes
(4 until session 28: a block slid 17 cm, 4.3 of its sizes, was followed, so it stood still in
the picture and the slide of a friction lesson did not show: teacher trial)."""


@dataclass(frozen=True)
class RenderOptions:
    """How a trajectory is drawn."""

    size: tuple[int, int] = (960, 540)
    """Image (width, height) [pixels]; rounded up to even numbers (H.264 needs them)."""
    color: str = JELLO_RED
    """Skin colour (any matplotlib/pyvista colour: name or ``#rrggbb``)."""
    opacity: float = 0.7
    """Skin opacity in (0, 1]."""
    show_points: bool = False
    """Draw the mass points as small spheres."""
    show_springs: bool = False
    """Draw the springs as lines."""
    show_skin: bool = True
    """Draw the skin (or the body's surface triangles when it has no skin)."""
    floor: bool = True
    """Draw the floor at the ground height."""
    shadow: bool = True
    """Draw a contact shadow: the skin's silhouette on the floor, straight below it."""
    plate: bool = False
    """Draw a round white plate on the floor under the body's last position."""
    clock: bool = False
    """Write the simulated time of each frame (``time 0.517 s``) in the upper right corner."""
    antialias: bool = True
    """Smooth the edges: on a software rasteriser (no GPU), where multisampling changed
    nothing, VTK's post-process pass (FXAA: 38 -> 61 ms per 960 x 540 frame of the demo); on
    a GPU its multisampling.  Without it silhouettes are jagged and shimmer in a video (the
    artist trial)."""
    background: str = "#f4f1ec"
    """Background colour, or ``"transparent"`` (PNG output only: an alpha channel, 0 where
    nothing is drawn; with ``floor = False`` the body alone)."""
    azimuth: float | None = None
    """Camera azimuth [degrees] around the vertical, from +x towards +z (None: 32)."""
    elevation: float | None = None
    """Camera elevation [degrees] above the horizontal (None: 20.4; 90: from above)."""
    zoom: float = 1.0
    """> 1 moves the camera closer (the automatic framing keeps the whole motion at 1),
    centred on the body at frame :attr:`zoom_on`."""
    zoom_on: int = -1
    """The frame whose body a zoom above 1 centres the picture on (-1: the last, where a
    dropped or slid jello rests; ``render --frame N``: N).  Until session 28 a zoom moved
    towards the middle of the whole motion: zoomed 3x, a cube dropped 20 cm was out of the
    picture (teacher trial)."""
    camera: str = "auto"
    """``"fixed"``: one camera that sees the whole motion; ``"follow"``: the camera moves
    with the body across the floor (its height and view stay), framing the body's largest
    extent; ``"auto"``: follow when the body travels more than :data:`FOLLOW_RATIO` times
    its own size (it would be a speck in a fixed frame), else fixed."""

    def even_size(self) -> tuple[int, int]:
        w, h = (int(s) for s in self.size)
        if w < 16 or h < 16:
            raise JellysimError(f"image size must be at least 16 x 16 pixels, got {w} x {h}")
        if w % 2 or h % 2:  # (H.264 wants even sides; said, not silently changed)
            warnings.warn(f"image size {w}x{h} rounded up to {w + w % 2}x{h + h % 2}: "
                          "pictures and videos are made with even sides", UserWarning,
                          stacklevel=3)
        return w + (w % 2), h + (h % 2)


def ground_height(traj) -> float | None:
    """The ground plane's height [m] from the run's parameters, ``None`` if disabled or not
    recorded (a Python recording of states alone: ``Recorder.record(sim)`` keeps it)."""
    g = traj.params.get("ground") if isinstance(traj.params, dict) else None
    if not g or not g.get("enabled", True):
        return None
    return float(g.get("height", 0.0))


def _import_pyvista(offscreen: bool = True):
    if offscreen:
        # EGL renders without an X server; it also silences VTK's "no display" warning
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista as pv
    except ImportError as exc:
        raise JellysimError("rendering needs pyvista: pip install 'jellysim[render]' "
                            f"({exc})") from None
    return pv


_SOFTWARE_GL: list = []


def _software_gl(pv) -> bool:
    """Whether OpenGL is a software rasteriser (Mesa's llvmpipe on a machine without a GPU,
    as these machines and CI have).  There pyvista's default 8x multisampling gave the same
    picture (the demo's frame 40: 563 pixels differ, by at most 3 of 255) at 1.8x the time
    (120 -> 68 ms a 960 x 540 frame), so off-screen renders turn it off; a GPU keeps it.
    Asked once per process (about 0.7 s: a small window reports its renderer)."""
    if not _SOFTWARE_GL:
        try:
            name = str(pv.GPUInfo().renderer).lower()
        except Exception:  # (no report: keep the default)
            name = ""
        _SOFTWARE_GL.append(any(k in name for k in ("llvmpipe", "softpipe", "swrast",
                                                    "swiftshader")))
    return _SOFTWARE_GL[0]


def _faces(tri: np.ndarray) -> np.ndarray:
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    return np.hstack([np.full((len(tri), 1), 3, dtype=np.int64), tri]).ravel()


def _spacing(x) -> float:
    """The median distance [m] from a point of ``x`` (n, 3) to its nearest neighbour (0 for
    fewer than two finite points)."""
    from scipy.spatial import cKDTree

    x = np.asarray(x, dtype=np.float64)
    x = x[np.all(np.isfinite(x), axis=1)]
    if len(x) < 2:
        return 0.0
    return float(np.median(cKDTree(x).query(x, k=2)[0][:, 1]))


_CORNERS = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
"""Which of (lower, upper) each of a box's eight corners takes per axis."""


def _frame_boxes(traj, surface_frames, chunk: int = 32) -> np.ndarray:
    """Each frame's bounding box of points and surface [m], shape (F, 2, 3) (lower, upper;
    NaN for a frame with no finite position).  Never expands every frame's surface at once."""
    boxes = []
    for start in range(0, traj.frame_count, chunk):
        sl = slice(start, min(start + chunk, traj.frame_count))
        blocks = [np.asarray(traj.positions[sl], dtype=np.float64)]
        if surface_frames is not None:
            blocks.append(np.asarray(surface_frames(sl), dtype=np.float64))
        a = np.concatenate(blocks, axis=1)                       # (c, m, 3)
        a = np.where(np.isfinite(a), a, np.nan)
        with warnings.catch_warnings():  # a frame of a failed run may hold no finite point
            warnings.simplefilter("ignore", RuntimeWarning)
            boxes.append(np.stack([np.nanmin(a, axis=1), np.nanmax(a, axis=1)], axis=1))
    return np.concatenate(boxes) if boxes else np.zeros((0, 2, 3))


def _motion_bounds(box) -> np.ndarray:
    """The eight corners [m] of each frame's box (:func:`_frame_boxes`), stacked: shape
    (8 F', 3) (frames with no finite position left out)."""
    box = box[np.all(np.isfinite(box), axis=(1, 2))]
    if not len(box):
        raise JellysimError("the trajectory has no finite positions to draw")
    return box[:, _CORNERS, [0, 1, 2]].reshape(-1, 3)


def _body_track(box, mode: str):
    """For a following camera: (each frame's horizontal body centre [m], shape (F, 3) with
    y = 0; the half-extents [m] (3,) of the largest box around the body in any frame), or
    ``None`` for a fixed camera (``mode`` "fixed", or "auto" and the body stays near)."""
    if mode not in ("auto", "fixed", "follow"):
        raise JellysimError(f"camera must be 'auto', 'fixed' or 'follow', got {mode!r}")
    if mode == "fixed" or len(box) < 2:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        half = np.nan_to_num(np.nanmax(0.5 * (box[:, 1] - box[:, 0]), axis=0))
    centre = 0.5 * (box[:, 0] + box[:, 1])
    good = np.all(np.isfinite(centre), axis=1)
    if not good.any():
        return None
    last_good = np.maximum.accumulate(np.where(good, np.arange(len(good)), -1))
    centre = centre[np.where(last_good >= 0, last_good, np.argmax(good))]
    centre[:, 1] = 0.0
    travel = float(np.max(np.ptp(centre[:, [0, 2]], axis=0)))
    size = 2.0 * float(np.max(half))
    if mode == "auto" and not travel > FOLLOW_RATIO * size:
        return None
    return centre, half


def _surface_of(traj, o):
    """(frames -> surface vertices [m], faces) a renderer draws for ``traj``: its skin, else
    its surface triangles; ``(None, None)`` for points and springs only."""
    if o.show_skin and traj.skin is not None:
        return (lambda f: traj.skin_positions(f)), traj.skin.faces
    if o.show_skin and len(traj.triangles):
        return (lambda f: traj.positions[f]), traj.triangles
    return None, None


class Renderer:
    """Draws frames of a :class:`~jellysim.io.trajectory.Trajectory`.

    The scene (floor, lights, meshes, camera) is built once; :meth:`render` moves the
    vertices of frame ``f`` into place and returns the image, shape (height, width, 3), uint8.
    The trajectory is only read.
    """

    def __init__(self, traj, options: RenderOptions = RenderOptions(), *, offscreen=True,
                 plotter=None, frame_with=(), label: str | None = None):
        """``frame_with``: other trajectories whose motion the camera frames too (side by
        side panels at one scale; the camera is then fixed); ``label``: a caption."""
        pv = _import_pyvista(offscreen)
        self.pv = pv
        self.traj = traj
        self.options = options
        o = options
        self.size = o.even_size()
        self.skin = traj.skin
        self._surface_frames, faces = _surface_of(traj, o)
        show_points = o.show_points or (self._surface_frames is None and not o.show_springs)
        self.plotter = plotter if plotter is not None else pv.Plotter(
            off_screen=offscreen, window_size=self.size, lighting="light kit")
        p = self.plotter
        if plotter is None and offscreen and (_software_gl(pv) or not o.antialias):
            p.disable_anti_aliasing()  # (see _software_gl)
            if o.antialias:  # (VTK's FXAA pass: the one smoothing that works there; pyvista's
                p.renderer.SetUseFXAA(True)  # own call would switch to SSAA, at 3x the cost)
        self._transparent = o.background == "transparent"
        p.set_background("white" if self._transparent else o.background)

        boxes = _frame_boxes(traj, self._surface_frames)  # (the surface expanded once)
        motion = _motion_bounds(boxes)                         # (8 F', 3) box corners
        for other in frame_with:
            motion = np.vstack([motion, _motion_bounds(
                _frame_boxes(other, _surface_of(other, o)[0]))])
        lo, hi = motion.min(axis=0), motion.max(axis=0)
        self._track = None if frame_with else _body_track(boxes, o.camera)
        gh = ground_height(traj)
        extra = self.floor = self.shadow = self._floor = None
        below = o.elevation is not None and o.elevation < 0 and gh is not None
        if o.floor and below:  # (its opaque underside hid the body)
            warnings.warn(f"elevation {o.elevation:g} deg: the camera looks up from below the "
                          "floor, so the floor is not drawn (it would hide the body)",
                          UserWarning, stacklevel=2)
        if o.floor and gh is not None and not below:  # no ground in the run: no floor
            from .floor import Floor

            floor_y = gh
            ext = float(np.max(hi - lo))
            c = 0.5 * (lo + hi)
            if self._track is not None:  # a floor patch that travels with the camera (its
                c = self._track[0][0]    # tiles stay on the world), so the clipping range
                #                          stays the body's
                ext = 2.0 * float(np.max(self._track[1]))
            sizes = boxes[:, 1] - boxes[:, 0]
            sizes = sizes[np.all(np.isfinite(sizes), axis=1)]
            body = float(np.max(sizes[0])) if len(sizes) else ext
            span = float(np.max(sizes[:, [0, 2]])) if len(sizes) else ext
            plate = None
            extra = np.array([[lo[0], floor_y, lo[2]], [hi[0], floor_y, hi[2]]])
            if o.plate:  # painted on the floor under where the body comes to rest
                x0 = np.asarray(traj.positions[-1])
                mid = 0.5 * (x0.min(axis=0) + x0.max(axis=0))
                # 1.6x the footprint's circumradius: a round jelly's plate as before (0.8x
                # its width); a cube's had shown a sliver beyond its corners (teacher trial)
                radius = 1.6 * float(np.max(np.hypot(x0[:, 0] - mid[0], x0[:, 2] - mid[2])))
                plate = (float(mid[0]), float(mid[2]), radius)
                rim = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)  # framed whole
                extra = np.vstack([extra, np.stack([mid[0] + radius * np.cos(rim),
                                                    np.full(16, floor_y),
                                                    mid[2] + radius * np.sin(rim)], axis=1)])
            # drawn a hair below the ground (the shadow in its plane): a skin resting on it is lifted onto y = floor_y (Skin.deform), and a floor in that
            # plane z-fights it (a saw-toothed contact patch through the translucent jello,
            # session 14's trial)
            self._floor = Floor(pv, p, floor_y - FLOOR_BELOW * ext, (c[0], c[2]), ext, body,
                                None if self._transparent else o.background, plate=plate,
                                shadow_span=span, spacing=_spacing(traj.positions[0]))
            self.floor, self.shadow = self._floor.mesh, self._floor.shadow
            if not o.shadow:
                p.remove_actor(self._floor.shadow_actor)
                self.shadow = None
        near = self._add_obstacles(traj, lo, hi)  # the solids the body meets: framed too
        if near is not None:
            extra = near if extra is None else np.vstack([extra, near])
        direction = view_direction(o.azimuth, o.elevation)
        focus = keep = None  # a zoom's centre: the body at frame zoom_on, kept whole
        if o.zoom > 1.0 and len(boxes) and np.all(np.isfinite(boxes[o.zoom_on % len(boxes)])):
            seen = boxes[o.zoom_on % len(boxes)]
            focus, keep = seen.mean(axis=0), seen[_CORNERS, [0, 1, 2]]
        if self._track is None:
            self.camera = frame_motion(motion, self.size, extra_points=extra, zoom=o.zoom,
                                       direction=direction, focus=focus, keep=keep)
        else:  # framed on the body's largest box, moved with its centre (see set_frame)
            half = self._track[1]
            box = np.array([-half, half])
            box[:, 1] = lo[1], hi[1]
            if self.floor is not None:
                box[0, 1] = min(box[0, 1], floor_y)
            if focus is not None:  # (the track moves it across the floor)
                focus = np.array([0.0, focus[1], 0.0])
                keep = keep - self._track[0][o.zoom_on % len(boxes)]
            self.camera = frame_motion(box[_CORNERS, [0, 1, 2]], self.size, zoom=o.zoom,
                                       direction=direction, focus=focus, keep=keep)

        self.surface = self.points = self.springs = None
        if self._surface_frames is not None:
            from ..geometry.creases import split_creases

            rest = np.asarray(self._surface_frames(0))  # creases (a box's edges) kept hard
            self._crease_source, split = split_creases(rest, faces)
            self.surface = pv.PolyData(rest[self._crease_source], _faces(split))
            p.add_mesh(self.surface, color=o.color, opacity=o.opacity, smooth_shading=True,
                       specular=0.6, specular_power=30, ambient=0.25, diffuse=0.8,
                       name="skin")
        if show_points:
            self.points = pv.PolyData(np.array(traj.positions[0]))
            p.add_mesh(self.points, color="#7a0f1f", point_size=max(2.0, 0.004 * self.size[1]),
                       render_points_as_spheres=False, name="points")
            # (as spheres, VTK's imposters lost to the floor's depth on the left half of the
            # picture under software GL: half the body's points vanished, the scale trial)
        if o.show_springs and len(traj.springs):
            lines = np.hstack([np.full((len(traj.springs), 1), 2, dtype=np.int64),
                               traj.springs.astype(np.int64)]).ravel()
            self.springs = pv.PolyData(np.array(traj.positions[0]), lines=lines)
            p.add_mesh(self.springs, color="#5a1020", opacity=0.35, line_width=1.0,
                       name="springs")
        self.camera.apply(p)
        self._beside = bool(frame_with) and bool(label)  # (a panel of several, captioned)
        if label:
            p.add_text(label, position="upper_left", font_size=max(8, self.size[1] // 40),
                       color="#3a3530", name="label")
        if self._track is not None:
            self.set_frame(0)  # the following camera's place at the first frame

    def _add_obstacles(self, traj, lo, hi):
        """The run's ``[[obstacle]]`` solids (spheres, boxes) in grey; planes as a patch
        three times the motion's size around the point nearest its centre.  Returns the
        bounding-box corners [m] (k, 3) of the solids within half the motion's size of it
        (to keep in the picture), or ``None``."""
        tables = traj.params.get("obstacle") if isinstance(traj.params, dict) else None
        if not tables:
            return None
        reach = 0.5 * float(np.max(hi - lo))
        near = []
        from ..scene_obstacles import make_obstacle
        from ..physics.contact import Box, Sphere

        pv, size = self.pv, 3.0 * max(float(np.max(hi - lo)), 1e-3)
        for k, table in enumerate(tables):
            ob = make_obstacle(table)
            box = None
            if isinstance(ob, Sphere):
                mesh = pv.Sphere(radius=float(ob.radius), center=tuple(ob.center),
                                 theta_resolution=64, phi_resolution=32)
                box = np.array([np.subtract(ob.center, ob.radius), np.add(ob.center, ob.radius)])
            elif isinstance(ob, Box):
                (x0, y0, z0), (x1, y1, z1) = ob.lower, ob.upper
                mesh = pv.Box(bounds=(x0, x1, y0, y1, z0, z1))
                box = np.array([ob.lower, ob.upper], dtype=np.float64)
            else:
                n = np.asarray(ob.normal, dtype=np.float64)
                n = n / np.linalg.norm(n)
                c = 0.5 * (lo + hi)
                c = c - ((c - np.asarray(ob.point, dtype=np.float64)) @ n) * n
                mesh = pv.Plane(center=tuple(c), direction=tuple(n), i_size=size, j_size=size)
            self.plotter.add_mesh(mesh, color="#9da3a8", ambient=0.3, diffuse=0.7,
                                  specular=0.2, smooth_shading=not isinstance(ob, Box),
                                  name=f"obstacle{k}")  # (a box's edges stay sharp)
            if box is not None and np.all(box[0] <= hi + reach) and np.all(box[1] >= lo - reach):
                near.append(box[_CORNERS, [0, 1, 2]])             # its eight corners
        return np.concatenate(near) if near else None

    def _shadow_points(self, f: int) -> np.ndarray:
        """What casts the contact shadow at frame ``f``: the points and the drawn surface [m]."""
        x = np.asarray(self.traj.positions[f], dtype=np.float64)
        if self._surface_frames is None:
            return x
        return np.vstack([x, np.asarray(self._surface_frames(f), dtype=np.float64)])

    def set_frame(self, f: int) -> None:
        """Move every drawn mesh (and a following camera) to frame ``f``."""
        x = self.traj.positions[f]
        if self._track is not None:
            shift = self._track[0][f]
            if self._floor is not None:
                self._floor.move_to(shift[[0, 2]])
            c = self.camera
            Camera(tuple(np.add(c.position, shift)), tuple(np.add(c.focal_point, shift)),
                   c.up, c.view_angle).apply(self.plotter)
        if self.shadow is not None:
            self._floor.update(self._shadow_points(f))
        if self.surface is not None:
            self.surface.points = np.asarray(self._surface_frames(f))[self._crease_source]
            self.surface.compute_normals(inplace=True, cell_normals=False, split_vertices=False)
        if self.points is not None:
            self.points.points = x
        if self.springs is not None:
            self.springs.points = x
        if self.options.clock:  # (a text actor of the same name replaces the last)
            # in captioned panels side by side, at the foot: at the top right it ran into
            # the next panel's caption ("time 0.500 s  torus", the artist trial)
            self.plotter.add_text(f"time {float(self.traj.times[f]):.3f} s ",
                                  position="lower_right" if self._beside else "upper_right",
                                  name="clock", color="#3a3530",
                                  font_size=max(8, self.size[1] // 40))

    def render(self, f: int) -> np.ndarray:
        """Image of frame ``f``, shape (height, width, 3), uint8."""
        self.set_frame(f)
        if self._transparent and self._floor is not None:
            return self._fading_out()
        self.plotter.render()
        img = self.plotter.screenshot(return_img=True,
                                      transparent_background=self._transparent)
        if self._transparent:  # (height, width, 4): the alpha channel kept
            return np.ascontiguousarray(img)
        return np.ascontiguousarray(img[..., :3])

    def _fading_out(self) -> np.ndarray:
        """A transparent picture with a floor, (height, width, 4): the picture as drawn, its
        alpha the drawn body's (the floor hidden) over the floor's opacity (a render of the
        floor alone, its tiles replaced by their opacity), ``a + m (1 - a)``: the floor fades
        out towards its horizon instead of into a white band (session 21's trial)."""
        p, fl = self.plotter, self._floor

        def shot():
            p.render()
            return p.screenshot(return_img=True, transparent_background=True).astype(float)

        full = shot()
        own = [fl.actor] + ([fl.shadow_actor] if self.shadow is not None else [])
        others = [a for a in p.actors.values() if all(a is not b for b in own)]
        shown = {id(a): a.GetVisibility() for a in others}
        tiles = fl.actor.texture
        try:
            for a in own:
                a.SetVisibility(False)
            body = shot()[..., 3] / 255.0
            for a in others:
                a.SetVisibility(False)
            fl.actor.SetVisibility(True)
            fl.actor.texture = fl.opacity_texture()
            p.set_background("black")  # (a pixel the floor's edge half covers: half grey)
            m = shot()[..., 0] / 255.0
        finally:
            p.set_background("white")
            fl.actor.texture = tiles
            for a in own:
                a.SetVisibility(True)
            for a in others:
                a.SetVisibility(shown[id(a)])
        full[..., 3] = 255.0 * (body + m * (1.0 - body))
        return np.ascontiguousarray(np.clip(np.round(full), 0, 255).astype(np.uint8))

    def close(self) -> None:
        self.plotter.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
