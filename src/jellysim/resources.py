"""Resource guard: estimate a body's memory before building it and refuse what cannot fit.

The estimate (bytes) is deliberately simple and on the generous side of what the builders and
the simulator hold at their peak (measured on the box and mesh builders, see docs):

* per point: :data:`BYTES_PER_POINT` (positions, velocities, accelerations, rest positions,
  scratch, the sort and neighbour-search temporaries);
* per spring (``neighbours / 2`` per point): :data:`BYTES_PER_SPRING` (pairs, rest lengths,
  stiffnesses, CSR slots, per-spring scratch of the implicit solver, query temporaries);
* per point of a tetrahedral builder (``delaunay``, ``tetgen``, ``marching``):
  :data:`BYTES_PER_TET_POINT` more (Qhull / TetGen working memory, about 6.5 tets per point).

The limit is ``max_memory`` when given, else the environment variable ``JELLYSIM_MAX_MEMORY``
(bytes, or with a suffix ``K``/``M``/``G``/``T``: ``4G``; the CLI's ``--max-memory`` sets it),
else the memory the system reports available (``MemAvailable`` of ``/proc/meminfo``).
"""
from __future__ import annotations

import os

from .errors import ResourceError

__all__ = ["BYTES_PER_POINT", "BYTES_PER_SPRING", "BYTES_PER_TET_POINT", "available_memory",
           "memory_limit", "parse_size", "estimate_body_bytes", "check_body_memory"]

BYTES_PER_POINT = 600
BYTES_PER_SPRING = 250
BYTES_PER_TET_POINT = 2500


def parse_size(text) -> int:
    """``"4G"``, ``"512M"``, ``"1e9"`` or an int -> bytes.  Raises ``ValueError``."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
    else:
        t = str(text).strip().upper().removesuffix("B").removesuffix("I")
        scale = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}.get(t[-1:], 1)
        try:
            value = float(t[:-1] if scale > 1 else t) * scale
        except ValueError:
            value = float("nan")
    if not (value > 0 and value < 1e20):
        raise ValueError(f"memory size {text!r}: expected a positive size such as 4G")
    return int(value)


def available_memory() -> int | None:
    """Memory the system reports available [bytes], or ``None`` when unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def memory_limit(max_memory=None) -> tuple[int | None, str]:
    """(limit in bytes or ``None``, where it comes from)."""
    if max_memory is not None:
        return parse_size(max_memory), "max_memory"
    env = os.environ.get("JELLYSIM_MAX_MEMORY")
    if env:
        try:
            return parse_size(env), "JELLYSIM_MAX_MEMORY / --max-memory"
        except ValueError as exc:
            raise ResourceError(f"JELLYSIM_MAX_MEMORY: {exc}") from None
    return available_memory(), "available memory"


def estimate_body_bytes(points: int, *, neighbours: float = 24.0, tets: bool = False) -> int:
    """Estimated peak bytes to build and simulate a body of ``points`` points."""
    n = int(points)
    k = 0.5 * float(neighbours) * n
    return int(n * BYTES_PER_POINT + k * BYTES_PER_SPRING + (n * BYTES_PER_TET_POINT
                                                             if tets else 0))


def _fmt(b: float) -> str:
    for unit, scale in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b / 1024:.3g} KiB"


def check_body_memory(points: int, *, neighbours: float = 24.0, tets: bool = False,
                      what: str = "the body", max_memory=None) -> int:
    """Refuse (:class:`ResourceError`) before building when the estimate exceeds the limit
    (see the module doc).  Returns the estimate [bytes]."""
    need = estimate_body_bytes(points, neighbours=neighbours, tets=tets)
    limit, source = memory_limit(max_memory)
    if limit is not None and need > limit:
        raise ResourceError(
            f"{what}: {int(points):,} points with about {neighbours:.3g} neighbours each would "
            f"need about {_fmt(need)} of memory, more than the limit {_fmt(limit)} ({source}); "
            "use fewer points, or raise the limit with --max-memory / JELLYSIM_MAX_MEMORY")
    return need
