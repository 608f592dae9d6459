"""Check an ``.npz`` before loading it: every member's header must fit the bytes it holds.

``np.load`` allocates what a member's ``.npy`` header claims before reading the data, so a
300-byte file that claims 10^12 rows asks for terabytes.  :func:`check_npz` reads only the
headers (a few hundred bytes each) and refuses a member whose claimed size exceeds the
uncompressed size stored for it in the zip directory, or whose claimed uncompressed size
exceeds what deflate can produce from its compressed bytes (ratio 1032:1).
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

__all__ = ["check_npz", "MAX_DEFLATE_RATIO"]

MAX_DEFLATE_RATIO = 1100
"""Deflate expands at most 1032:1; a member claiming more is refused."""


def check_npz(path) -> None:
    """Raise ``ValueError`` naming the member when an ``.npz`` member's header claims more data
    than the file can hold (see the module doc).  Reads headers only."""
    if not hasattr(path, "read"):
        path = Path(path)
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            if not info.filename.endswith(".npy"):
                continue
            member = info.filename[:-4]
            if info.compress_type != zipfile.ZIP_STORED and (
                    info.file_size > MAX_DEFLATE_RATIO * max(info.compress_size, 1)):
                raise ValueError(f"member '{member}' claims {info.file_size} bytes from "
                                 f"{info.compress_size} compressed bytes")
            with zf.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
                else:
                    raise ValueError(f"member '{member}': unsupported .npy version {version}")
                header = fh.tell()
            if dtype.hasobject:
                raise ValueError(f"member '{member}' holds Python objects (not allowed)")
            count = 1
            for s in shape:
                count *= int(s)
            need = count * dtype.itemsize
            have = info.file_size - header
            if need > have:
                raise ValueError(f"member '{member}' claims shape {tuple(shape)} "
                                 f"({need} bytes) but holds {max(have, 0)} bytes")
