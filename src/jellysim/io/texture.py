"""``--texture IMG``: an image mapped on the skin by its mesh file's UVs, in every export.

jellysim does not read a mesh file's materials (docs/visual.md); an artist names the texture
image instead, and the exports reference it (USD: a ``UsdUVTexture`` reading ``st`` into the
``UsdPreviewSurface``'s colour, the path relative to the stage; OBJ sequences: a ``.mtl`` with
``map_Kd``), or embed it (glTF: ``baseColorTexture``).  The material is then opaque, its base
colour the image's, instead of the renders' translucent red.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import JellysimError

__all__ = ["TEXTURE_SUFFIXES", "relative_to", "texture_file"]

TEXTURE_SUFFIXES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}
"""The image files a texture may be, with their MIME types (the two glTF allows)."""


def texture_file(traj, texture) -> Path | None:
    """``texture`` checked: an existing PNG or JPEG file, for a skin with texture coordinates
    (``None`` stays ``None``)."""
    if texture is None:
        return None
    from .usd import surface_uv

    path = Path(texture)
    if path.suffix.lower() not in TEXTURE_SUFFIXES:
        raise JellysimError(f"{path}: a texture must be a .png or .jpg image (what glTF and "
                            "USD previews read)")
    if not path.is_file():
        raise JellysimError(f"{path}: texture image not found")
    if surface_uv(traj) is None:
        raise JellysimError(f"{path}: the run's skin has no texture coordinates to map it with "
                            "(its mesh file had none, or they could not be read: the build or "
                            "the run said so); a texture needs the mesh's UVs")
    return path


def relative_to(texture: Path, folder) -> str:
    """``texture``'s path as the file in ``folder`` should name it: relative when it can be
    (the output and its image move together), else absolute; forward slashes."""
    try:
        text = os.path.relpath(Path(texture).resolve(), Path(folder).resolve())
    except ValueError:  # (another drive on Windows)
        text = str(Path(texture).resolve())
    return text.replace(os.sep, "/")
