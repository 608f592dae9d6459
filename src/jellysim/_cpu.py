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

Session 29 (BENCHMARKS.md, "Indices walked from zero"): with the spring loops walking their
lists from 0, their rest lengths, stiffnesses and neighbour indices load as vectors, and
numba's own choice on Zen 4 (2.85 ns a visit) beats ``prefer-no-gather`` on the old loops
(3.57 ns).  ``prefer-no-gather`` itself is no longer the default: with it, the kernels numba
compiles in a process and the same kernels loaded from its cache by the next gave different
last bits (1.9e-15 m on a 600-point scene), so a first run and a later one differed and MPI
ranks disagreed with a serial run (``tests/test_cache_bits.py`` fails under it); numba's own
choice and ``avx2`` compile alike in both.

``JELLYSIM_CPU`` (read once, when jellysim is imported):

* ``auto`` (default) and ``native``: numba's own choice (the host's features);
* ``avx2``: no AVX-512 instructions (spring bodies' fastest on Zen 4; the physical path's
  10-15 % slower);
* ``nogather``: the host's features with LLVM's ``prefer-no-gather`` (for measurements only:
  its cached and freshly compiled kernels can differ in their last bits, above).

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

MODES = ("auto", "native", "avx2", "nogather")


def configure(environ=None) -> str | None:
    """Set ``NUMBA_CPU_FEATURES`` in ``environ`` (default ``os.environ``) as ``JELLYSIM_CPU``
    asks (module docstring); returns the features set, or ``None`` when numba's own choice
    stands."""
    env = os.environ if environ is None else environ
    mode = env.get("JELLYSIM_CPU", "auto").strip().lower() or "auto"
    if mode not in MODES:
        import warnings

        warnings.warn(f"JELLYSIM_CPU={env.get('JELLYSIM_CPU')!r} is not one of {MODES}: "
                      "using 'auto'", UserWarning, stacklevel=2)
        mode = "auto"
    if mode in ("auto", "native") or env.get("NUMBA_CPU_NAME") or env.get("NUMBA_CPU_FEATURES"):
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
