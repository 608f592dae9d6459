"""Nothing lost (issue 13): streamed frames, checkpoints, bitwise resume, clean stops."""
import os
import signal
import subprocess
import sys
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest

from jellysim.errors import CheckpointError, JellysimError, RunInterrupted, SceneError
from jellysim.io.checkpoint import CHECKPOINT
from jellysim.io.stream import STREAM_DIR, GrowingNpy, stream_frames
from jellysim.io.trajectory import load_trajectory
from jellysim.runner import run_scene
from jellysim.scene import Scene

DATA = Path(__file__).parent / "data"

EXPLICIT = """
[body]
points = 60
lower = [0.0, 0.05, 0.0]
upper = [0.3, 0.35, 0.3]
seed = 3
[springs]
radius = 0.16
stiffness = 300.0
[mass]
point_mass = 0.002
[physics]
damping = 0.002
[ground]
model = "contact"
[integrator]
name = "symplectic"
dt = 0.001
steps = 300
[output]
every = 20
vtu = false
"""

IMPLICIT = """
[material]
preset = "gelatin"
model = "springs"          # the springs path with the implicit integrator
[body]
type = "box"
points = 64
distribution = "grid"
lower = [0.0, 0.005, 0.0]
upper = [0.06, 0.065, 0.06]
[springs]
connect = "radius"
radius = 0.027
[integrator]
name = "implicit"
scheme = "bdf2"
dt = 0.005
steps = 60
[output]
every = 4
vtu = false
"""

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _same(a, b):
    for name in ("positions", "velocities", "times", "steps"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape, name
        assert np.array_equal(x, y), f"{name} differ"   # bitwise (no NaN in these runs)


@pytest.mark.parametrize("text", [EXPLICIT, IMPLICIT], ids=["explicit", "implicit-bdf2"])
def test_stop_and_resume_is_bitwise_equal_to_an_uninterrupted_run(tmp_path, text):
    scene = Scene.from_text(text, name="scene.toml")
    full = run_scene(scene, tmp_path / "full", progress=False)
    ref = load_trajectory(full.trajectory)
    every = scene.frame_every
    with pytest.raises(RunInterrupted) as info:
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=3 * every + 1)
    assert "--resume" in str(info.value)
    cut = tmp_path / "cut"
    assert not (cut / "trajectory.npz").exists() and (cut / CHECKPOINT).exists()
    # the stopped run's frames are readable (through the missing .npz) and equal the reference
    part = load_trajectory(cut / "trajectory.npz")
    assert part.frame_count == 5 and part.status.startswith("interrupted")
    assert np.array_equal(part.positions, ref.positions[:5])
    res = run_scene(scene, cut, progress=False, resume=True)
    assert res.resumed_from == 4 * every
    _same(load_trajectory(res.trajectory), ref)
    # the simulated time each call reports (what `jellysim run` divides by its wall time for
    # the real-time factor): its own steps x dt, the trajectory's time span for the full run
    assert full.simulated == pytest.approx(ref.times[-1] - ref.times[0], rel=1e-12)
    assert res.simulated == pytest.approx((full.steps - res.resumed_from) / full.steps
                                          * full.simulated, rel=1e-12)
    assert not (cut / STREAM_DIR).exists() and not (cut / CHECKPOINT).exists()
    with pytest.raises(CheckpointError, match="nothing to resume"):
        run_scene(scene, cut, progress=False, resume=True)


def test_resume_command_repeats_the_set_overrides(tmp_path):
    """The command printed after an interruption resumes the run: it carries the run's
    ``--set`` items (without them the checkpoint is "written for another scene"); a bad
    ``--set`` key is blamed on the command line, not the file."""
    path = tmp_path / "s.toml"
    path.write_text(EXPLICIT)
    sets = ("integrator.steps=80",)
    scene = Scene.load(path, overrides=sets)
    with pytest.raises(RunInterrupted) as info:
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=2 * scene.frame_every)
    msg = str(info.value)
    command = msg[msg.index("continue with: ") + len("continue with: "):]
    import shlex

    argv = shlex.split(command)
    assert argv[:4] == ["jellysim", "run", str(path), "--resume"]
    again = tuple(argv[k + 1] for k, a in enumerate(argv) if a == "--set")
    assert again == sets
    res = run_scene(Scene.load(path, overrides=again), tmp_path / "cut", progress=False,
                    resume=True)
    assert load_trajectory(res.trajectory).steps[-1] == 80
    with pytest.raises(SceneError, match=r"given as an override: --set body\.pionts=5"):
        Scene.load(path, overrides=("body.pionts=5",))
    # a misspelt section given on the command line is said to come from there too (the
    # reliability trial: "unknown section [bdy]" seemed to be the file's)
    with pytest.raises(SceneError, match=r"unknown section \[bdy\].*\(given as an "
                                         r"override: --set bdy\.points=5\)"):
        Scene.load(path, overrides=("bdy.points=5",))
    # one string is one override, not one per character (sweep trial, session 30: a bare
    # string was read as --set 'b', --set 'o', ...)
    with pytest.raises(SceneError, match=r"\(given as an override: --set body\.pionts=5\)"):
        Scene.load(path, overrides="body.pionts=5")
    assert Scene.load(path, overrides="integrator.steps=7").steps == 7


def test_a_resume_finishes_the_steps_the_interrupted_run_asked(tmp_path):
    """A run given its own step count (`jellysim run --steps N`) and cut short finishes those N
    steps when resumed without repeating --steps (the checkpoint keeps them), bitwise as the
    uninterrupted run; a step count below the checkpoint's is refused, not "completed"."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    every, asked = scene.frame_every, 3 * scene.steps
    ref = load_trajectory(run_scene(scene, tmp_path / "full", progress=False,
                                    steps=asked).trajectory)
    with pytest.raises(RunInterrupted):
        run_scene(scene, tmp_path / "cut", progress=False, steps=asked,
                  stop_after=scene.steps + every)
    with pytest.raises(CheckpointError, match=r"past the 4 steps asked; resume with --steps"):
        run_scene(scene, tmp_path / "cut", progress=False, resume=True, steps=4)
    res = run_scene(scene, tmp_path / "cut", progress=False, resume=True)
    traj = load_trajectory(res.trajectory)
    assert traj.steps[-1] == asked and traj.status == "complete"
    _same(traj, ref)
    # the recorded parameters are the run's: the steps asked, not the scene file's
    assert ref.params["integrator"]["steps"] == asked != scene.steps
    assert traj.params["integrator"]["steps"] == asked
    assert ref.scene_toml.endswith(f"# run for {asked} steps (--steps)\n")


def test_run_scene_takes_a_scene_files_path_and_refuses_anything_else(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(EXPLICIT)
    res = run_scene(str(path), tmp_path / "out", progress=False, steps=4)
    assert load_trajectory(res.trajectory).steps[-1] == 4
    from jellysim.errors import ParameterError

    with pytest.raises(ParameterError, match=r"Scene\.from_file\(path\)"):
        run_scene(42, tmp_path / "out2", progress=False)
    assert not (tmp_path / "out2").exists()


@pytest.mark.parametrize("text", [EXPLICIT, IMPLICIT], ids=["explicit", "implicit-bdf2"])
def test_a_finished_run_extended_is_bitwise_the_longer_run(tmp_path, text):
    """A completed run continued for more steps (`jellysim run --resume DIR --set
    integrator.steps=N`, or `--steps N`) is bitwise the run asked for N steps from the start:
    the same frames, on the first run's frame schedule (the default `[output] every` follows
    the step count; an extension keeps the schedule it started with), and its ParaView series
    grows with it.  Asking a finished run for no more steps says how to extend it."""
    text = text.replace("every = 20\n", "").replace("every = 4\n", "").replace(
        "vtu = false", "vtu = true")
    short = Scene.from_text(text, name="scene.toml", overrides=("integrator.steps=100",))
    every = short.frame_every                      # 1 (100 steps: a frame every step)
    ref = load_trajectory(run_scene(Scene.from_text(text.replace(
        "[output]\n", f"[output]\nevery = {every}\n"), name="scene.toml",
        overrides=("integrator.steps=150",)), tmp_path / "full", progress=False).trajectory)
    out = tmp_path / "run"
    first = run_scene(short, out, progress=False)
    with pytest.raises(CheckpointError, match=r"finished at step 100 .*--steps N .*N > 100"):
        run_scene(short, out, progress=False, resume=True)
    longer = Scene.from_text(text, name="scene.toml", overrides=("integrator.steps=150",))
    assert longer.frame_every != every             # so the schedule kept is the first run's
    res = run_scene(longer, out, progress=False, resume=True)
    assert res.resumed_from == 100 and first.frames == 101 and res.frames == 151
    traj = load_trajectory(out)
    assert traj.status == "complete" and traj.steps[-1] == 150
    _same(traj, ref)
    assert (out / "body.pvd").read_text().count("<DataSet ") == 151
    assert not (out / STREAM_DIR).exists() and not (out / CHECKPOINT).exists()
    # and once more through --steps, the scene unchanged
    res = run_scene(longer, out, progress=False, resume=True, steps=170)
    assert load_trajectory(out).steps[-1] == 170 and res.resumed_from == 150


def test_internal_state_round_trip_continues_bitwise():
    """Two simulators: one runs 2n steps, the other takes over at n from the first one's
    state + internal_state and must end bitwise identical (implicit BDF2 with contact)."""
    scene = Scene.from_text(IMPLICIT, name="scene.toml")
    model = scene.build_model()
    a = scene.simulator(model)
    a.advance(7)
    snap = a.state.copy(), a.internal_state()
    assert {"_hist", "_fresh", "_contact_state", "_cg.0"} <= set(snap[1])
    a.advance(9)
    b = scene.simulator(model)
    b.state.assign(snap[0])
    b.restore_internal_state(snap[1])
    b.advance(9)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    assert a.cg_iterations == b.cg_iterations
    # without the internal state (BDF2 history, warm start) the runs part
    c = scene.simulator(model)
    c.state.assign(snap[0])
    c.advance(9)
    assert not np.array_equal(a.state.x, c.state.x)


def test_checkpoint_is_refused_for_another_scene(tmp_path):
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    with pytest.raises(RunInterrupted):
        run_scene(scene, tmp_path, progress=False, stop_after=40)
    other = Scene.from_text(EXPLICIT.replace("stiffness = 300.0", "stiffness = 301.0"),
                            name="other.toml")
    with pytest.raises(CheckpointError, match="another scene"):
        run_scene(other, tmp_path, progress=False, resume=True)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        run_scene(scene, tmp_path / "empty", progress=False, resume=True)


def test_growing_npy_ignores_an_unflushed_tail(tmp_path):
    """A kill between appending a frame's bytes and rewriting the header leaves extra bytes:
    np.load and the reopened file see only the flushed rows."""
    g = GrowingNpy(tmp_path / "a.npy", "<f8", (4, 3))
    rows = np.arange(24.0).reshape(2, 4, 3)
    g.append(rows)
    g.commit()
    g.append(rows[:1] + 100)           # appended, never committed (killed here)
    with open(tmp_path / "a.npy", "ab") as fh:
        fh.write(b"\x01\x02\x03")      # and half of another row
    g.close()
    assert np.array_equal(np.load(tmp_path / "a.npy"), rows)
    g = GrowingNpy(tmp_path / "a.npy", "<f8", (4, 3), keep=2)
    g.append(rows[1:] + 1)
    g.commit()
    g.close()
    got = np.load(tmp_path / "a.npy", mmap_mode="r")
    assert got.shape == (3, 4, 3) and np.array_equal(got[2], rows[1] + 1)


def test_a_full_disk_neither_publishes_a_short_frame_nor_hides_the_written_ones(tmp_path,
                                                                              monkeypatch):
    """A full disk makes ``pwrite`` write fewer bytes than asked and then none: the frame is
    refused (OSError ENOSPC, its header never counts it) and the frames written before stay
    readable; a stream whose header promises a frame its data lack (cut short) is read up to
    its last whole frame."""
    import errno
    import os

    from jellysim.io import stream as st
    from jellysim.state import State

    n = 5
    ts = st.TrajectoryStream(tmp_path / "s", n, {"rest_positions": np.zeros((n, 3))})
    for k in range(3):
        ts.record(State(np.full((n, 3), k + 0.5), np.full((n, 3), -k - 0.5), np.zeros((n, 3)),
                        0.1 * k, k))
    real = os.pwrite
    calls = []

    def full(fd, data, offset):  # 8 bytes, then nothing: the disk is full
        calls.append(len(data))
        return real(fd, bytes(data[:8]), offset) if len(calls) == 1 else 0

    monkeypatch.setattr(st.os, "pwrite", full)
    with pytest.raises(OSError) as err:
        ts.record(State(np.ones((n, 3)), np.ones((n, 3)), np.zeros((n, 3)), 0.3, 3))
    assert err.value.errno == errno.ENOSPC and "positions.npy" in str(err.value)
    monkeypatch.setattr(st.os, "pwrite", real)
    assert ts.frames == 3 and ts.files["positions"].rows == 3
    ts.close()
    d = st.read_stream(tmp_path / "s")
    assert d["positions"].shape == (3, n, 3) and np.array_equal(d["steps"], [0, 1, 2])
    assert np.array_equal(d["velocities"][2], np.full((n, 3), -2.5))
    # a header that promises a 4th frame the data lack (a short write taken for whole)
    g = st.GrowingNpy(tmp_path / "s" / "positions.npy", "<f8", (n, 3), keep=3)
    g.rows = 4
    g.commit()
    g.close()
    assert st.stream_frames(tmp_path / "s") == 3
    assert st.read_stream(tmp_path / "s")["positions"].shape == (3, n, 3)


def _peak(scene, out, steps):
    tracemalloc.start()
    try:
        run_scene(scene, out, progress=False, steps=steps)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_peak_memory_does_not_grow_with_frames(tmp_path):
    """50 frames vs 2,000 frames of a 60-point body: peak traced memory within 10 %
    (the in-memory recorder held 2,000 x 60 x 48 B = 5.8 MB more)."""
    scene = Scene.from_text(EXPLICIT.replace("every = 20", "every = 1"), name="scene.toml")
    run_scene(scene, tmp_path / "warm", progress=False, steps=5)   # compile first
    few = _peak(scene, tmp_path / "few", 50)
    many = _peak(scene, tmp_path / "many", 2000)
    assert load_trajectory(tmp_path / "many").frame_count == 2001
    print("peak traced memory", few, many)
    assert many <= 1.10 * few, (few, many)


def _cli(args, **kw):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen([sys.executable, "-m", "jellysim.cli", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _wait_frames(stream, k, proc, limit=120.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit:
        if proc.poll() is not None:
            raise AssertionError(f"run ended early: {proc.communicate()}")
        try:
            if stream_frames(stream) >= k:
                return
        except (FileNotFoundError, ValueError):
            pass
        time.sleep(0.02)
    raise AssertionError("no frames appeared")


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_killed_run_leaves_its_frames_and_resumes_bitwise(tmp_path, sig):
    """A CLI run (with .vtu output) killed mid-run: every frame flushed before the kill is
    readable and bitwise equal to an uninterrupted run's, no hidden file is left, and
    ``--resume`` completes it bitwise equal."""
    text = EXPLICIT.replace("steps = 300", "steps = 200000").replace(
        "every = 20", "every = 200").replace("vtu = false", "vtu = true")
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "run"
    proc = _cli(["run", str(tmp_path / "s.toml"), "-o", str(out), "--quiet",
                 "--checkpoint-every", "1000"])
    _wait_frames(out / STREAM_DIR, 12, proc)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    if sig == signal.SIGTERM:
        assert proc.returncode == 128 + signal.SIGTERM
        assert "--resume" in err and str(out) in err
    else:
        assert proc.returncode == -signal.SIGKILL
    from jellysim.io.lock import LOCK_NAME

    left = [p.name for p in out.iterdir() if p.name.startswith(".")]
    # no hidden temporary; only SIGKILL (no clean-up possible) leaves the run's lock, whose
    # process is gone: the resume below takes it over
    assert left == ([LOCK_NAME] if sig == signal.SIGKILL else [])
    part = load_trajectory(out / "trajectory.npz")         # falls back to the stream
    frames = part.frame_count
    assert frames >= 12
    pvd = (out / "body.pvd").read_text()
    assert pvd.rstrip().endswith("</VTKFile>") and pvd.count("<DataSet") >= frames - 1
    # the CLI readers take the killed run (its missing .npz, or its directory)
    from click.testing import CliRunner

    from jellysim.cli import cli

    r = CliRunner().invoke(cli, ["export", str(out / "trajectory.npz"), "--sequence", "obj",
                                 "-o", str(tmp_path / "objs")])
    assert r.exit_code == 0, r.output
    assert len(list((tmp_path / "objs").glob("*.obj"))) == frames
    r = CliRunner().invoke(cli, ["plot", str(out), "-o", str(tmp_path / "e.png")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"
    # the same run, uninterrupted, in this process, up to the resumed end
    scene = Scene.from_text(text, name="s.toml")
    steps = int(part.steps[-1]) + 600
    ref = load_trajectory(run_scene(scene, tmp_path / "ref", progress=False, vtu=False,
                                    steps=steps).trajectory)
    assert np.array_equal(part.positions, ref.positions[:frames])
    assert np.array_equal(part.velocities, ref.velocities[:frames])
    res = run_scene(Scene.from_text(text, name=str(tmp_path / "s.toml")), out,
                    progress=False, resume=True, steps=steps)
    assert res.resumed_from <= int(part.steps[-1])
    _same(load_trajectory(res.trajectory), ref)
    assert not (out / LOCK_NAME).exists()


# -- solver honesty ----------------------------------------------------------------------

GELATIN_SMALL = """
[material]
preset = "gelatin"
model = "springs"          # the springs path with the implicit integrator
[body]
type = "box"
points = 125
distribution = "grid"
lower = [0.0, 0.02, 0.0]
upper = [0.1, 0.12, 0.1]
[springs]
connect = "radius"
radius = 0.036
[integrator]
name = "implicit"
steps = 5
"""


def _gelatin(**integrator):
    text = GELATIN_SMALL
    for k, v in integrator.items():
        text = text.replace("[integrator]\n", f"[integrator]\n{k} = {v}\n")
    return Scene.from_text(text, name="gel.toml")


def test_ten_times_the_preset_dt_is_caught_as_a_collapse():
    """The preset's dt x 10 flattens the cube in one implicit step: a SimulationError naming
    the extent, the accuracy estimate (no 'inf s') and the fix; the preset's dt runs."""
    from jellysim.errors import SimulationError
    from jellysim.simulator import STATUS_COLLAPSE

    sim = _gelatin(dt=10.0 / 60.0).simulator()
    with pytest.raises(SimulationError) as info:
        sim.advance(1)
    msg = str(info.value)
    assert info.value.status == STATUS_COLLAPSE
    assert "thickness" in msg and "smaller dt" in msg
    assert "omega_max dt" in msg and "inf" not in msg
    ok = _gelatin().simulator()
    ok.advance(5)
    assert np.ptp(ok.state.x[:, 1]) > 0.05   # landed and squashed, not flattened


def test_unconverged_cg_warns_with_the_residual_and_fails_past_the_threshold():
    import warnings

    from jellysim.errors import SimulationError
    from jellysim.simulator import CG_ERROR_RESIDUAL, SolverWarning

    sim = _gelatin(cg_max_iterations=12).simulator()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        sim.advance(5)
    solver = [x for x in w if issubclass(x.category, SolverWarning)]
    assert len(solver) == 1 and "cg_max_iterations" in str(solver[0].message)
    assert 1e-3 < sim.cg_worst_residual < CG_ERROR_RESIDUAL
    assert f"{sim.cg_worst_residual:.3g}" in str(solver[0].message)
    with pytest.raises(SimulationError, match="cg_max_iterations"):
        _gelatin(cg_max_iterations=1).simulator().advance(1)
    quiet = _gelatin().simulator()          # the default iterations converge: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", SolverWarning)
        quiet.advance(5)
    assert quiet.cg_worst_residual <= 1e-3


def test_implicit_accuracy_estimate_matches_the_amplification_factor():
    """Backward Euler's |A| = 1/sqrt(1 + z^2); BDF2's principal root is closer to 1 than it
    for small z (second order); the message never says 'inf'."""
    from jellysim.stability import implicit_accuracy

    z, loss, words = implicit_accuracy(100.0, 0.01, theta=1.0)
    assert z == pytest.approx(1.0) and loss == pytest.approx(1 - 1 / np.sqrt(2))
    _, loss2, words2 = implicit_accuracy(100.0, 0.001, scheme="bdf2")
    _, loss1, _ = implicit_accuracy(100.0, 0.001, theta=1.0)
    assert 0 < loss2 < loss1 / 10
    assert "inf" not in words + words2 and "unconditionally stable" in words


def test_one_run_per_output_folder(tmp_path):
    """A run (or a resume) into a folder a live run is writing is refused before it touches
    anything there (it would delete the other's partial files and interleave frames); a lock
    left by a killed run (its process gone) is taken over; the lock goes when a run ends."""
    from jellysim.errors import OutputError
    from jellysim.io.lock import LOCK_NAME

    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    out = tmp_path / "out"
    out.mkdir()
    partial = out / "frames.partial"
    partial.write_text("the other run's")
    lock = out / LOCK_NAME
    lock.write_text(f"{os.getpid()} {__import__('socket').gethostname()}\n")  # alive: us
    with pytest.raises(OutputError, match=rf"another jellysim run \(process {os.getpid()}\)"):
        run_scene(scene, out, progress=False)
    assert partial.read_text() == "the other run's" and lock.exists()
    lock.write_text(f"{os.getpid()} elsewhere\n")  # another machine's: cannot be checked
    with pytest.raises(OutputError, match=rf"on elsewhere .*delete {lock}"):
        run_scene(scene, out, progress=False)
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    lock.write_text(f"{gone.pid} {__import__('socket').gethostname()}\n")  # a killed run's
    res = run_scene(scene, out, progress=False)
    assert res.steps == scene.steps and not lock.exists() and not partial.exists()


def test_a_folder_holding_only_a_killed_run_s_lock_is_free(tmp_path):
    """Sweep trial, session 30: a pool worker killed before writing anything left only its
    lock, and `jellysim run --out` there said "the folder is not empty (1 entries:
    .jellysim.lock); pass --overwrite".  A dead process's lock is not a run: the run goes
    ahead without --overwrite and takes the lock over."""
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.lock import LOCK_NAME

    scene = tmp_path / "scene.toml"
    scene.write_text(EXPLICIT)
    out = tmp_path / "out"
    out.mkdir()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    (out / LOCK_NAME).write_text(f"{gone.pid} {__import__('socket').gethostname()}\n")
    r = CliRunner().invoke(cli, ["run", str(scene), "--out", str(out), "--quiet"])
    assert r.exit_code == 0, r.output
    assert (out / "trajectory.npz").exists() and not (out / LOCK_NAME).exists()
    assert load_trajectory(out / "trajectory.npz").frame_count > 1


def test_python_run_into_an_earlier_run_is_refused_unless_overwrite(tmp_path):
    """``run_scene`` into a folder holding an earlier run: refused, nothing touched; with
    ``overwrite=True`` the earlier run's files go first (no stale frame survives, the
    ParaView series lists exactly the new frames) and the user's own files stay."""
    from jellysim.errors import OutputError

    sets = ("output.vtu=true", "output.every=10")
    long = Scene.from_text(EXPLICIT, overrides=sets + ("integrator.steps=60",))
    short = Scene.from_text(EXPLICIT, overrides=sets + ("integrator.steps=20",))
    out = tmp_path / "run"
    run_scene(long, out, progress=False)
    (out / "notes.txt").write_text("mine")
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    with pytest.raises(OutputError, match="earlier run.*overwrite=True"):
        run_scene(short, out, progress=False)
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    res = run_scene(short, out, progress=False, overwrite=True)
    frames = load_trajectory(res.trajectory).frame_count
    vtus = sorted(out.glob("body_*.vtu"))
    assert len(vtus) == frames < len([n for n in before if n.startswith("body_")])
    assert (out / "body.pvd").read_text().count("<DataSet") == frames
    assert (out / "notes.txt").read_text() == "mine"


def test_a_python_scene_stopped_early_says_how_to_continue_it_from_python(tmp_path):
    """Session 20's trial: a scene made in Python (no file) stopped by ``stop_after`` said
    "continue with: jellysim run '<scene>' --resume ...", a command that cannot work.  It now
    names the Python call, and that call finishes the run bitwise equal to one not stopped."""
    scene = Scene.from_text(EXPLICIT)
    with pytest.raises(RunInterrupted) as info:
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=2 * scene.frame_every)
    msg = str(info.value)
    assert "<scene>" not in msg
    assert f"continue with: run_scene(scene, {str(tmp_path / 'cut')!r}, resume=True)" in msg
    run_scene(scene, tmp_path / "cut", progress=False, resume=True)
    full = run_scene(scene, tmp_path / "full", progress=False)
    a, b = load_trajectory(tmp_path / "cut"), load_trajectory(full.trajectory)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.times, b.times)


def test_an_interrupted_run_in_a_folder_with_a_space_says_how_to_continue_it(tmp_path):
    """Session 10's trial: the printed "continue with" command broke on a folder with a space
    (not quoted), and running the same command again offered only --overwrite (which would
    delete the frames so far).  The command now parses back to the folder, and a new run into
    the folder says it holds an interrupted run and how to --resume it."""
    import shlex

    from jellysim.runner import prepare_out_dir

    scene = Scene.from_text(EXPLICIT, name="my scene.toml")
    out = tmp_path / "my run"
    with pytest.raises(RunInterrupted) as info:
        run_scene(scene, out, progress=False, stop_after=2 * scene.frame_every)
    msg = str(info.value)
    argv = shlex.split(msg[msg.index("continue with: ") + len("continue with: "):])
    assert argv[:5] == ["jellysim", "run", "my scene.toml", "--resume", str(out)]
    with pytest.raises(JellysimError, match=r"holds an interrupted run; continue it with "
                                            r"--resume '.*my run'"):
        prepare_out_dir(out)
    assert (out / CHECKPOINT).exists()   # nothing was touched


def test_extending_a_run_off_its_frame_schedule_repeats_the_longer_run(tmp_path):
    """The review of session 10: a run of 50 steps saving every 20 ends with an extra frame at
    step 50; extended to 100 it kept that frame ([0 20 40 50 60 80 100]).  Now the extension's
    frames are the 100-step run's ([0 20 40 60 80 100]), positions and velocities bitwise (its
    clock to round-off); a run without ParaView
    frames (--no-vtu) is extended without them; `--set integrator.steps=N` extends even when N
    is the scene file's own count (the first run was cut short by --steps)."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")         # every = 20, steps = 300
    ref = load_trajectory(run_scene(scene, tmp_path / "ref", progress=False, steps=100)
                          .trajectory)
    out = tmp_path / "run"
    run_scene(scene, out, progress=False, steps=50, vtu=False)
    assert load_trajectory(out).steps.tolist() == [0, 20, 40, 50]
    res = run_scene(scene, out, progress=False, steps=100, resume=True)
    assert res.resumed_from == 50
    got = load_trajectory(out)
    assert np.array_equal(got.steps, ref.steps)
    assert np.array_equal(got.positions, ref.positions)
    assert np.array_equal(got.velocities, ref.velocities)
    # (the clock adds dt x steps per call: 10 + 10 steps, not 20, round differently)
    np.testing.assert_allclose(got.times, ref.times, rtol=1e-14)
    assert not (out / "body.pvd").exists()                      # still no ParaView series
    again = Scene.from_text(EXPLICIT, name="scene.toml", overrides=("integrator.steps=300",))
    assert again.steps == scene.steps                            # the file's own count
    res = run_scene(again, out, progress=False, resume=True)
    assert res.resumed_from == 100 and load_trajectory(out).steps[-1] == 300


def test_a_timed_force_is_refused_when_it_would_never_act_and_a_new_force_keeps_its_own(
        tmp_path):
    """The review of session 10: `until` shorter than half a step rounds to step 0: the scene
    now names its [[handle]] and the nearest step (it said "not after t = 0" of a Python call);
    a force applied again on the same points is not released by the earlier `until`."""
    import jellysim as js

    text = ('[material]\npreset = "gelatin"\n[body]\npoints = 27\n[integrator]\nsteps = 4\n'
            '[[handle]]\nkind = "force"\nindices = [0]\nforce = [0.0, 1.0, 0.0]\n'
            'until = 0.001\n')
    scene = Scene.from_text(text, name="s.toml")
    with pytest.raises(SceneError, match=r"\[\[handle\]\] #1 until = 0.001 s falls on step 0"):
        scene.simulator(scene.build_model())
    model = js.physical_model(js.Body.box(points=27), js.material("gelatin"))
    sim = js.Simulator(model, dt=1 / 60)
    sim.apply_force([0, 1], [0.0, 1.0, 0.0], until=0.05)
    sim.apply_force([1], [0.0, 2.0, 0.0])                       # replaces point 1's, for good
    sim.advance(5)
    assert np.allclose(sim.handles.point_force[0], 0.0)         # released at step 3
    assert np.allclose(sim.handles.point_force[1], [0.0, 2.0, 0.0])


def test_a_checkpoint_from_before_the_extension_change_still_resumes(tmp_path):
    """Checkpoints hashed the scene's text and parameters before session 10 (now the
    parameters but the run's length); the review found such interrupted runs refused as
    "written for another scene".  The old hash is still accepted."""
    import numpy as np_

    from jellysim.io.checkpoint import _legacy_hash

    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    full = load_trajectory(run_scene(scene, tmp_path / "full", progress=False).trajectory)
    with pytest.raises(RunInterrupted):
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=2 * scene.frame_every)
    ck = tmp_path / "cut" / CHECKPOINT
    with np_.load(ck) as z:
        d = {k: z[k] for k in z.files}
    d["scene_sha256"] = np_.array(_legacy_hash(scene))
    np_.savez(ck, **d)
    res = run_scene(scene, tmp_path / "cut", progress=False, resume=True)
    assert np_.array_equal(load_trajectory(res.trajectory).positions, full.positions)


def test_a_resume_with_another_scene_names_what_differs(tmp_path):
    """Session 10's trial: resuming without the run's `--set body.points=...` said only
    "written for another scene"; it now names the key and both values."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml", overrides=("body.points=40",))
    with pytest.raises(RunInterrupted):
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=scene.frame_every)
    plain = Scene.from_text(EXPLICIT, name="scene.toml")
    with pytest.raises(CheckpointError, match=r"body\.points: 40 then, 60 now"):
        run_scene(plain, tmp_path / "cut", progress=False, resume=True)


def test_overwrite_never_deletes_a_live_run_or_a_run_for_a_scene_that_cannot_start(tmp_path):
    """Session 11's hostile trial: `run --overwrite` deleted the files of a run still going
    there (which then died with nothing left), and `run BAD.toml -o GOOD --overwrite` deleted
    the good run before the bad scene was refused (a handle holding no point, a body below
    the ground).  A live run's folder is now refused before anything is touched, naming its
    process, and an earlier run's files go only once the new run's body and simulator are
    made: every file stays, byte for byte, when the new run cannot start."""
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.lock import LOCK_NAME

    good = tmp_path / "good.toml"
    good.write_text(EXPLICIT.replace("steps = 300", "steps = 40").replace("vtu = false",
                                                                            "vtu = true"))
    out = tmp_path / "run"
    r = CliRunner().invoke(cli, ["run", str(good), "-o", str(out), "--quiet"])
    assert r.exit_code == 0, r.output
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert "trajectory.npz" in before and any(n.endswith(".vtu") for n in before)
    bad = tmp_path / "bad.toml"
    below = EXPLICIT.replace("lower = [0.0, 0.05, 0.0]", "lower = [0.0, -0.05, 0.0]")
    held = EXPLICIT + '[[handle]]\nkind = "gravity"\nscale = 0.0\nindices = [999]\n'
    huge = EXPLICIT.replace("steps = 300", "steps = 100000000000").replace("every = 20",
                                                                              "every = 1")
    for text in (below, held, huge):  # (huge: refused for the disk, after the build)
        bad.write_text(text)
        r = CliRunner().invoke(cli, ["run", str(bad), "-o", str(out), "--overwrite"])
        assert r.exit_code != 0
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before, r.output
    lock = out / LOCK_NAME  # a live run (this process) writing there
    lock.write_text(f"{os.getpid()} {__import__('socket').gethostname()}\n")
    r = CliRunner().invoke(cli, ["run", str(good), "-o", str(out), "--overwrite"])
    assert r.exit_code != 0 and f"another jellysim run (process {os.getpid()})" in r.output
    assert "interrupted" not in r.output
    lock.unlink()
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    r = CliRunner().invoke(cli, ["run", str(good), "-o", str(out), "--overwrite", "--quiet"])
    assert r.exit_code == 0, r.output  # (a scene that starts does replace it)


def test_a_resume_refuses_a_frame_stream_cut_short(tmp_path):
    """Session 11's hostile trial: a stream whose positions.npy lost its tail (a crash, a
    copy cut short) was accepted by --resume, which extended the file with zeros: 392 frames
    of the body at the origin, silently.  The resume now refuses it, naming the file and how
    many frames it holds, and leaves the folder as it was."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    out = tmp_path / "cut"
    with pytest.raises(RunInterrupted):
        run_scene(scene, out, progress=False, stop_after=scene.steps // 2)
    pos = out / STREAM_DIR / "positions.npy"
    size = pos.stat().st_size
    with open(pos, "r+b") as fh:
        fh.truncate(size - 3 * 60 * 3 * 8)  # three frames' data gone
    cut = pos.read_bytes()
    with pytest.raises(CheckpointError, match=r"positions.npy: is cut short: its data hold "
                                              r"\d+ of the \d+ frames the checkpoint needs"):
        run_scene(scene, out, progress=False, resume=True)
    assert pos.read_bytes() == cut and (out / CHECKPOINT).exists()


def test_a_full_disk_says_where_and_how_to_go_on(tmp_path, monkeypatch):
    """Session 11's hostile trial: a disk filling up mid-run printed only "No space left on
    device" and left the stream's status "running".  The error now names the file, the step
    and the fix (free space, fewer frames, then --resume), the status says it stopped, and
    the resumed run is bitwise the uninterrupted one."""
    import errno

    from jellysim.errors import OutputError
    from jellysim.io.vtk import PVDSeries

    scene = Scene.from_text(EXPLICIT.replace("vtu = false", "vtu = true"), name="scene.toml")
    ref = load_trajectory(run_scene(scene, tmp_path / "ref", progress=False).trajectory)
    real, calls = PVDSeries.add, [0]

    def add(self, *a, **k):
        calls[0] += 1
        if calls[0] == 6:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.pvd_path))
        return real(self, *a, **k)

    monkeypatch.setattr(PVDSeries, "add", add)
    out = tmp_path / "full"
    with pytest.raises(OutputError, match=r"No space left on device writing .*body.pvd at step "
                                          r"100 of 300: free space .*--resume"):
        run_scene(scene, out, progress=False, checkpoint_every=40)
    assert "stopped at step 100" in (out / STREAM_DIR / "status.txt").read_text()
    monkeypatch.setattr(PVDSeries, "add", real)
    _same(load_trajectory(run_scene(scene, out, progress=False, resume=True).trajectory), ref)

    def full(self, *a, **k):  # full at the first frame, before any checkpoint: start again
        raise OSError(errno.ENOSPC, "No space left on device", "body_00000.vtu")

    monkeypatch.setattr(PVDSeries, "add", full)
    with pytest.raises(OutputError, match=r"writing body_00000.vtu: free space .* then run it "
                                          r"again with --overwrite \(no checkpoint"):
        run_scene(scene, tmp_path / "first", progress=False, checkpoint_every=0)


def test_a_damaged_checkpoint_or_finished_trajectory_is_refused_by_name(tmp_path):
    """Session 11's verification trial: a checkpoint cut short (a copy, a crash) made
    `--resume` raise zipfile's BadZipFile from inside; extending a finished run whose
    trajectory.npz was cut short did too and left a half-reopened stream; a finished run
    whose trajectory.npz was deleted blamed the stream.  Each is a CheckpointError naming the
    file and the fix, and the folder is left as it was."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    cut = tmp_path / "cut"
    with pytest.raises(RunInterrupted):
        run_scene(scene, cut, progress=False, stop_after=scene.steps // 2)
    ck = cut / CHECKPOINT
    ck.write_bytes(ck.read_bytes()[: ck.stat().st_size // 2])
    with pytest.raises(CheckpointError, match=r"checkpoint.npz: damaged checkpoint .*cut short"
                                              r".*with --overwrite"):
        run_scene(scene, cut, progress=False, resume=True)
    done = tmp_path / "done"
    run_scene(scene, done, progress=False)
    npz = done / "trajectory.npz"
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    before = sorted(p.name for p in done.iterdir())
    with pytest.raises(CheckpointError, match=r"trajectory.npz: damaged .*cannot be extended"):
        run_scene(scene, done, progress=False, resume=True, steps=2 * scene.steps)
    assert sorted(p.name for p in done.iterdir()) == before  # (no half-reopened stream left)
    npz.unlink()
    with pytest.raises(CheckpointError, match=r"the run's frames are gone \(no trajectory.npz"):
        run_scene(scene, done, progress=False, resume=True, steps=2 * scene.steps)


@pytest.mark.parametrize("physical", [False, True], ids=["springs", "physical"])
def test_a_run_resumes_on_another_thread_count_and_its_command_keeps_the_flags(tmp_path,
                                                                              physical):
    """Session 13's hostile trial: a run stopped with ``--threads 2`` printed "continue with:
    jellysim run s.toml --resume ..." and following it was refused ("integrator.threads: 2
    then, None now"), though the results are bitwise the same for any thread count;
    ``--precision`` was dropped from the command likewise.  A run stopped on 1 thread now
    resumes on 2 (and back), bitwise the uninterrupted run, and the printed command carries
    the backend options given (as --set items)."""
    text = (('[material]\npreset = "gelatin"\n[body]\npoints = 125\nlower = [0, 0.01, 0]\n'
             'upper = [0.05, 0.06, 0.05]\n[integrator]\ndt = 0.016666666666666666\n'
             'steps = 24\n{threads}[output]\nevery = 4\nvtu = false\n') if physical else
            EXPLICIT.replace("[integrator]\n", "[integrator]\n{threads}"))
    scene = lambda t: Scene.from_text(text.format(threads=t), name="s.toml")  # noqa: E731
    ref = load_trajectory(run_scene(scene("threads = 1\n"), tmp_path / "ref",
                                    progress=False).trajectory)
    for first, later in (("threads = 1\n", "threads = 2\n"), ("threads = 2\n", "")):
        cut = tmp_path / f"cut{len(later)}"
        with pytest.raises(RunInterrupted):
            run_scene(scene(first), cut, progress=False, stop_after=2 * ref.frame_count // 3
                      * scene(first).frame_every // 2)
        res = run_scene(scene(later), cut, progress=False, resume=True)
        _same(load_trajectory(res.trajectory), ref)
    if not physical:
        path = tmp_path / "s.toml"
        path.write_text(text.format(threads=""))
        numpy = Scene.load(path).with_backend("numpy")
        with pytest.raises(RunInterrupted) as info:
            run_scene(numpy, tmp_path / "np", progress=False, stop_after=4)
        assert "--set integrator.backend=numpy" in str(info.value)
        with pytest.raises(CheckpointError, match=r"integrator\.backend: 'numpy' then, 'numba' "
                                                  r"now.* --backend / --device / --precision"):
            run_scene(Scene.load(path), tmp_path / "np", progress=False, resume=True)


def test_ctrl_c_while_trimesh_is_imported_stops_the_mesh_load_and_leaves_trimesh_whole(
        tmp_path):
    """trimesh wraps the exceptions of its own imports, KeyboardInterrupt included, in place of
    the module: a new user's Ctrl-C during a mesh scene's start was swallowed (the run went on
    to the end) or broke trimesh (``ExceptionWrapper`` TypeError deep in it).  Here SIGINT is
    sent when ``trimesh.grouping`` (one of those imports) starts: ``load_mesh`` must raise
    KeyboardInterrupt once the import is done, and the next load must read the mesh whole."""
    probe = tmp_path / "probe.py"
    probe.write_text(
        "import os, signal, sys\n"
        # (a live Ctrl-C, as in a terminal: a parent that ignores SIGINT, as a test worker
        # may, passes SIG_IGN on, and then the noted signal is rightly ignored)
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "def hook(event, args):\n"
        "    if event == 'import' and args[0] == 'trimesh.grouping':\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "sys.addaudithook(hook)\n"
        "from jellysim.geometry.mesh import load_mesh\n"
        f"path = {str(DATA / 'sphere.obj')!r}\n"
        "try:\n"
        "    load_mesh(path)\n"
        "    print('not interrupted')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted')\n"
        "m = load_mesh(path)\n"
        "print(len(m.vertices), len(m.faces))\n"
        "import trimesh.grouping\n"
        "print(type(trimesh.grouping).__name__)\n")
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parents[1] / "src"))
    out = subprocess.run([sys.executable, str(probe)], capture_output=True, text=True,
                         timeout=120, env=env)
    lines = out.stdout.split()
    assert out.returncode == 0, out.stderr
    assert lines[0] == "interrupted", out.stdout + out.stderr
    faces = sum(1 for ln in (DATA / "sphere.obj").read_text().splitlines()
                if ln.startswith("f "))
    assert int(lines[2]) == faces and lines[3] == "module"


@pytest.mark.parametrize("module", ["numpy", "click", "jellysim.cli"])
def test_ctrl_c_while_the_command_is_still_loading_says_so_without_a_traceback(
        tmp_path, module):
    """A Ctrl-C in the command's first ~0.4 s (before ``jellysim.cli`` has loaded, so before
    the command's own interrupt handling exists) printed a KeyboardInterrupt traceback from
    inside an import.  The ``jellysim`` script's entry point (``_jellysim_launch.main``) must
    answer it with one line and exit status 130, and write nothing.  SIGINT is sent from an
    audit hook as ``module`` starts to import, then the real entry point runs; the same probe
    without the signal must run the command (``jellysim --version``)."""
    src = Path(__file__).parents[1] / "src"
    out_dir = tmp_path / "out"
    probe = tmp_path / "probe.py"
    probe.write_text(
        "import os, signal, sys\n"
        "sent = []\n"
        "def hook(event, args):\n"
        f"    if event == 'import' and args[0] == {module!r} and not sent and "
        "os.environ.get('SEND'):\n"
        "        sent.append(1)\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "sys.addaudithook(hook)\n"
        "import _jellysim_launch\n"
        f"sys.argv = ['jellysim', *sys.argv[1:]]\n"
        "_jellysim_launch.main()\n")
    env = dict(os.environ, PYTHONPATH=str(src), SEND="1")
    args = [sys.executable, str(probe), "build", "--out-of-nowhere", str(out_dir)]
    out = subprocess.run(args, capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 130, out.stderr
    assert "Traceback" not in out.stderr and "KeyboardInterrupt" not in out.stderr, out.stderr
    assert out.stderr.strip() == ("interrupted while jellysim was starting: nothing was read "
                                  "or written"), out.stderr
    assert not out_dir.exists()
    env.pop("SEND")
    ok = subprocess.run([sys.executable, str(probe), "--version"], capture_output=True,
                        text=True, timeout=120, env=env)
    assert ok.returncode == 0 and "0.1.0" in ok.stdout, ok.stdout + ok.stderr


def _poison(sim):
    """Overwrite every array :attr:`Simulator._SCRATCH` names (NaN, or 3 for integers)."""
    arrays = []
    for key in sim._SCRATCH:
        name, _, i = key.partition(".")
        value = getattr(sim, name, None)
        if value is None:
            continue
        value = value[int(i)] if i else value
        arrays += [value] if isinstance(value, np.ndarray) else list(value)
    for a in arrays:
        a.fill(np.nan if a.dtype.kind == "f" else 3)
    return len(arrays)


_SPHERE = '\n[[obstacle]]\nkind = "sphere"\ncenter = [0.15, -0.05, 0.15]\nradius = 0.08\n'


@pytest.mark.parametrize("text, overrides", [
    (EXPLICIT + _SPHERE, ()),                                       # symplectic, contact
    (EXPLICIT, ('integrator.precision="float32"',)),
    ((Path(__file__).parents[1] / "examples" / "paper_cube.toml").read_text(),
     ("body.points=150", "provot.order=\"jacobi\"", "provot.velocity_update=true")),
    ((Path(__file__).parents[1] / "examples" / "paper_cube.toml").read_text(),
     ("body.points=150",)),                                         # the report's Gauss-Seidel
    (IMPLICIT, ()),                                                 # BDF2, contact
    (IMPLICIT, ('integrator.scheme="theta"',)),
    ((Path(__file__).parents[1] / "examples" / "gelatin_cube.toml").read_text() + _SPHERE,
     ("body.points=125", "integrator.steps=40")),                   # physical (tets)
], ids=["symplectic", "float32", "jacobi", "gauss-seidel", "bdf2", "theta", "physical"])
def test_scratch_carries_nothing_between_advance_calls(text, overrides):
    """What a checkpoint leaves out (Simulator._SCRATCH: per-spring and per-tet buffers) is
    written before it is read by every step: a simulator resumed from another's state and
    internal_state, all its scratch overwritten with NaN first, ends bitwise equal to it; and
    the checkpointed arrays are no larger than a few times the state."""
    scene = Scene.from_text(text, name="scene.toml", overrides=overrides)
    model = scene.build_model()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = scene.simulator(model)
        a.advance(6)
        state, inner = a.state.copy(), a.internal_state()
        assert not set(inner) & a._SCRATCH
        a.advance(6)
        b = scene.simulator(model)
        assert _poison(b) >= 3
        b.state.assign(state)
        b.restore_internal_state(inner)
        b.advance(6)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    # springs outnumber points 5-30x: the checkpoint holds no per-spring array
    kept = sum(v.nbytes for v in inner.values())
    tets = 0 if model.fem is None else model.fem.tet_count
    assert kept <= 20 * state.x.nbytes + 48 * tets + 1024


def test_a_resume_without_vtu_frames_says_the_paraview_series_stops(tmp_path):
    """A new user resumed a run that wrote .vtu frames with --no-vtu: body.pvd listed 65 frames
    and trajectory.npz 151, unsaid.  Now the resume says where the series ends; without
    --no-vtu the series goes on to the last frame."""
    import re

    scene = Scene.from_text(EXPLICIT.replace("vtu = false", "vtu = true"), name="scene.toml")
    for name, vtu in (("cut", False), ("whole", None)):
        with pytest.raises(RunInterrupted):
            run_scene(scene, tmp_path / name, progress=False, stop_after=100)
        told = []
        res = run_scene(scene, tmp_path / name, progress=False, resume=True, vtu=vtu,
                        notify=told.append)
        listed = len(re.findall(r"<DataSet ", (tmp_path / name / "body.pvd").read_text()))
        frames = load_trajectory(res.trajectory).frame_count
        if vtu is False:
            assert listed < frames and any("body.pvd ends at t = 0.1 s" in m for m in told)
        else:
            assert listed == frames and not any("body.pvd" in m for m in told)


def test_a_run_resumes_from_its_folder_alone(tmp_path, monkeypatch):
    """A new user's `jellysim run --resume out/cube2` failed with "Missing argument
    'SCENE_FILE'".  The checkpoint records the scene's resolved parameters and its file's
    path, so `jellysim run --resume DIR` continues the run from another directory, with the
    mesh the scene names by a relative path, bitwise as the uninterrupted run; a folder that
    does not exist, or no scene and no --resume, get one line saying what to give."""
    import shutil

    from click.testing import CliRunner

    from jellysim.cli import cli

    home = tmp_path / "scenes"
    home.mkdir()
    shutil.copy(DATA / "torus.obj", home / "ring.obj")
    (home / "ring.toml").write_text(
        '[material]\npreset = "gelatin"\n[body]\ntype = "mesh"\npath = "ring.obj"\n'
        'points = 300\nsize = 0.06\nbase = [0.0, 0.01, 0.0]\n'
        '[integrator]\nsteps = 24\n[output]\nevery = 4\nvtu = false\n')
    monkeypatch.chdir(home)
    whole = run_scene(Scene.load("ring.toml", overrides=("integrator.steps=40",)),
                      tmp_path / "whole", progress=False)
    with pytest.raises(RunInterrupted, match=r"continue with: jellysim run ring.toml"):
        run_scene(Scene.load("ring.toml", overrides=("integrator.steps=40",)),
                  tmp_path / "cut", progress=False, stop_after=12)
    monkeypatch.chdir(tmp_path)                                 # elsewhere: ring.obj is not here
    runner = CliRunner()
    res = runner.invoke(cli, ["run", "--resume", "cut", "--quiet"])
    assert res.exit_code == 0, res.output
    assert "resumed from the checkpoint at step 12" in res.output
    _same(load_trajectory(tmp_path / "cut"), load_trajectory(whole.trajectory))
    res = runner.invoke(cli, ["run", "--resume", "cut", "--steps", "48", "--quiet"])
    assert res.exit_code == 0 and load_trajectory(tmp_path / "cut").steps[-1] == 48
    res = runner.invoke(cli, ["run", "--resume", "nothing_here"])
    assert res.exit_code == 2 and "no such folder" in res.output
    res = runner.invoke(cli, ["run"])
    assert res.exit_code == 2 and "give a scene" in res.output and "--resume DIR" in res.output


def test_an_extension_killed_before_its_first_checkpoint_resumes_to_its_own_length(tmp_path):
    """The reliability trial: a finished 900-step run extended to 1800 steps and killed
    (SIGKILL) before the extension wrote a checkpoint, then `--resume` without --steps, was
    "resumed" to the first run's 900 steps from its final state: the 402 frames past it that
    render, plot and export had shown were deleted unsaid.  The extension records its length
    in its stream when it starts: a plain resume finishes it (bitwise the longer run).  A
    damaged stream is said before the resume takes a step (it failed with a traceback after
    simulating everything)."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    n = scene.steps
    ref = load_trajectory(run_scene(scene, tmp_path / "full", progress=False,
                                    steps=3 * n).trajectory)
    out = tmp_path / "run"
    run_scene(scene, out, progress=False)
    with pytest.raises(RunInterrupted):
        run_scene(scene, out, progress=False, resume=True, steps=3 * n, stop_after=2 * n)
    (out / CHECKPOINT).unlink()  # (as a SIGKILL before the extension's first checkpoint)
    (out / STREAM_DIR / "status.txt").unlink(missing_ok=True)  # (killed: still "running")
    assert load_trajectory(out).frame_count > n // scene.frame_every + 1
    res = run_scene(scene, out, progress=False, resume=True)
    traj = load_trajectory(res.trajectory)
    assert traj.steps[-1] == 3 * n and traj.status == "complete"
    _same(traj, ref)
    with pytest.raises(RunInterrupted):
        run_scene(scene, tmp_path / "cut", progress=False, stop_after=n // 2)
    (tmp_path / "cut" / STREAM_DIR / "meta.npz").write_text("garbage")
    with pytest.raises(CheckpointError, match=r"meta\.npz: damaged .*--overwrite"):
        run_scene(scene, tmp_path / "cut", progress=False, resume=True)
    # without its meta.npz the stream was said to be absent ("holds no trajectory.stream")
    (tmp_path / "cut" / STREAM_DIR / "meta.npz").unlink()
    from jellysim.errors import JellysimError

    with pytest.raises(JellysimError, match=r"trajectory\.stream: damaged: its meta\.npz is "
                                            r"missing"):
        load_trajectory(tmp_path / "cut")


def test_a_disk_full_while_copying_the_frames_resumes_by_copying_them(tmp_path, monkeypatch):
    """The reliability trial: the disk filled while a finished run's frames were copied into
    trajectory.npz.  The 93 MB ``.partial`` was left on the full disk, and the resume, once
    space was freed, was refused for the room its own frames already took ("needs about 0.214
    GiB, 0.184 free" with 0.11 more needed), then simulated the whole run again from its
    first checkpoint.  Now the partial copy goes, the error says how to go on, the resume
    counts only the room still needed and takes no step: it copies the frames (bitwise the
    uninterrupted run)."""
    import errno

    import jellysim.runner as runner
    from jellysim.errors import OutputError
    from jellysim.run_disk import _check_disk

    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    ref = load_trajectory(run_scene(scene, tmp_path / "ref", progress=False).trajectory)
    real = runner.finalize_stream

    def full(directory, npz_path, status):
        npz_path.with_name(npz_path.name + ".partial").write_bytes(b"x" * 1000)
        raise OSError(errno.ENOSPC, "No space left on device", str(npz_path) + ".partial")

    monkeypatch.setattr(runner, "finalize_stream", full)
    out = tmp_path / "full"
    with pytest.raises(OutputError, match=r"No space left on device .*all 300 steps done, "
                                          r"copying the frames.*free space.*--resume"):
        run_scene(scene, out, progress=False, checkpoint_every=40)
    assert not list(out.glob("*.partial")) and not (out / CHECKPOINT).exists()
    monkeypatch.setattr(runner, "finalize_stream", real)
    res = run_scene(scene, out, progress=False, resume=True)
    assert res.resumed_from == scene.steps          # nothing simulated again
    _same(load_trajectory(res.trajectory), ref)
    # the room a resume needs: what its stream does not hold yet, and the .npz copy
    frames = scene.steps // scene.frame_every + 1
    free = __import__("shutil").disk_usage(tmp_path).free
    points = int(1.5 * free / (2 * frames * 48))   # stream + copy: 1.5x the free space
    with pytest.raises(Exception, match="needs about"):
        _check_disk(tmp_path, scene.steps, scene.frame_every, points, [])
    _check_disk(tmp_path, scene.steps, scene.frame_every, points, [], have=frames)  # (0.75x)


def test_a_run_still_going_is_said_to_be_running_not_killed(tmp_path):
    """The reliability trial: `inspect` of a run still being written said "incomplete: the
    run stopped without finishing (killed, or its disk full?)".  A stream whose folder a live
    process holds is "running: process N is writing it"; once that process is gone (a killed
    run's lock) it is incomplete, as before."""
    import os
    import socket

    from jellysim.io.lock import LOCK_NAME

    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    out = tmp_path / "run"
    with pytest.raises(RunInterrupted):
        run_scene(scene, out, progress=False, stop_after=scene.steps // 2)
    (out / STREAM_DIR / "status.txt").write_text("running")
    host = socket.gethostname()
    (out / LOCK_NAME).write_text(f"{os.getpid()} {host}")
    traj = load_trajectory(out)
    assert traj.status.startswith(f"running: process {os.getpid()} is writing it (")
    dead = 2 ** 22 + 12345                      # (beyond Linux's pid range: no such process)
    (out / LOCK_NAME).write_text(f"{dead} {host}")
    assert load_trajectory(out).status.startswith("incomplete: the run stopped without")
    # a run still building its body has no frame yet: said so, not "not a run's folder"
    starting = tmp_path / "starting"
    starting.mkdir()
    (starting / LOCK_NAME).write_text(f"{os.getpid()} {host}")
    from jellysim.errors import JellysimError

    with pytest.raises(JellysimError, match=rf"a run \(process {os.getpid()}\) is starting "
                                            r"here and has written no frame yet"):
        load_trajectory(starting)
    # a run killed under mpiexec leaves only its ParaView frames (the HPC trial: "not a run's
    # folder"): said so, with what can open them
    (starting / LOCK_NAME).unlink()
    (starting / "body.pvd").write_text("<VTKFile/>")
    with pytest.raises(JellysimError, match=r"holds ParaView frames \(body\.pvd\) but no "
                                            r"trajectory"):
        load_trajectory(starting)


def test_a_resume_asked_fewer_steps_than_its_frames_says_what_it_drops(tmp_path):
    """The re-trial: after a killed extension with 220 frames on disk, `--resume --steps 170`
    threw away the 49 computed frames past step 170 without a word.  It still ends where it
    is asked (bitwise the shorter run), and says how many frames are dropped."""
    scene = Scene.from_text(EXPLICIT, name="scene.toml")
    n, every = scene.steps, scene.frame_every
    out = tmp_path / "run"
    run_scene(scene, out, progress=False)
    with pytest.raises(RunInterrupted):
        run_scene(scene, out, progress=False, resume=True, steps=3 * n, stop_after=2 * n)
    (out / CHECKPOINT).unlink()
    have = load_trajectory(out).frame_count
    with pytest.warns(UserWarning, match=rf"{have} frames are on disk and {n + every} steps "
                                         rf"asked end before the last of them"):
        res = run_scene(scene, out, progress=False, resume=True, steps=n + every)
    ref = load_trajectory(run_scene(scene, tmp_path / "ref", progress=False,
                                    steps=n + every).trajectory)
    _same(load_trajectory(res.trajectory), ref)


def test_a_runs_paraview_frames_are_bounded_and_large_ones_are_said(tmp_path):
    """Scale trial (session 28): a 10,948-point gelatin body's 181 .vtu frames took 1.1 GB
    (9-10 GB at 100k points) with nothing said, and the bound used for a full disk left out
    the tets' stress fields (3.8 MB a frame where 5.8 MB were written).  A physical run's
    frames now stay under the bound, and frames that will exceed 1 GiB are said, with
    --no-vtu, before the run starts."""
    from jellysim.run_disk import LARGE_TRAJECTORY_BYTES, _check_disk, _vtu_frame_bound

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 343\n'
            'lower = [0.0, 0.01, 0.0]\nupper = [0.04, 0.05, 0.04]\n[integrator]\nsteps = 4\n'
            '[output]\nevery = 2\nvtu = true\n')
    scene = Scene.from_text(text, name="s.toml")
    run_scene(scene, tmp_path / "run", progress=False)
    model = scene.build_model()
    bound = _vtu_frame_bound(model, None)
    sizes = [p.stat().st_size for p in (tmp_path / "run").glob("body_*.vtu")]
    assert len(sizes) == 3 and max(sizes) < bound
    messages = []
    frames = LARGE_TRAJECTORY_BYTES // bound + 10  # just over 1 GiB of frames
    _check_disk(tmp_path, int(frames) - 1, 1, model.point_count, messages, frame_bytes=bound)
    said = [m for m in messages if "ParaView frames (.vtu" in m]
    assert len(said) == 1 and "--no-vtu writes none" in said[0]
    messages.clear()
    _check_disk(tmp_path, 100, 1, model.point_count, messages, frame_bytes=bound)
    assert not messages
