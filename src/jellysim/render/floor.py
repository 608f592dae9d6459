"""The floor a renderer draws under a body: world-fixed tiles of a round size (1, 2 or 5 x
10^k m, a scale for the eye), fading into the background towards a soft horizon, an optional
white plate painted on it, and a soft contact shadow under the body.

The floor is drawn unlit: its colour on screen is its texture times its vertex colour, so
where the fade reaches the background colour the floor's edge cannot be seen, and the shadow
patch (a finer grid over the body's footprint, sampling the same texture and darkened by its
vertex colours) joins the floor without a seam.
"""
from __future__ import annotations

import numpy as np

TILE_LIGHT = np.array([0xde, 0xd6, 0xca], dtype=np.float64)
TILE_DARK = np.array([0xcc, 0xc3, 0xb4], dtype=np.float64)
PLATE = np.array([0xfb, 0xfa, 0xf7], dtype=np.float64)
PLATE_RIM = np.array([0xe4, 0xe0, 0xd8], dtype=np.float64)

SHADOW_DARKEST = 0.5
"""The floor's brightness under a body resting on it (1: no shadow)."""

LIFT_BLUR = 0.3
"""The shadow's blur widens by this times the body's height above the floor [m / m]."""

PATCH_EXTENTS = 16.0
"""The floor patch spans this many motion extents; the fade reaches the background at its
edge (from :data:`FADE_START` of its half-width on)."""
FADE_START = 0.2

MAX_TEXELS = 2048
"""The floor texture's side at most [texels]; each tile spans a whole number of them."""


def round_tile(size: float) -> float:
    """A round tile side [m] (1, 2 or 5 x 10^k) near half of ``size`` [m]."""
    target = 0.5 * max(float(size), 1e-6)
    k = np.floor(np.log10(target))
    choices = np.array([1.0, 2.0, 5.0, 10.0]) * 10.0 ** k
    return float(choices[np.argmin(np.abs(np.log(choices / target)))])


def _hex_rgb(colour) -> np.ndarray:
    """An (r, g, b) in 0..255 for a colour name or #rrggbb (pyvista's parser)."""
    import pyvista as pv

    return np.asarray(pv.Color(colour).int_rgb, dtype=np.float64)


class Floor:
    """A floor patch [m] at height ``y`` centred near ``centre`` (x, z) and a shadow patch.

    ``extent``: the motion's size [m] (sets the patch and fade); ``body_size`` [m]: sets the
    tile and the shadow's softness; ``background``: the colour the floor fades into
    (``None``: a transparent picture's floor fades out, its texture's alpha);
    ``plate``: (centre x, z, radius) [m] of a white plate painted on the floor, or ``None``;
    ``shadow_span`` [m]: the body's largest horizontal size in any frame; ``spacing`` [m]: its
    typical distance between neighbouring points.
    The shadow patch lies in the floor's plane (a patch above it, seen at a slant, samples the
    tiles a pixel off along their edges), drawn over it by a polygon offset.
    """

    def __init__(self, pv, plotter, y, centre, extent, body_size, background,
                 plate=None, shadow_span=None, spacing=None):
        self.pv, self.plotter = pv, plotter
        # about half the body, or an eighth of what the camera frames (a body travelling
        # metres under a fixed camera: 5 cm tiles over 4 m of floor were a moire)
        self.tile = round_tile(max(float(body_size), float(extent) / 4.0))
        self.body_size = max(float(body_size), 1e-6)
        self.background = None if background is None else _hex_rgb(background)
        self.plate = plate
        half = 0.5 * PATCH_EXTENTS * max(float(extent), 1e-3)
        tiles = 2 * int(np.ceil(half / self.tile))                 # across the patch, even
        self.texels_per_tile = int(max(1, min(32, MAX_TEXELS // tiles)))
        if tiles * self.texels_per_tile > MAX_TEXELS:  # a very small tile: a larger round
            least = 2.0 * (half + 1e-12) / (MAX_TEXELS - 2)  # one, a texel or more
            k = 10.0 ** np.floor(np.log10(least))
            self.tile = float(next(c * k for c in (1.0, 2.0, 5.0, 10.0) if c * k >= least))
            tiles = 2 * int(np.ceil(half / self.tile))
        self.n_tiles = tiles
        self.side = tiles * self.tile                              # [m] the patch's side
        self.y = float(y)
        self.origin = None                                         # (x, z) of its corner [m]
        self.mesh = pv.Plane(center=(0.0, self.y, 0.0), direction=(0, 1, 0),
                             i_size=self.side, j_size=self.side, i_resolution=1, j_resolution=1)
        self._corners = np.array(self.mesh.points)
        self.actor = None
        self.move_to(centre)
        self.actor = plotter.add_mesh(self.mesh, texture=self._texture(), lighting=False,
                                      name="floor")
        # the shadow: a grid over the largest horizontal footprint plus its blur's reach
        span = float(shadow_span if shadow_span is not None else body_size)
        self.cell = min(max(span, 1e-6) / 24.0, self.body_size / 16.0)
        self.sigma_cells = max(1.0, 0.06 * self.body_size / self.cell)
        # each point covers the floor a point spacing wide (a coarse body's footprint filled)
        self.cover = max(1, int(np.ceil(float(spacing or 0.0) / self.cell)) | 1)
        margin = 4.0 * (self.sigma_cells * self.cell + LIFT_BLUR * self.body_size)
        n = int(np.ceil((span + 2.0 * margin) / self.cell)) + 1
        self.n_cells = max(8, min(n, 400))
        self.cell = (span + 2.0 * margin) / (self.n_cells - 1)
        self.shadow = pv.Plane(center=(0.0, self.y, 0.0), direction=(0, 1, 0),
                               i_size=self.cell * (self.n_cells - 1),
                               j_size=self.cell * (self.n_cells - 1),
                               i_resolution=self.n_cells - 1, j_resolution=self.n_cells - 1)
        self._shadow_local = np.array(self.shadow.points)
        self._shadow_local[:, [0, 2]] -= self._shadow_local[:, [0, 2]].min(axis=0)
        self.shadow.point_data["shade"] = np.full((self.shadow.n_points, 3), 255, np.uint8)
        self.shadow_actor = plotter.add_mesh(self.shadow, texture=self.actor.texture,
                                             scalars="shade", rgb=True, lighting=False,
                                             name="shadow")
        self.shadow_actor.mapper.SetResolveCoincidentTopologyToPolygonOffset()
        self.shadow_actor.mapper.SetRelativeCoincidentTopologyPolygonOffsetParameters(-2, -2)

    # ----------------------------------------------------------------------------- floor
    def move_to(self, centre) -> None:
        """Centre the patch near ``centre`` (x, z) [m], its corner on the tile grid (tiles stay
        where they are on the world); the texture is re-painted only when the corner moves."""
        cx, cz = float(centre[0]), float(centre[1])
        origin = (self.tile * np.round(cx / self.tile) - 0.5 * self.side,
                  self.tile * np.round(cz / self.tile) - 0.5 * self.side)
        if self.origin is not None and np.allclose(origin, self.origin, rtol=0, atol=1e-12):
            return
        self.origin = origin
        pts = self._corners.copy()
        pts[:, 0] += origin[0] + 0.5 * self.side
        pts[:, 2] += origin[1] + 0.5 * self.side
        self.mesh.points = pts
        self.mesh.active_texture_coordinates = self._uv(pts)
        if self.actor is not None:
            self.actor.texture = self._texture()
            self.shadow_actor.texture = self.actor.texture

    def _parity(self) -> int:
        """Which of the two checkers the patch shows (its corner's tile, odd or even)."""
        return int(round(self.origin[0] / self.tile) + round(self.origin[1] / self.tile)) % 2

    def _uv(self, pts) -> np.ndarray:
        return ((pts[:, [0, 2]] - np.asarray(self.origin)) / self.side).astype(np.float32)

    def image(self) -> np.ndarray:
        """The floor's texture, shape (n, n, 3) uint8: row i at z = origin z + (i + 0.5)
        texels (VTK puts an image's first row at v = 0), column j along x."""
        n = self.n_tiles * self.texels_per_tile
        texel = self.side / n
        t = ((np.arange(n) + 0.5) * texel).astype(np.float32)     # [m] from the corner
        ix = np.floor(t / self.tile + 1e-6).astype(np.int64)       # tile index along x, z
        ox, oz = (int(np.round(o / self.tile)) for o in self.origin)
        checker = ((ix[None, :] + ox) + (ix[:, None] + oz)) % 2 == 0
        img = np.where(checker[..., None], TILE_LIGHT.astype(np.float32),
                       TILE_DARK.astype(np.float32))              # (n, n, 3), float32
        if self.plate is not None:
            px, pz, radius = self.plate
            x = (self.origin[0] - px) + t[None, :]
            z = (self.origin[1] - pz) + t[:, None]
            d = (np.hypot(x, z) - radius) / texel             # [texels] out of its edge
            inside = np.clip(0.5 - d, 0.0, 1.0)[..., None]       # its edge anti-aliased
            rim = np.clip(0.5 - np.abs(d + 0.03 * radius / texel) + 0.03 * radius / texel,
                          0.0, 1.0)[..., None]                    # the outer 6 % of it
            img = (1.0 - inside) * img + inside * ((1.0 - rim) * PLATE + rim * PLATE_RIM)
        half = np.float32(0.5 * self.side)
        r = np.hypot(t[None, :] - half, t[:, None] - half) / half  # 0 at the centre
        s = np.clip((r - FADE_START) / (1.0 - FADE_START), 0.0, 1.0)
        fade = (s * s * (3.0 - 2.0 * s))[..., None]               # smoothstep to the edge
        if self.background is None:  # a transparent picture: the tiles, and their opacity
            self.opacity = np.repeat(255.0 * (1.0 - fade), 3, axis=2)  # (Renderer.render)
        else:
            img += fade * (self.background.astype(np.float32) - img)
        np.round(img, out=img)
        return np.clip(img, 0, 255, out=img).astype(np.uint8)

    def opacity_texture(self):
        """A transparent picture's floor opacity as a grey texture (white: opaque), laid as
        the tiles are (:meth:`image` first)."""
        tex = self.pv.Texture(np.clip(np.round(self.opacity), 0, 255).astype(np.uint8))
        tex.repeat, tex.interpolate, tex.mipmap = False, True, False
        return tex

    def _texture(self):
        """The texture of the patch where it is: without a plate one of two, painted once
        each (the patch moves by whole tiles: only the checker's parity changes; a following
        camera re-painted 1,728^2 texels a frame, 0.7 s), with a plate painted afresh."""
        cache = self.__dict__.setdefault("_textures", {})
        key = self._parity() if self.plate is None else None
        if key is not None and key in cache:
            self.opacity = cache[key][1]
            return cache[key][0]
        tex = self._paint()
        if key is not None:
            cache[key] = (tex, getattr(self, "opacity", None))
        return tex

    def _paint(self):
        tex = self.pv.Texture(self.image())
        tex.repeat = False
        tex.interpolate = True   # (tile edges soft over one texel, not jagged)
        tex.mipmap = False       # (software GL samples mipmaps slowly: +70 % a frame)
        return tex

    # ---------------------------------------------------------------------------- shadow
    def shade(self, points) -> np.ndarray:
        """The shadow patch's brightness factors (n_points,) in [SHADOW_DARKEST, 1] for a body
        whose points are ``points`` [m] (k, 3): each grid cell darkened by the lowest point
        above it (fully on the floor, half at 0.35 body sizes up), blurred by a Gaussian that
        widens with the body's height above the floor.  Also moves the patch under them."""
        from scipy.ndimage import gaussian_filter, maximum_filter

        p = np.asarray(points, dtype=np.float64)
        p = p[np.all(np.isfinite(p), axis=1)]
        n = self.n_cells
        if not len(p):
            return np.ones(self.shadow.n_points)
        mid = 0.5 * (p[:, [0, 2]].min(axis=0) + p[:, [0, 2]].max(axis=0))
        # the patch's grid is fixed to the floor (its corner on whole cells): a grid that
        # followed the footprint's centre by fractions of a cell re-rounded every point, and
        # a jello at rest flickered (the demo's frames 154, 166, 170, 178: ~2,000 pixels)
        corner = np.round((mid - 0.5 * self.cell * (n - 1)) / self.cell) * self.cell
        pts = self._shadow_local.copy()
        pts[:, 0] += corner[0]
        pts[:, 2] += corner[1]
        self.shadow.points = pts
        self.shadow.active_texture_coordinates = self._uv(pts)
        h = np.maximum(p[:, 1] - self.y, 0.0)
        w = np.exp(-np.log(2.0) * h / (0.35 * self.body_size))
        # each point darkens its cell fully and a neighbour by a weight that falls from 1 at
        # half a cell away to 0 at 3/4 of a cell (continuous in its position: rounded to one
        # cell, a point on a cell's edge that moved a micrometre flipped that cell)
        u = (p[:, [0, 2]] - corner) / self.cell
        near = np.round(u).astype(np.int64)
        occ = np.zeros(n * n)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                ij = near + (di, dj)
                t = np.clip(3.0 - 4.0 * np.abs(u - ij), 0.0, 1.0)
                keep = np.all((ij >= 0) & (ij < n), axis=1)
                np.maximum.at(occ, ij[keep, 1] * n + ij[keep, 0],
                              (w * t[:, 0] * t[:, 1])[keep])
        if self.cover > 1:
            occ = maximum_filter(occ.reshape(n, n), size=self.cover, mode="constant").ravel()
        lift = min(float(h.min()), self.body_size)  # (higher up, it has all but gone)
        sigma = self.sigma_cells + LIFT_BLUR * lift / self.cell
        blurred = gaussian_filter(occ.reshape(n, n), sigma, mode="constant")
        at = np.clip(np.round((pts[:, [0, 2]] - corner) / self.cell).astype(np.int64), 0, n - 1)
        # a filled footprint blurs to ~1 inside; a lone point to a faint smudge
        return 1.0 - (1.0 - SHADOW_DARKEST) * np.clip(blurred[at[:, 1], at[:, 0]] * 1.6,
                                                       0.0, 1.0)

    def update(self, points) -> None:
        """Put the shadow under ``points`` [m] (k, 3)."""
        f = self.shade(points)
        self.shadow.point_data["shade"][:] = np.round(255.0 * f).astype(np.uint8)[:, None]
        self.shadow.Modified()
