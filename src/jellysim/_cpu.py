"""Which instructions numba compiles jellysim's kernels for, chosen before numba loads.

Why (BENCHMARKS.md, "Gathers on Zen 4"): every spring kernel sums, for each point, over its
neighbours' positions, loaded through an index.  On AMD Zen 4 (AVX-512) LLVM vectorises those
loads into AVX-512 gather instructions, which are slow there: the sum's inner loop cost 4.1 ns
per spring visit with them, 3.0 ns with LLVM's ``prefer-no-gather`` tuning (the loads done one
by one, the arithmetic still vectorised) and 2.6 ns compiled without AVX-512 (the same loop,
one thread, ``benchmarks/bench_gathers.py``).  Whole report steps (``bench_step``, one
thread): ``prefer-no-gather`` ran 1.10x faster at 600 points and 1.42x at 100k, the physical
(tet) path unchanged (``examples/motion_check.py``); no AVX-512 ran them 1.37x / 1.62x faster
(at 600 points 1.0-1.38x from one process to the next) but the physical path 10-15 % slower
(its tet kernel, ~250 operations per tet, spills without AVX-512's 32 vector registers).

``JELLYSIM_CPU`` (read once, when jellysim is imported):

* ``auto`` (default): ``prefer-no-gather`` on an AMD CPU of family 25 with AVX-512 (Zen 4, the
  CPU it was measured on); elsewhere numba's own choice;
* ``native``: numba's own choice (the host's features, gathers where LLVM likes them);
* ``avx2``: no AVX-512 instructions (spring bodies' fastest on Zen 4; the physical path's
  slower).

A ``NUMBA_CPU_NAME`` or ``NUMBA_CPU_FEATURES`` set by the user wins: nothing is changed.  The
choice is numba's process-wide target (``NUMBA_CPU_FEATURES``, inherited by child processes:
MPI ranks, the warm-up compile, spawned pools), so numba code of the user's compiled in the same
process gets it too; it applies only if numba has not compiled anything yet.  Results agree
across choices to rounding (the sums' lanes differ): ``tests/test_cpu.py``.
"""
from __future__ import annotations

import os
import sys

__all__ = ["configure", "MODES"]

MODES = ("auto", "native", "avx2")


def configure(environ=None, cpuinfo: str | None = None) -> str | None:
    """Set ``NUMBA_CPU_FEATURES`` in ``environ`` (default ``os.environ``) as ``JELLYSIM_CPU``
    asks (module docstring); returns the features set, or ``None`` when numba's own choice
    stands.  ``cpuinfo``: the text of ``/proc/cpuinfo`` (read when ``None``; tests pass
    their own)."""
    env = os.environ if environ is None else environ
    mode = env.get("JELLYSIM_CPU", "auto").strip().lower() or "auto"
    if mode not in MODES:
        import warnings

        warnings.warn(f"JELLYSIM_CPU={env.get('JELLYSIM_CPU')!r} is not one of {MODES}: "
                      "using 'auto'", UserWarning, stacklevel=2)
        mode = "auto"
    if mode == "native" or env.get("NUMBA_CPU_NAME") or env.get("NUMBA_CPU_FEATURES"):
        return None
    if mode == "auto" and not zen4(cpuinfo):
        return None
    flat = _features(avx512=mode != "avx2")
    if flat is not None:
        _set(env, flat)
    return flat


def _features(*, avx512: bool) -> str | None:
    """The host's features as numba would give them, with ``prefer-no-gather`` added, or with
    every AVX-512 feature off (``avx512=False``); ``None`` where LLVM cannot tell."""
    try:
        import llvmlite.binding as ll

        features = ll.get_host_cpu_features()
        version = tuple(ll.llvm_version_info)
    except Exception:  # (no llvmlite, or LLVM cannot tell: numba's own choice)
        return None
    if not avx512:
        for name in list(features):
            if name.startswith("avx512"):
                features[name] = False
        return features.flatten()
    if version >= (17,):  # (the tuning flag exists from LLVM 17)
        return features.flatten() + ",+prefer-no-gather"
    return None


def _set(env, flat: str) -> None:
    env["NUMBA_CPU_FEATURES"] = flat
    if env is os.environ and "numba.core.config" in sys.modules:  # (numba read it already)
        sys.modules["numba.core.config"].CPU_FEATURES = flat


def zen4(cpuinfo: str | None = None) -> bool:
    """Whether the CPU is an AMD of family 25 with AVX-512 (Zen 4; Zen 3, the same family,
    has no AVX-512), from ``/proc/cpuinfo``'s first processor (``False`` where it cannot be
    read: other systems keep numba's choice)."""
    if cpuinfo is None:
        try:
            with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
                cpuinfo = f.read(16384)
        except OSError:
            return False
    fields = {}
    for line in cpuinfo.splitlines():
        if not line.strip():
            if fields:
                break
            continue
        key, _, value = line.partition(":")
        fields.setdefault(key.strip(), value.strip())
    return (fields.get("vendor_id") == "AuthenticAMD" and fields.get("cpu family") == "25"
            and "avx512f" in fields.get("flags", "").split())
