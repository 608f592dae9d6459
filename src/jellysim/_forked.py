"""A clear error, not a hang, in a process forked after jellysim's threads ran.

numba's kernels run on GNU OpenMP, which cannot run in a child ``fork()``-ed from a process
that already ran its threads: numba ends such a child at its first parallel kernel
("Terminating: fork() called from a process already using GNU OpenMP, this is unsafe.").  With
``multiprocessing.Pool`` (Linux's default start method, fork) the pool then waits for ever
for the dead workers' results (sweep trial, session 30: a Pool after one run in the parent
hung until killed).  :func:`check` (called where a body is built and a simulator made) raises
a :class:`~jellysim.errors.JellysimError` in such a child instead, which the pool hands back
to the parent, with the fix: a ``spawn`` (or ``forkserver``) context.
"""
from __future__ import annotations

import os
import sys

from .errors import JellysimError

__all__ = ["check"]

_FORKED_AFTER_THREADS = False


def _after_fork_in_child() -> None:
    global _FORKED_AFTER_THREADS
    parallel = sys.modules.get("numba.np.ufunc.parallel")  # (never imported here)
    if parallel is not None and getattr(parallel, "_is_initialized", False):
        _FORKED_AFTER_THREADS = True


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def check(where: str) -> None:
    """Raise in a child forked after the parent ran jellysim's (numba's OpenMP) threads."""
    if not _FORKED_AFTER_THREADS:
        return
    raise JellysimError(
        f"{where}: this process was forked (multiprocessing's default 'fork' start method) from "
        "one that had already run jellysim's threads, and GNU OpenMP cannot run in it (numba "
        "would end the process at its first parallel kernel, and a pool would wait for ever): "
        "make the pool with a spawn context, e.g. concurrent.futures.ProcessPoolExecutor("
        "mp_context=multiprocessing.get_context('spawn')) or multiprocessing.get_context("
        "'spawn').Pool(...) (README, 'Sweeps in parallel processes')")
