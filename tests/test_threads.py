"""Threads: the CLI's --threads option changes nothing in the results; jellysim's import sets
OpenMP's passive wait (robust to competing processes) unless the user chose otherwise."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from jellysim.cli import cli
from jellysim.io.trajectory import load_trajectory

ROOT = Path(__file__).resolve().parent.parent

SCENE = """
[body]
points = 700
distribution = "uniform"
lower = [0.0, 0.05, 0.0]
upper = [1.0, 1.05, 1.0]
seed = 5

[springs]
radius = 0.2
stiffness = 2000.0

[mass]
point_mass = 1.0

[physics]
damping = 0.5

[integrator]
name = "symplectic"
dt = 0.002
steps = 30

[provot]
loops = 2

[output]
every = 10
vtu = false
"""


def test_cli_threads_option_gives_bitwise_equal_runs(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE)
    runs = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}"
        res = CliRunner().invoke(cli, ["run", str(scene), "--out", str(out), "--quiet",
                                       "--threads", str(threads)])
        assert res.exit_code == 0, res.output
        assert f"real time, on {threads} thread(s))" in res.output  # the summary says it
        traj = load_trajectory(out / "trajectory.npz")
        assert traj.params["integrator"]["threads"] == threads
        runs.append(traj.positions[-1])
    assert np.array_equal(runs[0], runs[1])
    assert np.ptp(runs[0][:, 1]) > 0.5  # the body moved and landed, still a body
    res = CliRunner().invoke(cli, ["run", str(scene), "--threads", "0"])
    assert res.exit_code == 2 and "--threads" in res.output


def _env_after_import(*, names=("OMP_WAIT_POLICY", "KMP_BLOCKTIME", "GOMP_SPINCOUNT"), **env):
    drop = names + ("JELLYSIM_THREADING", "OMP_NUM_THREADS", "NUMBA_NUM_THREADS")
    base = {k: v for k, v in os.environ.items() if k not in drop}
    base.update(env)
    base["PYTHONPATH"] = str(ROOT / "src")
    code = f"import os, jellysim; print(*[os.environ.get(k) for k in {names!r}])"
    res = subprocess.run([sys.executable, "-W", "always", "-c", code], env=base,
                         capture_output=True, text=True, check=True)
    return res.stdout.split(), res.stderr


def test_import_sets_a_short_spin_and_passive_wait_unless_the_user_chose():
    """libgomp's threads spin 1000 times (about 10 us) then sleep; other OpenMP runtimes
    sleep at once; a user's own settings win; ``JELLYSIM_THREADING`` picks another set-up,
    and an unknown value is said, not ignored."""
    assert _env_after_import() == (["PASSIVE", "0", "1000"], "")
    assert _env_after_import(OMP_WAIT_POLICY="active")[0] == ["active", "0", "1000"]
    assert _env_after_import(GOMP_SPINCOUNT="50")[0] == ["PASSIVE", "0", "50"]
    assert _env_after_import(JELLYSIM_THREADING="passive")[0] == ["PASSIVE", "0", "None"]
    assert _env_after_import(JELLYSIM_THREADING="spin")[0] == ["None", "None", "None"]
    values, said = _env_after_import(JELLYSIM_THREADING="spinning")
    assert values == ["PASSIVE", "0", "1000"]
    assert "JELLYSIM_THREADING='spinning' is not known" in said and "'passive'" in said
    assert _env_after_import(JELLYSIM_THREADING=" Spin ") == (["None", "None", "None"], "")


def test_omp_num_threads_sizes_numbas_pool_and_bad_counts_are_said():
    """OMP_NUM_THREADS (the usual polite setting on a shared machine, which numba ignores)
    sizes numba's pool unless NUMBA_NUM_THREADS is set; a count that is not >= 1 is said and
    dropped (numba stopped with a traceback on NUMBA_NUM_THREADS=0)."""
    pool = ("NUMBA_NUM_THREADS",)
    code = "import numba; print(numba.config.NUMBA_NUM_THREADS)"
    assert _env_after_import(names=pool, OMP_NUM_THREADS="1")[0] == ["1"]
    assert _env_after_import(names=pool, OMP_NUM_THREADS="1,1")[0] == ["1"]
    assert _env_after_import(names=pool, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="2")[0] == ["2"]
    values, said = _env_after_import(names=pool, NUMBA_NUM_THREADS="0")
    assert values == ["None"] and "NUMBA_NUM_THREADS='0' is not a thread count" in said
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_NUM_THREADS",)}
    env.update(OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "src"))
    res = subprocess.run([sys.executable, "-c", "import jellysim; " + code], env=env,
                         capture_output=True, text=True, check=True)
    assert res.stdout.split() == ["1"]  # numba's pool really is one thread


def test_auto_threads_drops_to_one_on_an_oversubscribed_machine(monkeypatch):
    import numba

    from jellysim import simulator

    cpus = os.cpu_count()
    monkeypatch.setattr(os, "getloadavg", lambda: (0.2, 0.2, 0.2))  # idle: every thread
    assert simulator.auto_threads(10_000) == numba.config.NUMBA_NUM_THREADS
    assert simulator.auto_threads(100) == 1  # small bodies: one thread regardless
    assert simulator.auto_threads(10_000, simulator.PARALLEL_MIN_SPRINGS - 1) == 1
    assert simulator.auto_threads(10_000, simulator.PARALLEL_MIN_SPRINGS) == (
        numba.config.NUMBA_NUM_THREADS)
    monkeypatch.setattr(os, "getloadavg", lambda: (cpus + 1.0, 0.0, 0.0))  # a busy process
    assert simulator.auto_threads(10_000) == numba.config.NUMBA_NUM_THREADS  # per core: passive
    monkeypatch.setattr(os, "getloadavg", lambda: (2.5 * cpus, 0.0, 0.0))  # oversubscribed
    assert simulator.auto_threads(10_000) == 1
    monkeypatch.setattr(os, "getloadavg", lambda: (20.0 * cpus, 0.0, 0.0))
    assert simulator.auto_threads(1_000_000) == 1


def test_more_threads_than_numba_has_are_capped_and_said():
    """``Simulator.threads`` is what the steps use: asking for more threads than numba's pool
    holds warns and reports the pool's size, and the run equals the pool-sized one bitwise."""
    import warnings

    import numba
    import pytest

    import jellysim as js

    most = int(numba.config.NUMBA_NUM_THREADS)
    body = js.Body.box(points=200, distribution="uniform", radius=0.35, seed=2)
    model = js.finalize(body, stiffness=500.0, density=1.0)
    with pytest.warns(UserWarning, match=f"numba runs at most {most}"):
        many = js.Simulator(model, dt=1e-3, threads=most + 3)
    assert many.threads == most
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pool = js.Simulator(model, dt=1e-3, threads=most)
    assert pool.threads == most
    many.advance(20)
    pool.advance(20)
    assert np.array_equal(many.state.x, pool.state.x)


def test_thread_choice_keeps_the_faster_count_and_tries_the_other_again():
    """The chooser (threads = None) runs its first frame on each count untimed, interleaves
    four timed frames of each, keeps all threads if faster than one by more than MARGIN
    (else one), and tries the other count again every PROBE_EVERY frames: here 2 threads are
    faster at first (300 vs 400 us a substep), then slower (the machine got busy: 800 us)."""
    from jellysim.thread_choice import MARGIN, PROBE_EVERY, ThreadChoice

    cost = {1: 400e-6, 2: 300e-6}
    ch = ThreadChoice(start=1, most=2)
    frames = []
    for _ in range(2 * PROBE_EVERY + 20):
        count, timed = ch.next_frame()
        frames.append((count, timed))
        if timed:
            ch.record(count, cost[count] * 40, 40)
        if len(frames) == PROBE_EVERY:
            cost[2] = 800e-6  # from here on the second thread costs more
    assert frames[:10] == [(1, False), (2, False)] + [(1, True), (2, True)] * 4
    retry = 10 + PROBE_EVERY  # the first try's 10 frames, then PROBE_EVERY on the choice
    assert all(c == 2 for c, _ in frames[10:retry])  # 300 < (1 - MARGIN) 400: switched to 2
    # 1 tried again (its first frame untimed: it warms that count up): 400 < 800
    assert frames[retry:retry + 3] == [(1, False), (1, True), (1, True)]
    assert all(c == 1 for c, _ in frames[retry + 3:retry + 3 + PROBE_EVERY])  # kept
    assert [c for c, _ in frames[retry + 3 + PROBE_EVERY:]] == [2, 2, 2] + [1] * 4  # 2 tried
    # two threads within MARGIN of one thread's speed: one thread, whichever it started on
    # (a tie leaves the other core to other work)
    for start in (1, 2):
        ch = ThreadChoice(start=start, most=2)
        for _ in range(40):
            count, timed = ch.next_frame()
            if timed:
                ch.record(count, (1.0 - 0.5 * MARGIN if count == 2 else 1.0) * 1e-2, 40)
        assert ch.chosen and ch.current == 1


def test_threads_chosen_by_timing_change_nothing_in_the_results():
    """A physical body big enough for the chooser (threads = None) runs its first frames on
    1 and on all of numba's threads, and its trajectory is bitwise the one-thread run's."""
    import numba

    from jellysim.body import Body
    from jellysim.geometry.lattice import grid_points, grid_tets
    from jellysim.params import GroundModel, GroundParams
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin
    from jellysim.simulator import Simulator
    from jellysim.thread_choice import ADAPTIVE_MIN_TETS

    most = numba.config.NUMBA_NUM_THREADS
    if most < 2:
        pytest.skip("numba has one thread here (NUMBA_NUM_THREADS): there is nothing to choose")
    pts = grid_points(13**3, [0.0, 0.01, 0.0], [0.08, 0.09, 0.08])
    model = physical_model(Body(points=pts, springs=np.zeros((0, 2), dtype=np.int64),
                                volume=0.08**3, tets=grid_tets(pts),
                                meta={"distribution": "grid"}), gelatin())
    assert model.fem.tet_count >= ADAPTIVE_MIN_TETS
    ground = GroundParams(model=GroundModel.CONTACT)
    auto = Simulator(model, dt=1 / 60, ground=ground)
    one = Simulator(model, dt=1 / 60, ground=ground, threads=1)
    used = set()
    for _ in range(12):
        auto.advance(1)
        one.advance(1)
        used.add(auto.threads)
    assert used == {1, most}
    assert np.array_equal(auto.state.x, one.state.x) and np.array_equal(auto.state.v, one.state.v)
    assert auto.state.x[:, 1].min() < 0.005  # it fell onto the ground: contact was in play


def test_springs_chooser_tries_the_other_count_after_seconds_not_calls():
    """On the springs path a piece ends with each advance() call, so the other count is tried
    after SPRINGS_PROBE_SECONDS of timed steps on the chosen one, however the steps were cut:
    pieces of 1/32 s try it once in 66 pieces (a count of ten pieces tried it once in 12)."""
    from jellysim.thread_choice import SPRINGS_PROBE_SECONDS, ThreadChoice

    for piece_seconds in (1 / 32, 1 / 4):  # (sums of them are exact)
        ch = ThreadChoice(start=2, most=2, probe_seconds=SPRINGS_PROBE_SECONDS)
        counts = []
        for _ in range(10 + 3 * int(SPRINGS_PROBE_SECONDS / piece_seconds) + 9):
            count, timed = ch.next_frame()
            counts.append(count)
            if timed:  # one thread 1.5x slower a step: all threads are kept
                ch.record(count, piece_seconds * (1.5 if count == 1 else 1.0), 100)
        after = counts[10:]
        runs = int(round(SPRINGS_PROBE_SECONDS / piece_seconds))
        assert after[:runs] == [2] * runs and after[runs:runs + 3] == [1, 1, 1]
        assert after[runs + 3:2 * runs + 3] == [2] * runs and after[2 * runs + 3] == 1
        assert ch.current == 2 and ch.chosen
    # a first try disturbed (two threads timed 2x slower than one), then two threads 2x
    # faster: one later try decides on its own timings, not on the first try's
    ch = ThreadChoice(start=2, most=2, probe_seconds=SPRINGS_PROBE_SECONDS)
    cost = {1: 1.0, 2: 2.0}
    for i in range(10 + int(SPRINGS_PROBE_SECONDS / 0.25) + 4):
        count, timed = ch.next_frame()
        if i == 10:  # (the first try is decided as its next frame is asked for)
            assert ch.current == count == 1
            cost[2] = 0.5
        if timed:
            ch.record(count, 0.25 * cost[count], 100)
    assert ch.current == 2


def test_short_pieces_are_summed_into_one_timing():
    """Pieces shorter than min_seconds (advance(10): about 1 ms) are summed per count into
    one timing, and a try runs a count again until its timing is that long: the first try
    gives each count four timings of ten 1 ms pieces, not four 1 ms ones."""
    import itertools

    from jellysim.thread_choice import ThreadChoice

    ch = ThreadChoice(start=2, most=2, probe_seconds=2.0, min_seconds=0.01)
    counts = []
    while not ch.chosen:
        count, timed = ch.next_frame()
        counts.append(count)
        if timed:
            ch.record(count, 0.001 * (1.0 if count == 2 else 1.5), 10)
    assert counts[:2] == [2, 1]  # untimed first frames
    runs = [(c, len(list(g))) for c, g in itertools.groupby(counts[2:-1])]
    assert [c for c, _ in runs] == [2, 1] * 4
    assert [n for c, n in runs] == [10, 7] * 4  # 10 x 1 ms; 7 x 1.5 ms >= 10 ms
    assert ch.current == 2 and len(ch.cost[1]) == len(ch.cost[2]) == 4


def test_a_chooser_pickled_before_its_new_fields_still_runs():
    """A Simulator in an older checkpoint holds a chooser without the fields added since
    (probe_every, min_seconds, ...): unpickled, it runs frames and decides as before."""
    import pickle

    from jellysim.thread_choice import PROBE_EVERY, ThreadChoice

    old = ThreadChoice(start=1, most=2)
    for name in ("probe_every", "_timed_probe", "min_seconds", "_sum"):
        del old.__dict__[name]
    ch = pickle.loads(pickle.dumps(old))
    assert ch.probe_every == PROBE_EVERY and ch.min_seconds == 0.0
    for _ in range(11):
        count, timed = ch.next_frame()
        if timed:
            ch.record(count, 1e-3 if count == 2 else 2e-3, 1)
    assert ch.chosen and ch.current == 2


@pytest.mark.parametrize("integrator, order", [("paper", "jacobi"),
                                               ("symplectic", "gauss-seidel"),
                                               ("implicit", None)])
def test_springs_threads_chosen_by_timing_change_nothing_in_the_results(integrator, order):
    """A spring body given no thread count runs its pieces on 1 and on all of numba's
    threads (the chooser's first try), the try's pieces short, and its trajectory is bitwise
    the one-thread run's, on the report's ground."""
    import numba

    import jellysim as js
    from jellysim import thread_choice

    most = numba.config.NUMBA_NUM_THREADS
    if most < 2:
        pytest.skip("numba has one thread here (NUMBA_NUM_THREADS): there is nothing to choose")
    body = js.Body.box(points=600, distribution="uniform", radius=0.3, seed=4,
                       lower=(0.0, 0.02, 0.0), upper=(1.0, 1.02, 1.0))
    model = js.finalize(body, stiffness=20.0, point_mass=0.05, damping=0.01)
    assert model.spring_count >= thread_choice.ADAPTIVE_MIN_SPRINGS
    kw = dict(dt=0.005, integrator=integrator, ground=js.GroundParams(),
              provot=order and js.ProvotParams(tau=0.01, loops=2, order=order),
              check_stability=False)
    auto, one = js.Simulator(model, **kw), js.Simulator(model, threads=1, **kw)
    assert auto._thread_choice and not one._thread_choice
    used = set()
    for _ in range(12):
        auto.advance(3)
        one.advance(3)
        used.add(auto.threads)
    assert used == {1, most}
    auto.advance(40)  # (pieces of several steps: the try's are TRY_PIECE_SECONDS long)
    one.advance(40)
    assert np.array_equal(auto.state.x, one.state.x) and np.array_equal(auto.state.v, one.state.v)
    assert set(auto.thread_steps) == {1, most} and sum(auto.thread_steps.values()) == 76
    assert one.thread_steps == {1: 76}
    assert one.state.x[:, 1].min() == 0.0  # it fell onto the ground: the ground rule was in play
