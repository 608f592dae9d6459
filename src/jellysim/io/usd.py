"""USD export: the skin as one mesh with time-sampled points (``.usdc`` / ``.usda``).

The stage is Y-up, 1 unit = 1 m, ``timeCodesPerSecond`` = the chosen frame rate, one time code
per trajectory frame (time code ``k`` = frame ``k``).  The mesh has time-sampled vertex
normals (area-weighted: it shades smooth, as jellysim's own renders; per face corner where
the first frame has a crease, so a box keeps its edges, as in the glTF export), the mesh
file's texture
coordinates when it had some (the face-varying primvar ``st``), and a
``UsdPreviewSurface`` material of the renders' jello red, translucent (opacity 0.7), bound to
it.  Opens in Blender, Houdini, usdview.  Needs ``usd-core`` (``pip install
'jellysim[usd]'``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import JellysimError
from .atomic import atomic_path
from .texture import JELLO_RGBA
from .timing import frame_rate

__all__ = ["export_usd", "surface_of", "surface_uv", "vertex_normals"]


class _Frames:
    """Lazy sequence of surface vertex arrays [m], each (m, 3): one per trajectory frame."""

    def __init__(self, traj, skin: bool):
        self.traj, self.skin = traj, skin

    def __len__(self) -> int:
        return self.traj.frame_count

    def __getitem__(self, k):
        if isinstance(k, (slice, np.ndarray, list)):
            idx = np.arange(len(self))[k]
            return np.stack([self[int(i)] for i in idx]) if len(idx) else np.zeros((0, 0, 3))
        return (self.traj.skin_positions(k) if self.skin else self.traj.positions[k])

    def __iter__(self):
        return (self[k] for k in range(len(self)))


def surface_of(traj):
    """The surface to export: ``(frames, faces (f, 3))`` where ``frames[k]`` are frame k's
    vertices [m] (m, 3), computed on demand (a long run is never expanded all at once).

    The skin when the trajectory has one, else the body's surface triangles."""
    if traj.skin is not None:
        return _Frames(traj, True), traj.skin.faces
    if len(traj.triangles):
        return _Frames(traj, False), np.asarray(traj.triangles, dtype=np.int64)
    raise JellysimError("this trajectory has no skin and no surface triangles to export; "
                        "export it as ParaView (.pvd) instead")


def surface_uv(traj) -> np.ndarray | None:
    """Texture coordinates [-] (f, 3, 2) of each corner of :func:`surface_of`'s faces: the
    skin's, when its mesh file had some (:mod:`jellysim.geometry.texcoords`), else ``None``."""
    return None if traj.skin is None else traj.skin.uv


def inside_out_note(traj) -> str | None:
    """A warning when the surface to export (:func:`surface_of`) encloses a negative volume in
    some frame while it encloses a positive one in the first: the body passed through itself
    and its faces point inward there.  ``None`` when no frame is inside out."""
    try:
        frames, faces = surface_of(traj)
    except JellysimError:
        return None
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    if np.any(np.unique(edges, axis=0, return_counts=True)[1] != 2):
        return None  # an open surface encloses no volume to check

    from ..geometry.shells import face_volumes_x6

    def volume(v):  # [m^3], the divergence theorem over the triangles
        return float(face_volumes_x6(v, faces).sum()) / 6.0

    if not volume(frames[0]) > 0:
        return None
    bad = [k for k in range(1, len(frames)) if volume(frames[k]) < 0]
    if not bad:
        return None
    return (f"the body's surface is inside out in {len(bad)} of {len(frames)} frames (from "
            f"t = {float(traj.times[bad[0]]):.3g} s): the body passed through itself (the "
            "report's step does this to the paper cube as it lands, docs/physics.md section 4);"
            " a viewer that hides back faces shows little of it there")


def _time_codes(times, count: int, fps: float) -> list[float]:
    """Each frame's USD time code: its simulated time since the first frame x ``fps`` (whole
    numbers for evenly spaced frames; a shorter last interval, or a stage rate other than the
    run's, still plays in real time)."""
    t = np.asarray(times, dtype=np.float64)[:count]
    if len(t) != count:  # (no times for these frames: one code per frame)
        return [float(k) for k in range(count)]
    codes = (t - t[0]) * fps
    snapped = np.round(codes)
    codes = np.where(np.abs(codes - snapped) < 1e-6, snapped, codes)
    for k in range(1, count):  # a frame recorded twice (or out of order): just after the one
        if codes[k] <= codes[k - 1]:  # before it, so that no sample is lost
            codes[k] = codes[k - 1] + 1e-3
    return codes.tolist()


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit vertex normals, shape (m, 3): the area-weighted sum of the faces' normals
    (counter-clockwise faces: outward on a closed skin); 0 for a vertex on no face."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # |.| = 2 x area
    n = np.zeros_like(v)
    for c in range(3):
        for k in range(3):
            n[:, k] += np.bincount(f[:, c], face_n[:, k], minlength=len(v))
    length = np.linalg.norm(n, axis=1)
    return n / np.where(length > 0, length, 1.0)[:, None]


def _preview_material(stage, prim, where: str, texture: str | None = None):
    """A UsdPreviewSurface (the material prim ``where``) of the renders' jello red,
    translucent, bound to ``prim`` (the mesh, or a face subset of it); with ``texture`` (an
    asset path) opaque, its colour read from the image at the ``st`` UVs."""
    from pxr import Gf, Sdf, UsdShade

    material = UsdShade.Material.Define(stage, Sdf.Path(where))
    shader = UsdShade.Shader.Define(stage, Sdf.Path(f"{where}/surface"))
    shader.CreateIdAttr("UsdPreviewSurface")
    colour = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
    if texture is None:
        colour.Set(Gf.Vec3f(*JELLO_RGBA[:3]))
    else:
        reader = UsdShade.Shader.Define(stage, Sdf.Path(f"{where}/st"))
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
        image = UsdShade.Shader.Define(stage, Sdf.Path(f"{where}/texture"))
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(texture))
        image.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("repeat")
        image.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("repeat")
        image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
            reader.ConnectableAPI(), "result")
        colour.ConnectToSource(image.CreateOutput("rgb", Sdf.ValueTypeNames.Float3))
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(
        JELLO_RGBA[3] if texture is None else 1.0)
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.25)
    shader.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.34)  # (mostly water)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)


def export_usd(traj, path, *, fps: float | None = None, name: str = "jello",
               overwrite: bool = False, texture=None) -> Path:
    """Write the skin of a loaded trajectory as a USD stage with time-sampled points (an
    existing ``path`` is refused unless ``overwrite``); ``texture``: a PNG/JPEG image the
    material shows at the skin's UVs, or ``{material name: image}`` for a skin of several
    materials (:mod:`jellysim.io.texture`: their faces are ``GeomSubset``s, each bound to a
    material of its own), named relative to the stage."""
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, Vt
    except ImportError as exc:
        raise JellysimError(f"USD export needs usd-core: pip install 'jellysim[usd]' ({exc})"
                            ) from None
    path = Path(path)
    if path.suffix.lower() not in (".usdc", ".usda", ".usd"):
        raise JellysimError(f"{path}: a USD file name must end in .usdc, .usda or .usd")
    from .atomic import guard_file

    guard_file(path, overwrite, flag="overwrite=True")
    frames, faces = surface_of(traj)
    from .texture import face_groups, relative_to, textures_of

    images = {k: relative_to(p, path.parent) for k, p in textures_of(traj, texture).items()}
    groups = face_groups(traj)
    fps = (frame_rate(traj.times) or 30.0) if fps is None else float(fps)  # real time
    with atomic_path(path) as tmp:
        tmp.unlink()
        stage = Usd.Stage.CreateNew(str(tmp))
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        stage.SetTimeCodesPerSecond(fps)
        stage.SetFramesPerSecond(fps)
        codes = _time_codes(traj.times, len(frames), fps)
        stage.SetStartTimeCode(codes[0])
        stage.SetEndTimeCode(codes[-1])
        root = UsdGeom.Xform.Define(stage, Sdf.Path(f"/{name}"))
        stage.SetDefaultPrim(root.GetPrim())
        mesh = UsdGeom.Mesh.Define(stage, Sdf.Path(f"/{name}/skin"))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(faces.ravel().tolist()))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(True)  # as the glTF export: an open skin shows its inside
        mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*JELLO_RGBA[:3])]))
        mesh.CreateDisplayOpacityAttr(Vt.FloatArray([JELLO_RGBA[3]]))
        if len(groups) == 1:  # one material for the mesh
            _preview_material(stage, mesh.GetPrim(), f"/{name}/jello_material",
                              images.get(groups[0][0]))
        else:  # a face subset per material of the file, each with its own
            from .texture import identifiers

            for (group, rows), ident in zip(groups, identifiers(g for g, _ in groups)):
                subset = UsdGeom.Subset.CreateGeomSubset(
                    mesh, ident, UsdGeom.Tokens.face, Vt.IntArray(rows.tolist()),
                    "materialBind", UsdGeom.Tokens.partition)
                _preview_material(stage, subset.GetPrim(), f"/{name}/materials/{ident}",
                                  images.get(group))
        uv = surface_uv(traj)
        if uv is not None:  # per face corner: a seam vertex has one UV on each side
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
                "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
            st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(uv.reshape(-1, 2), np.float32)))
        points = mesh.CreatePointsAttr()
        normals = mesh.CreateNormalsAttr()
        # creases of the first frame (a box's edges) stay hard, as in the glTF export: the
        # normals are then per face corner, each corner's from its side of the crease
        from ..geometry.creases import split_creases

        source, split = split_creases(np.asarray(frames[0], dtype=np.float64), faces)
        creased = len(source) > len(np.unique(np.asarray(faces).ravel()))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying if creased
                                     else UsdGeom.Tokens.vertex)
        extent = mesh.CreateExtentAttr()
        for k, verts in enumerate(frames):
            v = np.ascontiguousarray(verts, dtype=np.float32)
            points.Set(Vt.Vec3fArray.FromNumpy(v), Usd.TimeCode(codes[k]))
            n = (vertex_normals(np.asarray(verts)[source], split)[split].reshape(-1, 3)
                 if creased else vertex_normals(verts, faces))
            normals.Set(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(n, dtype=np.float32)),
                        Usd.TimeCode(codes[k]))
            extent.Set(Vt.Vec3fArray.FromNumpy(np.stack([v.min(0), v.max(0)])),
                       Usd.TimeCode(codes[k]))
        stage.GetRootLayer().Save()
        del stage
    return path
