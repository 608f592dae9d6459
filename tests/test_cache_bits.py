"""A run's bits do not depend on whether numba compiled its kernels in that process or loaded
them from its on-disk cache.

Session 29: with the per-point spring loops sliced and walked from 0 (a 1.2-1.7x faster report
step, BENCHMARKS.md "Indices walked from zero") and LLVM's `prefer-no-gather` (then the default
`JELLYSIM_CPU=auto` on Zen 4, now the opt-in `nogather`), a process that compiled
the kernels and the next one, which loaded them, ended the same scene 1.9e-15 m apart: fast-math
sums whose lanes LLVM chose differently in the two.  Only the MPI tests' bitwise comparisons
on the fresh-clone CI's cold cache showed it; this test runs two scenes cold and then warm in a
private cache (``NUMBA_CACHE_DIR``), so a kernel change that brings it back fails here, on any
machine.  The springs paths only: the physical path's cold compile takes minutes."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).parent / "data" / "mpi"
SCENES = [DATA / "symplectic_contact.toml", DATA / "paper_springs.toml"]

CHILD = r"""
import hashlib, sys, warnings
warnings.simplefilter("ignore")
from jellysim.scene import Scene
out = []
for path in sys.argv[1:]:
    scene = Scene.load(path)
    sim = scene.simulator(scene.build_model())
    sim.advance(scene.steps)
    out.append(hashlib.sha256(sim.state.x.tobytes() + sim.state.v.tobytes()).hexdigest())
print(" ".join(out))
"""


def test_compiled_and_cache_loaded_kernels_give_the_same_bits(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"), JELLYSIM_WARMUP="0")
    env.pop("NUMBA_DISABLE_JIT", None)
    runs = [subprocess.run([sys.executable, "-c", CHILD, *map(str, SCENES)], env=env,
                           capture_output=True, text=True, timeout=900) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    assert "numba is compiling" in runs[0].stderr  # the first compiled ...
    assert "numba is compiling" not in runs[1].stderr  # ... the second loaded them
    cold, warm = (r.stdout.split() for r in runs)
    assert len(cold) == len(SCENES) and cold == warm
