"""Numba's on-disk cache, kept consistent with the sources.

``@njit(cache=True)`` re-validates a cached function against its *own* file only: a kernel
that calls (and so inlines) a function of another module keeps its stale machine code when
only that other module changed, until its own file changes.  :func:`check` therefore
fingerprints every source of the packages that hold compiled code (their ``.py`` files'
bytes) and, when the fingerprint differs from the one stored beside the cache, removes the
cached ``.nbi`` / ``.nbc`` files so that everything is compiled afresh once.  Nothing is done
when ``NUMBA_CACHE_DIR`` points the cache elsewhere, nor when the package folder is
read-only (numba then caches in the user's folder and the same caveat applies there).
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

_PACKAGES = ("kernels", "geometry", "physics", "distributed")
"""Sub-packages of jellysim with ``@njit(cache=True)`` functions."""

_done = False


def check() -> None:
    """Drop the numba cache of jellysim's compiled packages if any of their sources changed
    since it was written (once per process)."""
    global _done
    if not _done and not os.environ.get("NUMBA_CACHE_DIR"):
        sync(Path(__file__).resolve().parent)
    _done = True


def sync(root: Path) -> bool:
    """For the package at ``root``: remove the cached ``.nbi`` / ``.nbc`` files of its
    compiled sub-packages when their sources' fingerprint differs from the stored one, and
    store the new one.  Returns whether the cache was dropped."""
    digest = hashlib.sha1()
    for pkg in _PACKAGES:
        for path in sorted((root / pkg).glob("*.py")):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    stamp = digest.hexdigest()
    marker = root / "kernels" / "__pycache__" / "jellysim-sources.sha1"
    try:
        if marker.read_text() == stamp:
            return False
    except OSError:
        pass
    try:
        for pkg in _PACKAGES:
            for path in (root / pkg / "__pycache__").glob("*.nb[ic]"):
                path.unlink(missing_ok=True)
        marker.parent.mkdir(exist_ok=True)
        tmp = marker.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(stamp)
        os.replace(tmp, marker)
    except OSError:
        pass  # read-only install: numba keeps its own (per-file) validation
    return True
