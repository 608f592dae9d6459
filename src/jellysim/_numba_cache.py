"""Numba's on-disk cache, kept consistent with the sources.

``@njit(cache=True)`` re-validates a cached function against its *own* file only: a kernel
that calls (and so inlines) a function of another module keeps its stale machine code when
only that other module changed, until its own file changes.  :func:`check` therefore
fingerprints every source of the packages that hold compiled code (their ``.py`` files'
bytes) and, when the fingerprint differs from the one stored beside the cache, removes the
cached ``.nbi`` / ``.nbc`` files so that everything is compiled afresh once.  Nothing is done
when ``NUMBA_CACHE_DIR`` points the cache elsewhere, nor when the package folder is
read-only (numba then caches in the user's folder and the same caveat applies there).

Compiling takes about a minute on a first run (after an install or an update); from Python
nothing else would say why the first steps pause, so :func:`check` also has numba tell us when
it starts compiling one of jellysim's functions, and says so once per process on stderr
(:data:`NOTICE`).  A run whose kernels come from the cache says nothing.
"""
from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

_PACKAGES = ("kernels", "geometry", "physics", "distributed")
"""Sub-packages of jellysim with ``@njit(cache=True)`` functions."""

_done = False

NOTICE = ("jellysim: numba is compiling the kernels (a first run after an install or an update, "
          "or a kind of run not made before: about a minute; later runs load them from its "
          "cache)\n")
"""Said on stderr, once per process, when numba starts compiling a function of jellysim."""

_said = False


def check() -> None:
    """Drop the numba cache of jellysim's compiled packages if any of their sources changed
    since it was written, and have numba's compiles of jellysim said (once per process)."""
    global _done
    if not _done:
        if not os.environ.get("NUMBA_CACHE_DIR"):
            sync(Path(__file__).resolve().parent)
        _listen_for_compiles()
    _done = True


def _say_compiling(event) -> None:
    """numba's ``numba:compile`` event: :data:`NOTICE` the first time it is one of ours."""
    global _said
    if _said or not event.is_start or _rank() != "0":
        return
    func = getattr(event.data.get("dispatcher"), "py_func", None)
    if (getattr(func, "__module__", None) or "").split(".")[0] == "jellysim":
        _said = True
        sys.stderr.write(NOTICE)
        sys.stderr.flush()


def _rank() -> str:
    """This process's MPI rank from the launcher's environment ("0" outside mpiexec): under
    mpiexec only rank 0 says :data:`NOTICE`."""
    for key in ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK"):
        if os.environ.get(key):
            return os.environ[key]
    return "0"


def _listen_for_compiles() -> None:
    try:
        from numba.core import event
    except ImportError:  # an older numba without the event API: say nothing
        return

    class _Notice(event.Listener):
        def on_start(self, ev):
            _say_compiling(ev)

        def on_end(self, ev):
            pass

    event.register("numba:compile", _Notice())


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
