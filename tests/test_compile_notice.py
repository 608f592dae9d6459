"""From Python, the first run's pause while numba compiles is said once, on stderr; other
libraries' compiles and a run from the cache say nothing."""
from __future__ import annotations

import jellysim._numba_cache as cache
import jellysim.kernels._numba_opts  # noqa: F401  (registers the listener, as any kernel does)


def _compile(module: str, value: float) -> float:
    from numba import njit

    namespace = {"__name__": module}
    exec("def probe(x):\n    return 2.0 * x + 1.0\n", namespace)
    return njit(cache=False)(namespace["probe"])(value)


def test_numba_compiling_our_code_is_said_once_on_stderr(capfd, monkeypatch):
    monkeypatch.setattr(cache, "_said", False)
    monkeypatch.delenv("PMI_RANK", raising=False)
    assert _compile("somebody_else", 1.0) == 3.0     # another library's function: silent
    assert capfd.readouterr().err == ""
    assert _compile("jellysim.probe_a", 2.0) == 5.0
    assert capfd.readouterr().err == cache.NOTICE
    assert _compile("jellysim.probe_b", 3.0) == 7.0  # once per process
    assert capfd.readouterr().err == ""


def test_only_rank_zero_says_it_under_mpiexec(capfd, monkeypatch):
    monkeypatch.setattr(cache, "_said", False)
    monkeypatch.setenv("PMI_RANK", "1")
    assert _compile("jellysim.probe_c", 1.0) == 3.0
    assert capfd.readouterr().err == ""


def test_a_run_whose_kernels_are_cached_says_nothing(tmp_path):
    """Once a run has compiled (and cached) its kernels, the next process loads them silently."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    code = ("import jellysim as js\n"
            "m = js.finalize(js.Body.box(points=150, distribution='uniform', radius=0.4, seed=1),"
            " stiffness=300.0, density=1.0)\n"
            "js.Simulator(m, dt=1e-3, threads=1).advance(5)\n")
    exec(code, {})                     # compiles (or loads) and caches this path's kernels
    src = str(Path(__file__).resolve().parent.parent / "src")
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.pop("PMI_RANK", None)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=tmp_path, timeout=300)
    assert out.returncode == 0, out.stderr
    assert cache.NOTICE.strip() not in out.stderr
