"""Automatic camera framing: one fixed camera that sees every frame of the motion.

Y is up (gravity is -y in jellysim scenes).  The camera looks at the centre of the bounding box
of all frames from a fixed elevated three-quarter direction, as close as keeps the corners of
every frame's bounding box inside the image with a margin (:func:`frame_motion`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Camera", "frame_motion", "view_direction"]

DEFAULT_DIRECTION = (1.6, 0.7, 1.0)
"""From the focal point towards the camera (x, y up, z)."""


def view_direction(azimuth: float | None = None, elevation: float | None = None) -> np.ndarray:
    """Unit vector from the focal point towards the camera for an ``azimuth`` [degrees]
    around the vertical y axis, from +x towards +z, and an ``elevation`` [degrees] above the
    horizontal; each left ``None`` takes :data:`DEFAULT_DIRECTION`'s (32.0 and 20.4)."""
    d = np.asarray(DEFAULT_DIRECTION, dtype=np.float64)
    d = d / np.linalg.norm(d)
    az = math.atan2(d[2], d[0]) if azimuth is None else math.radians(float(azimuth))
    el = math.asin(d[1]) if elevation is None else math.radians(float(elevation))
    return np.array([math.cos(el) * math.cos(az), math.sin(el), math.cos(el) * math.sin(az)])


@dataclass(frozen=True)
class Camera:
    position: tuple[float, float, float]
    """Camera position [m], shape (3,)."""
    focal_point: tuple[float, float, float]
    """Point looked at [m], shape (3,)."""
    up: tuple[float, float, float]
    """View-up direction [-], shape (3,)."""
    view_angle: float
    """Vertical field of view [degrees]."""

    def apply(self, plotter) -> None:
        """Set this camera on a pyvista plotter."""
        cam = plotter.camera
        cam.position = self.position
        cam.focal_point = self.focal_point
        cam.up = self.up
        cam.view_angle = self.view_angle
        plotter.reset_camera_clipping_range()


def frame_motion(positions: np.ndarray, size: tuple[int, int], *, view_angle: float = 30.0,
                 direction=DEFAULT_DIRECTION, margin: float = 0.9,
                 extra_points: np.ndarray | None = None, zoom: float = 1.0,
                 focus=None, keep: np.ndarray | None = None) -> Camera:
    """A camera that keeps all of ``positions`` in view.

    The camera looks at the centre of their bounding box from ``direction``, as close as the
    positions allow: each one's distance from the view axis, over the tangent of the half
    field of view it lies in (horizontal or vertical), plus its depth towards the camera,
    bounds the distance; the largest bound is taken.  A perspective image of a box is the
    convex hull of its corners' images, so giving the corners of boxes (each frame's, as the
    renderer does) keeps everything inside them in view.

    Parameters
    ----------
    positions: [m], shape (..., 3): every position of every frame to keep in view.
    size: image (width, height) in pixels.
    view_angle: vertical field of view [degrees].
    direction: from the focal point towards the camera (normalised here).
    margin: the fraction of each half field of view the box may fill (0.9: a tenth of the
        image is left free on each side; 1 = touching the image border).
    extra_points: more positions [m] (..., 3) to include (e.g. a floor patch).
    zoom: > 1 moves the camera closer by that factor (the framing then crops the motion).
    focus: [m] (3,): with ``zoom`` > 1, the point looked at instead of the motion's centre
        (the body where the picture should show it).
    keep: [m] (..., 3): positions a zoom may not crop (the body at ``focus``: the camera
        comes no closer than keeps them inside the image's border; a following camera zoomed
        3x stood inside a block and drew it solid red, session 28's re-trial).
    """
    pts = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if extra_points is not None:
        pts = np.concatenate([pts, np.asarray(extra_points, dtype=np.float64).reshape(-1, 3)])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) == 0:
        pts = np.zeros((1, 3))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center = 0.5 * (lo + hi)
    width, height = size
    vfov = math.radians(view_angle)
    hfov = 2.0 * math.atan(math.tan(vfov / 2.0) * width / height)
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    up = (0.0, 1.0, 0.0)
    if abs(d[1]) > 0.999:  # looking (nearly) straight down: +y is not "up" on the image
        n = float(np.hypot(d[0], d[2]))
        up = (-d[0] / n, 0.0, -d[2] / n) if n > 0 else (0.0, 0.0, -1.0)
    right = np.cross(-d, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, -d)
    rel = pts - center
    lateral = np.maximum(np.abs(rel @ right) / (margin * math.tan(hfov / 2.0)),
                         np.abs(rel @ true_up) / (margin * math.tan(vfov / 2.0)))
    extent = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-3)
    distance = max(float(np.max(rel @ d + lateral)), 1.05 * extent) / float(zoom)
    if focus is not None and zoom > 1.0:
        center = np.asarray(focus, dtype=np.float64).reshape(3)
        if keep is not None:  # (the same bound as above, for these alone, at the border)
            k = np.asarray(keep, dtype=np.float64).reshape(-1, 3) - center
            side = np.maximum(np.abs(k @ right) / math.tan(hfov / 2.0),
                              np.abs(k @ true_up) / math.tan(vfov / 2.0))
            distance = max(distance, float(np.max(k @ d + side)))
    pos = center + distance * d
    return Camera(tuple(pos.tolist()), tuple(center.tolist()), tuple(float(u) for u in up),
                  float(view_angle))
