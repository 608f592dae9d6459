"""``--texture``: images mapped on the skin by its mesh file's UVs, in every export.

jellysim does not read a mesh file's material images (docs/visual.md); an artist names them
instead: one image for the whole skin (``--texture IMAGE``), or one per material of a file
of several (``--texture NAME=IMAGE``, the names the file gives its materials).  The exports
reference them (USD: a ``UsdUVTexture`` reading ``st`` into a ``UsdPreviewSurface``'s colour,
the path relative to the stage; OBJ sequences: the image copied beside the frames and named
by a ``.mtl`` with ``map_Kd``), or embed them (glTF: ``baseColorTexture``).  A textured
material is opaque, its base colour the image's; the others keep the renders' translucent red
(:data:`JELLO_RGBA`).

A skin of several materials (:class:`~jellysim.geometry.texcoords.Materials`) is exported
as one group of faces per material (USD ``GeomSubset``s of the ``materialBind`` family, OBJ
``usemtl`` runs, one glTF primitive each), each bound to a material of its own name.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import JellysimError

__all__ = ["JELLO_RGBA", "TEXTURE_SUFFIXES", "face_groups", "identifiers", "parse_textures", "relative_to",
           "textures_of"]

JELLO_RGBA = (0.85, 0.12, 0.24, 0.7)
"""The exports' untextured material: the renders' jello red (linear RGB) and its opacity."""
TEXTURE_SUFFIXES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}
"""The image files a texture may be, with their MIME types (the two glTF allows)."""


def parse_textures(specs) -> dict | None:
    """``--texture`` values: ``IMAGE`` (the whole skin, key ``None``) or ``NAME=IMAGE`` (one
    material), as ``{name or None: path}``; ``None`` when none is given."""
    if not specs:
        return None
    out = {}
    for spec in specs:
        name, sep, image = str(spec).partition("=")
        key, path = (name, image) if sep and not Path(spec).is_file() else (None, spec)
        if not str(path).strip():
            raise JellysimError(f"--texture {spec}: no image after '='; give NAME=IMAGE")
        if key in out:
            raise JellysimError(f"--texture {spec}: " + ("a second image for the whole skin; "
                                "give one, or NAME=IMAGE per material" if key is None else
                                f"a second image for material {key!r}"))
        out[key] = path
    return out


def face_groups(traj):
    """The skin's faces by material: ``[(name, face indices)]``; one group of every face,
    named ``jello``, for a skin of one material (or without UVs)."""
    import numpy as np

    from .usd import surface_of

    _, faces = surface_of(traj)
    materials = None if traj.skin is None else traj.skin.materials
    if materials is None:
        return [("jello", np.arange(len(faces)))]
    return [(name, np.flatnonzero(materials.index == k))
            for k, name in enumerate(materials.names)]


def identifiers(names) -> list[str]:
    """``names`` as distinct identifiers (letters, digits, ``_``; not starting with a digit),
    for formats that allow no others (USD prim names, OBJ ``usemtl``): ``Skin Mat.001`` ->
    ``Skin_Mat_001``; a clash gets ``_2``, ``_3`` ..."""
    import re

    out = []
    for name in names:
        base = re.sub(r"\W", "_", str(name), flags=re.ASCII) or "material"
        base = "_" + base if base[0].isdigit() else base
        ident, k = base, 1
        while ident in out:
            k += 1
            ident = f"{base}_{k}"
        out.append(ident)
    return out


def textures_of(traj, texture) -> dict:
    """``texture`` (an image for the whole skin, a ``{material name or None: image}``
    mapping, or ``None``) checked, as ``{group name: Path}`` over :func:`face_groups`'
    names: existing PNG or JPEG files, named materials that the skin has, and a skin with
    texture coordinates."""
    if texture is None:
        return {}
    from .usd import surface_uv

    mapping = texture if isinstance(texture, dict) else {None: texture}
    groups = [name for name, _ in face_groups(traj)]
    for name in mapping:
        if name is not None and name not in groups:
            raise JellysimError(f"--texture {name}=...: the skin has no material {name!r}; "
                                + (f"its materials are {', '.join(map(repr, groups))}"
                                   if groups != ["jello"] else "it has one material: give "
                                   "--texture IMAGE"))
    out = {}
    for name, image in mapping.items():
        path = Path(image)
        if path.suffix.lower() not in TEXTURE_SUFFIXES:
            raise JellysimError(f"{path}: a texture must be a .png or .jpg image (what glTF "
                                "and USD previews read)")
        if not path.is_file():
            raise JellysimError(f"{path}: texture image not found")
        if surface_uv(traj) is None:
            raise JellysimError(f"{path}: the run's skin has no texture coordinates to map it "
                                "with (its mesh file had none, or they could not be read: "
                                "the build or the run said so); a texture needs the mesh's UVs")
        if name is not None:
            out[name] = path                     # (a material's own image wins)
        else:
            for group in groups:
                out.setdefault(group, path)
    return out


def relative_to(texture: Path, folder) -> str:
    """``texture``'s path as the file in ``folder`` should name it: relative when it can be
    (the output and its image move together), else absolute; forward slashes."""
    try:
        text = os.path.relpath(Path(texture).resolve(), Path(folder).resolve())
    except ValueError:  # (another drive on Windows)
        text = str(Path(texture).resolve())
    return text.replace(os.sep, "/")
