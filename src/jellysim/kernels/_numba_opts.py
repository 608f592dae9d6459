"""Compile options shared by the numba kernels (importing this first also drops a stale
numba cache: :mod:`jellysim._numba_cache`)."""
from .._numba_cache import check as _check_cache

_check_cache()

OPTS = dict(parallel=True, cache=True, nogil=True, error_model="numpy")
