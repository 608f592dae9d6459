"""A first run's compiling, shared with the second core.

numba compiles on one core, and a first run (after an install or an update) compiles two
groups of kernels one after the other: the body's (point-in-mesh test, sampling) while the body
is built, then the time step's when the simulation starts.  :func:`start` runs the second group
in a second process meanwhile: it builds the same scene on a tiny box body and takes one step,
so numba writes the step's kernels to its on-disk cache; :func:`wait`, called before the first
frames of the physical path (``Simulator._advance_physical``), lets that process finish, and
the step's kernels are then loaded from the cache instead of compiled.

Measured (``jellysim demo`` on a cold cache, ``benchmarks/bench_first_run.py``, BENCHMARKS.md
"The demo", session 13): 70-74 s before, 54-59 s after (the split of the step's drivers
included).

Nothing is started when the kernels are already cached, under ``mpiexec``, on one core, when
numba's cache is off, or with ``JELLYSIM_WARMUP=0``.  The second process writes nothing but
numba's cache, prints nothing, and is ended with its parent; if its scene differs from the one
run after all (another thread count, say), the run simply compiles what it needs, as before.
"""
from __future__ import annotations

import atexit
import os
import pickle
import subprocess
import sys
from pathlib import Path

__all__ = ["start", "wait"]

_proc: subprocess.Popen | None = None

WAIT_S = 300.0
"""Longest wait [s] for the second process at the first step (it takes about 15 s of CPU)."""


def _mpi() -> bool:
    return any(k in os.environ for k in ("PMI_RANK", "PMIX_RANK", "OMPI_COMM_WORLD_RANK",
                                         "MPI_LOCALRANKID"))


def _cached(dispatcher) -> bool:
    """Whether numba's cache holds a valid entry of ``dispatcher`` (any signature); True
    where that cannot be told (so that nothing is started)."""
    try:
        return len(dispatcher._cache._cache_file._load_index()) > 0
    except Exception:  # another numba's internals, or the cache off
        return True


def _needed(params: dict) -> bool:
    """Whether the scene's first steps would compile: the physical step driver its threads
    select (one thread, the default below 50,000 tets: the summed tet pass) is not cached."""
    from .kernels import fem_numba

    threads = params.get("integrator", {}).get("threads") or 1
    return not _cached(fem_numba._steps_gathered if threads > 1 else fem_numba._steps_summed)


def start(params: dict) -> bool:
    """Start compiling the time step of the scene ``params`` (a scene's parameter dict,
    :attr:`jellysim.scene.Scene.params`) in a second process; True if one was started."""
    global _proc
    if _proc is not None or os.environ.get("JELLYSIM_WARMUP", "1").strip().lower() in (
            "0", "no", "off", "false"):
        return False
    if _mpi() or (os.cpu_count() or 1) < 2 or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return False
    try:
        if not _needed(params):
            return False
        payload = pickle.dumps(params)
    except Exception:
        return False
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1])  # this jellysim, not another one
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    try:
        proc = subprocess.Popen([sys.executable, "-m", "jellysim._warmup"], env=env,
                                stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        proc.stdin.write(payload)
        proc.stdin.close()
    except Exception:
        return False
    _proc = proc
    atexit.register(_end)
    return True


def wait(timeout: float = WAIT_S) -> None:
    """Let the warm-up process finish (at most ``timeout`` s, then it is ended)."""
    global _proc
    proc, _proc = _proc, None
    if proc is None:
        return
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _end() -> None:
    global _proc
    proc, _proc = _proc, None
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()


def _tiny_body():
    """A 3 x 3 x 3 grid box with its tets, where the scene's body would be (same arrays'
    types as any body of the scene's builders)."""
    from .body import Body

    return Body.box(points=27, lower=(0.0, 0.01, 0.0), upper=(0.02, 0.03, 0.02))


def _compile(params: dict) -> None:
    """Build the scene on a tiny body and take one step (what the warm-up process does)."""
    import warnings

    from .scene import Scene

    warnings.simplefilter("ignore")
    params = dict(params)
    params["handle"] = []  # the scene's handles select points of its own body
    sc = Scene.from_dict(params, name="warm-up")
    model = sc.build_model(_tiny_body())
    sim = sc.simulator(model, settle=False)
    sim.advance(1)


if __name__ == "__main__":
    try:
        _compile(pickle.loads(sys.stdin.buffer.read()))
    except BaseException:  # nothing to say: the run itself compiles what is missing
        sys.exit(1)
