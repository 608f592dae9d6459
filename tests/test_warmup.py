"""A first run's step kernels compiled in a second process (jellysim._warmup).

The warm-up builds the scene on a tiny box and takes one step, so that numba's on-disk cache
holds the step's kernels when the run itself reaches its first step.  That only helps if the
signature it compiles is the one the run calls: here a fresh process runs the demo's scene on
a body of another size and resolution, and numba must load the physical step from the cache
(a hit, no compile).  Each process gets its own empty NUMBA_CACHE_DIR, so the test does not
depend on (nor touch) the suite's cache.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

SRC = str(Path(__file__).resolve().parents[1] / "src")

WARM = """
from jellysim import _warmup
from jellysim.demo import DEMO_SCENE
from jellysim.scene import Scene
started = _warmup.start(Scene.from_dict(DEMO_SCENE, name="demo").params)
_warmup.wait()
again = _warmup.start(Scene.from_dict(DEMO_SCENE, name="demo").params)
print(started, again)
"""

RUN = """
import json
from jellysim.body import Body
from jellysim.demo import DEMO_SCENE
from jellysim.kernels import fem_numba
from jellysim.scene import Scene
sc = Scene.from_dict(DEMO_SCENE, name="demo")
model = sc.build_model(Body.box(points=64, lower=(0.0, 0.02, 0.0), upper=(0.04, 0.06, 0.04)))
sim = sc.simulator(model)
sim.advance(2)
st = fem_numba._steps_summed.stats
print(json.dumps([sum(st.cache_hits.values()), sum(st.cache_misses.values()),
                  model.point_count]))
"""


def _python(code, cache, **env):
    full = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=SRC, **env)
    out = subprocess.run([sys.executable, "-c", code], env=full, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()[-1]


def test_the_warm_up_compiles_the_step_the_demo_then_loads(tmp_path):
    assert _python(WARM, tmp_path / "cache") == "True False"  # started; then cached: not again
    hits, misses, points = json.loads(_python(RUN, tmp_path / "cache"))
    assert points > 27                      # another body than the warm-up's 27 points
    assert (hits, misses) == (1, 0)         # the physical step loaded, not compiled


def test_no_warm_up_when_switched_off(tmp_path):
    assert _python(WARM, tmp_path / "off", JELLYSIM_WARMUP="0") == "False False"
    assert not any((tmp_path / "off").rglob("*.nbi"))  # nothing compiled ahead
