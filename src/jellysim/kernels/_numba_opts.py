"""Compile options shared by the numba kernels."""
OPTS = dict(parallel=True, cache=True, nogil=True, error_model="numpy")
