"""numba's target chosen at import (src/jellysim/_cpu.py, JELLYSIM_CPU): which CPU gets which
features, that the user's own NUMBA_CPU_* settings win, and that a run gives the same result,
to rounding, whichever instructions it was compiled for."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from jellysim import _cpu

def _host():
    import llvmlite.binding as llvm

    return _tokens(llvm.get_host_cpu_features().flatten())


def _tokens(flat):
    return dict((t[1:], t[0]) for t in flat.split(","))


def test_the_features_set_are_the_host_s_with_only_the_documented_change():
    host = _host()
    env = {"JELLYSIM_CPU": "nogather"}
    flat = _cpu.configure(env)
    assert flat is not None and env["NUMBA_CPU_FEATURES"] == flat
    got = _tokens(flat)
    assert got.pop("prefer-no-gather") == "+" and got == host
    env = {"JELLYSIM_CPU": "avx2"}
    got = _tokens(_cpu.configure(env))
    assert all(got[k] == "-" for k in got if k.startswith("avx512"))
    assert {k: v for k, v in got.items() if not k.startswith("avx512")} == {
        k: v for k, v in host.items() if not k.startswith("avx512")}


@pytest.mark.parametrize("env", [{"JELLYSIM_CPU": "native"}, {"JELLYSIM_CPU": "auto"}, {},
                                 {"JELLYSIM_CPU": "avx2", "NUMBA_CPU_FEATURES": "+sse2"},
                                 {"JELLYSIM_CPU": "nogather", "NUMBA_CPU_NAME": "generic"}])
def test_numba_s_own_choice_stands_by_default_or_where_the_user_set_numba_s(env):
    """The default is numba's own choice (session 29: `prefer-no-gather`, the default on Zen 4
    before, made freshly compiled and cache-loaded kernels differ, tests/test_cache_bits.py);
    a NUMBA_CPU_* the user set wins over any JELLYSIM_CPU."""
    before = dict(env)
    assert _cpu.configure(env) is None
    assert env == before


def test_an_unknown_mode_is_said_and_auto_used():
    env = {"JELLYSIM_CPU": "avx512"}
    with pytest.warns(UserWarning, match=r"JELLYSIM_CPU='avx512' is not one of"):
        assert _cpu.configure(env) is None


RUN = """
import json, numpy as np, jellysim as js, numba
body = js.Body.box(points=125, distribution="uniform", radius=0.35, seed=5)
model = js.finalize(body, stiffness=40.0, damping=0.05)
sim = js.Simulator(model, dt=2e-3, integrator="symplectic", ground=js.GroundParams(),
                   threads=1)
sim.state.x[:, 1] += 0.3
sim.advance(400)
print(json.dumps({"x": sim.state.x.tolist(), "features": numba.config.CPU_FEATURES or ""}))
"""


def test_a_run_agrees_to_rounding_whatever_instructions_it_was_compiled_for():
    """The same report-ground run (a spring box dropped 0.3 m, bouncing) compiled natively and
    without AVX-512: the sums' vector lanes differ (8 or 4 doubles), so positions differ by
    rounding only, far below the body's 1 m size."""
    out = {}
    for mode in ("native", "avx2"):
        env = dict(os.environ, JELLYSIM_CPU=mode)
        env.pop("NUMBA_CPU_FEATURES", None)
        res = subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True,
                             text=True, timeout=600)
        assert res.returncode == 0, res.stderr
        out[mode] = json.loads(res.stdout.strip().splitlines()[-1])
    assert "-avx512f" in out["avx2"]["features"].split(",")
    a, b = (np.array(out[m]["x"]) for m in ("native", "avx2"))
    assert np.all(np.isfinite(a)) and np.abs(a - b).max() < 1e-9
