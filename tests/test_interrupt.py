"""Ctrl-C during ``Simulator.advance`` (notebook trial, session 30).  A Ctrl-C that landed
between a physical frame's kernel and its bookkeeping left positions 9 mm ahead of ``t`` and
``step``; a long ``advance`` of the springs path (one compiled call) could not be stopped at
all.  Now a signal is acted on between whole steps (``_interrupts.Deferred``), and
``advance`` steps in pieces of about ``Simulator.PIECE_SECONDS`` whose cut changes nothing."""
import copy
import os
import signal
import threading
import time
import warnings

import numpy as np
import pytest

import jellysim as js
from jellysim.geometry import box_field, radius_springs

G = js.GroundParams(model="contact")


@pytest.fixture
def ctrl_c():
    """Python's own Ctrl-C handler for the test (a test runner's worker may ignore SIGINT),
    and a timer that presses Ctrl-C ``seconds`` from now."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    timers = []

    def press_after(seconds):
        timers.append(threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT)))
        timers[-1].start()

    yield press_after
    for t in timers:
        t.join()
    signal.signal(signal.SIGINT, old)


def _report_cube():
    """The README's 600-point cube (the report's constants), Provot over all pairs."""
    points = box_field(600, [0, 0.5, 0], [1, 1.5, 1], distribution="edge", seed=2010)
    body = js.Body(points=points, springs=radius_springs(points, 0.3), volume=1.0)
    model = js.finalize(body, stiffness=2.0, density=1141.0, damping=0.8)

    def make():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return js.Simulator(model, dt=0.01, integrator="paper", ground=js.GroundParams(),
                                provot=js.ProvotParams(tau=0.001, loops=1, pairs="all"))
    return make


def _assert_same_state(a, b):
    for name in ("x", "v", "a"):
        np.testing.assert_array_equal(getattr(a.state, name), getattr(b.state, name))
    assert a.state.t == b.state.t and a.state.step == b.state.step


def test_an_interrupted_physical_advance_stops_at_a_whole_frame(ctrl_c):
    """Ctrl-C half a second into advance(10**6) of a gelatin cube: KeyboardInterrupt within
    a frame or so, and x, v, a, t and step are those of a straight run to the same step
    (bitwise), which then goes on alike; Ctrl-C's handler is back afterwards."""
    model = js.physical_model(js.Body.box(points=64), js.material("gelatin"))
    sim = js.Simulator(model, dt=1 / 60, ground=G)
    sim.advance(5)  # (compiled or loaded)
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        ctrl_c(0.5)
        sim.advance(10**6)
    assert time.perf_counter() - started < 2.5
    steps = sim.state.step
    assert 5 < steps < 10**6 and sim.state.t == steps * (1 / 60)
    straight = js.Simulator(model, dt=1 / 60, ground=G)
    straight.advance(steps)
    _assert_same_state(sim, straight)
    sim.advance(3)
    straight.advance(3)
    _assert_same_state(sim, straight)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_long_springs_advance_stops_soon_after_ctrl_c(ctrl_c):
    """The README's report cube asked for 10**7 steps (hours): Ctrl-C half a second in ends
    it within about a piece, at a step a straight run reproduces bitwise."""
    make = _report_cube()
    sim = make()
    sim.advance(2)
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        ctrl_c(0.5)
        sim.advance(10**7)
    assert time.perf_counter() - started < 0.5 + 1.5
    steps = sim.state.step
    assert 2 < steps < 10**7
    straight = make()
    straight.advance(steps)
    _assert_same_state(sim, straight)


@pytest.mark.parametrize("kind", ["paper-all-pairs", "paper-springs", "symplectic",
                                  "implicit-theta", "implicit-bdf2", "physical"])
def test_the_pieces_an_advance_is_cut_into_change_nothing(kind):
    """One step a piece (PIECE_SECONDS tiny) against one piece after the first eight: the
    same bits, on each path."""
    if kind == "paper-all-pairs":
        make = _report_cube()
    else:
        body = js.Body.box(points=125, distribution="uniform", radius=0.35, seed=5)
        springs = js.finalize(body, stiffness=40.0, damping=0.05)
        jello = js.physical_model(js.Body.box(points=64), js.material("gelatin"))

        def make():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if kind == "physical":
                    sim = js.Simulator(jello, dt=1 / 60, ground=G)
                elif kind.startswith("implicit"):
                    sim = js.Simulator(springs, dt=1 / 60, integrator="implicit", ground=G,
                                       implicit=js.ImplicitParams(scheme=kind[9:]))
                else:
                    sim = js.Simulator(
                        springs, dt=5e-6 if kind == "paper-springs" else 2e-3, integrator=(
                            "paper" if kind == "paper-springs" else "symplectic"),
                        ground=js.GroundParams(), provot=js.ProvotParams(
                            tau=0.01, loops=2, pairs="springs"))
            sim.state.x[:, 1] += 0.05
            return sim
    runs = []
    for seconds in (1e-12, 1e9):
        sim = make()
        sim.PIECE_SECONDS = seconds
        sim.advance(40)
        runs.append(sim)
    _assert_same_state(*runs)


def test_a_shallow_copy_is_an_independent_simulator():
    """copy.copy(sim) stepped on does not move sim (it shared the state arrays)."""
    model = js.physical_model(js.Body.box(points=64), js.material("gelatin"))
    sim = js.Simulator(model, dt=1 / 60, ground=G)
    sim.advance(3)
    other = copy.copy(sim)
    x = sim.state.x.copy()
    other.advance(5)
    assert sim.state.step == 3 and other.state.step == 8 and other.model is sim.model
    np.testing.assert_array_equal(sim.state.x, x)
    assert not np.array_equal(other.state.x, x)


FORK_POOL = r"""
import multiprocessing as mp, sys
import jellysim as js

def job(k):
    body = js.Body.box(points=27, distribution="uniform", radius=0.5, seed=k)
    model = js.finalize(body, stiffness=2.0, density=1000.0)
    sim = js.Simulator(model, dt=1e-3, integrator="symplectic")
    sim.advance(5)
    return float(sim.state.x[:, 1].mean())

if __name__ == "__main__":
    job(0)  # the parent runs jellysim's threads first
    try:
        with mp.get_context("fork").Pool(2) as pool:
            print(pool.map(job, [1, 2]))
    except js.errors.JellysimError as exc:
        print("REFUSED:", exc)
    with mp.get_context("spawn").Pool(2) as pool:
        print("SPAWN:", pool.map(job, [1, 2]) == [job(1), job(2)])
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork() exists on POSIX only")
def test_a_pool_forked_after_a_run_is_told_to_spawn_instead_of_hanging(tmp_path):
    """Sweep trial, session 30: after one simulation in the parent, a fork-started
    multiprocessing.Pool hung for ever (numba ended each worker at its first OpenMP kernel).
    Now the worker raises a JellysimError naming the fix, which the pool hands back; a spawn
    pool gives the parent's own numbers."""
    import subprocess
    import sys

    script = tmp_path / "pool.py"
    script.write_text(FORK_POOL)
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=300, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "REFUSED: Simulator: this process was forked" in res.stdout
    assert "get_context('spawn')" in res.stdout and "SPAWN: True" in res.stdout
    assert "Terminating" not in res.stderr
