"""OpenMP and numba thread settings, made before numba loads (:func:`configure`).

Why (docs/architecture.md, "Threads"): OpenMP's default lets an idle thread spin about 3 ms,
which made runs 20-270x slower next to another busy process; threads that sleep at once cost a
wake-up at every parallel region (the paper scene 8k steps/s on two threads against 13.5k on
one).  A 10 us spin (libgomp's ``GOMP_SPINCOUNT=1000``) runs it at 22k, and the Simulator's
timed choice of 1 or all threads (:mod:`jellysim.thread_choice`) copes with a loaded machine.

``JELLYSIM_THREADING`` (read once, at import): unset = that set-up; ``passive`` = threads sleep
at once; ``spin`` = OpenMP's defaults.  Every variable the user set wins.  ``OMP_NUM_THREADS``
(the usual way to ask a program for fewer threads on a shared machine) sets numba's pool,
``NUMBA_NUM_THREADS``, when that is not set: numba itself ignores it.
"""
from __future__ import annotations

import os
import warnings

__all__ = ["configure"]


def _count(name: str) -> int | None:
    """The thread count in environment variable ``name`` (its first, for OpenMP's list
    ``"4,2"``), or ``None`` when unset; a value that is not an integer >= 1 is said and
    removed (numba stops with a traceback on ``NUMBA_NUM_THREADS=0``)."""
    raw = os.environ.get(name)
    if raw is None:
        return None
    try:
        value = int(raw.split(",")[0].strip())
    except ValueError:
        value = 0
    if value >= 1:
        return value
    warnings.warn(f"{name}={raw!r} is not a thread count (an integer >= 1): ignored, numba "
                  "uses one thread per core", stacklevel=3)
    del os.environ[name]
    return None


def configure() -> None:
    """Set the threading environment (see the module docstring); only before numba loads."""
    mode = os.environ.get("JELLYSIM_THREADING", "").strip().lower()
    if mode not in ("", "passive", "spin"):
        warnings.warn(f"JELLYSIM_THREADING={mode!r} is not known: give 'passive' (threads "
                      "sleep at once) or 'spin' (OpenMP's defaults), or leave it unset (a 10 "
                      "us spin); using the default", stacklevel=3)
    if mode != "spin":
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # (other OpenMP runtimes)
        os.environ.setdefault("KMP_BLOCKTIME", "0")
        if mode != "passive":  # (libgomp: the spin count wins over the passive policy)
            os.environ.setdefault("GOMP_SPINCOUNT", "1000")
    pool = _count("NUMBA_NUM_THREADS")
    omp = _count("OMP_NUM_THREADS")
    if pool is None and omp is not None:
        os.environ["NUMBA_NUM_THREADS"] = str(omp)
