"""A handles user's trial (session 31): what a handle cannot do as asked is said when it is
given, handles show in a run's frames, and a shake is one call.

The trial pinned a cube's top face and moved it into a sphere obstacle: the contact held the
points on the sphere's surface, 18 mm from their path, without a word (the ground said so);
a path typed in millimetres and a force far beyond the body's weight were taken in silence and
blew the run up with advice about substeps; pins and forces were invisible in the .vtu frames;
a sinusoidal shake took 120-240 hand-written keyframes a second.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import jellysim
from jellysim.errors import SceneError, SimulationError
from jellysim.handles import PinPath, select_points

CENTER = np.array([0.01, 0.10, 0.01])
RADIUS = 0.02


def _cube(**kw):
    """A 2 cm gelatin cube held 5 cm above the ground by its pinned top face (y = 0.07 m)."""
    body = jellysim.Body.box((0, 0.05, 0), (0.02, 0.07, 0.02), points=64)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    sim = jellysim.Simulator(model, dt=1 / 60, **kw)
    top = np.flatnonzero(body.points[:, 1] > 0.07 - 1e-9)
    return sim, top


def test_a_pin_path_into_an_obstacle_is_said_and_the_obstacle_wins_as_said():
    """The top face lifted 2 cm into a sphere whose lowest point is 1 cm above it: the deepest
    pinned point would end 1 cm inside (the face's centre, on the sphere's axis).  The
    warning names the obstacle and that depth; run on, every pinned point ends on or outside
    the sphere's surface (the contact wins, as the warning says), the face's centre on the
    sphere's lowest point, 1 cm short of its path's end.  The same lift beside the sphere says
    nothing."""
    sphere = jellysim.Sphere(center=tuple(CENTER), radius=RADIUS)
    sim, top = _cube(obstacles=[sphere])
    with pytest.warns(UserWarning, match=r"pin: the path takes pinned points 0\.01 m into "
                                         r"obstacle #1 \(a sphere\).*the obstacle wins"):
        sim.pin(top, path=[[0.5, 0.0, 0.02, 0.0]])
    start = sim.state.x[top].copy()
    sim.advance(60)
    dist = np.linalg.norm(sim.state.x[top] - CENTER, axis=1)
    assert dist.min() >= RADIUS * (1 - 1e-3)
    mid = int(np.argmin(np.linalg.norm(start[:, [0, 2]] - CENTER[[0, 2]], axis=1)))
    assert np.linalg.norm(start[mid, [0, 2]] - CENTER[[0, 2]]) < 1e-9  # (on the axis)
    assert abs(dist[mid] - RADIUS) < 1e-3 * RADIUS
    assert abs((start[mid, 1] + 0.02) - sim.state.x[top][mid, 1] - 0.01) < 1e-4
    beside = jellysim.Sphere(center=(0.2, 0.10, 0.01), radius=RADIUS)
    sim, top = _cube(obstacles=[beside])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.pin(top, path=[[0.5, 0.0, 0.02, 0.0]])


def test_a_path_through_an_obstacle_between_keyframes_is_said():
    """The path is straight between keyframes: one that passes through the sphere from a
    keyframe below it to one beside it (both outside) is still said."""
    sphere = jellysim.Sphere(center=tuple(CENTER), radius=RADIUS)
    sim, top = _cube(obstacles=[sphere])
    with pytest.warns(UserWarning, match=r"into obstacle #1"):
        sim.pin(top, path=[[0.5, -0.05, 0.03, 0.0], [1.0, 0.05, 0.03, 0.0]])


def test_millimetres_and_a_crushing_force_are_said_as_likely_slips_of_units():
    """A path of 50 'm' on a 2 cm body (2,500 times its size) and a force of 100 N on a
    9 g body (over 1,000 g) are said as likely slips of units; 1.5 m (75 sizes) and 1 N
    (11 g) are not."""
    sim, top = _cube()
    mass = float(np.sum(sim.model.point_mass))
    assert mass == pytest.approx(1141 * 0.02**3, rel=1e-6)
    with pytest.warns(UserWarning, match=r"pin: the path moves the pinned points up to 50 m, "
                                         r"2500 times the body's size.*likely a slip of units"):
        sim.pin(top, path=[[0.5, 0.0, 50.0, 0.0]])
    with pytest.warns(UserWarning, match=r"apply_force: 100 N would accelerate the whole body "
                                         r"\(0\.009128 kg\) at \d+ g: likely a slip of units"):
        sim.apply_force([0], [0.0, 100.0, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.pin(top, path=[[0.5, 0.0, 1.5, 0.0]])
        sim.apply_force([0], [0.0, 1.0, 0.0])
    sim.apply_force([0], [0.0, 1e7, 0.0])
    with pytest.raises(SimulationError, match=r"check the handles first \(a pin path's offsets "
                                              r"are metres, forces newtons"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sim.advance(3)


def test_bad_rows_and_indices_are_named():
    """A path's non-finite number names its row; an index out of range names the index."""
    with pytest.raises(SceneError, match=r"every number must be finite; row 2 is "
                                         r"\[0\.2, nan, 0\.0, 0\.0\]"):
        PinPath.of([[0.1, 0.0, 0.0, 0.0], [0.2, float("nan"), 0.0, 0.0]])
    pts = np.zeros((10, 3))
    with pytest.raises(SceneError, match=r"index 12 is out of range: indices must lie in "
                                         r"\[0, 9\] \(the body has 10 points\)"):
        select_points(pts, indices=[1, 12])
    with pytest.raises(SceneError, match=r"index -1 is out of range"):
        select_points(pts, indices=[-1, 2])


def test_move_pinned_replaces_the_path_as_documented():
    """``move_pinned`` drops the rest of the path the points followed (its docstring says
    so): after it, the earlier path's later keyframe no longer moves them."""
    sim, top = _cube()
    sim.pin(top, path=[[1.0, 0.0, 0.02, 0.0]])
    sim.advance(6)
    sim.move_pinned(top, [0.01, 0.0, 0.0])
    held = sim.state.x[top].copy()
    sim.advance(1)
    moved = sim.state.x[top] - held
    np.testing.assert_allclose(moved, np.tile([0.01, 0.0, 0.0], (len(top), 1)), atol=1e-12)
    after = sim.state.x[top].copy()
    sim.advance(60)
    np.testing.assert_allclose(sim.state.x[top], after, atol=1e-12)
    assert "replaces the path" in jellysim.Simulator.move_pinned.__doc__


def test_a_runs_handles_are_fields_of_its_paraview_frames(tmp_path):
    """Handles trial: pins and forces were invisible in a run's outputs.  Each ``.vtu`` frame
    of a run with handles carries ``pinned`` (1 on exactly the points the pin's box selects),
    ``point_force`` [N] (summing to the handle's force, on its points only) and
    ``gravity_scale``; the frames stay under the full-disk bound."""
    import meshio

    from jellysim.run_disk import _vtu_frame_bound
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 125\n'
            'lower = [0.0, 0.01, 0.0]\nupper = [0.04, 0.05, 0.04]\n[integrator]\nsteps = 4\n'
            '[output]\nevery = 2\nvtu = true\n'
            '[[handle]]\nkind = "pin"\nbox = [[-1, 0.049, -1], [1, 1, 1]]\n'
            '[[handle]]\nkind = "force"\nindices = [0, 1]\nforce = [0.0, 0.0, 0.03]\n')
    scene = Scene.from_text(text, name="h.toml")
    run_scene(scene, tmp_path / "run", progress=False)
    x0 = scene.build_model().point_x0
    top = np.flatnonzero(x0[:, 1] >= 0.049)
    frames = sorted((tmp_path / "run").glob("body_*.vtu"))
    assert len(frames) == 3
    for path in frames:
        data = meshio.read(path).point_data
        np.testing.assert_array_equal(np.flatnonzero(data["pinned"]), top)
        force = data["point_force"]
        np.testing.assert_allclose(force[[0, 1]].sum(axis=0), [0.0, 0.0, 0.03], rtol=1e-12)
        assert not force[2:].any() and np.all(data["gravity_scale"] == 1.0)
        assert path.stat().st_size < _vtu_frame_bound(scene.build_model(), None)


def test_shake_path_is_the_sine_it_says():
    """``shake_path``: rows at start + j seconds / count, j = 0..count, count = ceil(seconds f
    per_period), offsets exactly ``A sin(2 pi f (t - start))`` (0 at ``start`` itself)."""
    rows = jellysim.shake_path((0.004, 0.0, -0.002), 2.5, seconds=1.0, start=0.3)
    assert rows.shape == (81, 4)
    t = 0.3 + np.arange(0, 81) / 80
    np.testing.assert_allclose(rows[:, 0], t, rtol=0, atol=1e-15)
    s = np.sin(2 * np.pi * 2.5 * (t - 0.3))
    np.testing.assert_allclose(rows[:, 1:], np.outer(s, [0.004, 0.0, -0.002]), atol=1e-15)
    assert not rows[0, 1:].any()
    for bad, said in ((dict(amplitude=(1, 2)), "amplitude must be 3 numbers"),
                      (dict(frequency=0.0), "frequency must be a number > 0"),
                      (dict(seconds=-1.0), "seconds must be a time > 0"),
                      (dict(per_period=2), "per_period must be a whole number >= 4")):
        kw = dict(amplitude=(0.01, 0, 0), frequency=1.0, seconds=1.0) | bad
        with pytest.raises(SceneError, match=said):
            jellysim.shake_path(kw.pop("amplitude"), kw.pop("frequency"), **kw)


def test_a_shaken_base_follows_its_sine_and_the_jelly_answers_at_the_drive():
    """A gelatin cube resting on its pinned base, shaken sideways at 7 Hz (32 keyframes a
    period): at every frame the base is where the path's straight segments put it (1e-12 m),
    and the top's sideways motion over the last second has its largest Fourier component at
    the drive frequency (the free sway, 12 Hz for this cube, has decayed 8-fold by then)."""
    body = jellysim.Body.box((0, 0, 0), (0.03, 0.03, 0.03), points=125)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    sim = jellysim.Simulator(model, dt=1 / 120)
    base = np.flatnonzero(body.points[:, 1] < 1e-9)
    top = np.flatnonzero(body.points[:, 1] > 0.03 - 1e-9)
    rows = jellysim.shake_path((0.002, 0.0, 0.0), 7.0, seconds=3.0)
    sim.pin(base, path=rows)
    start = sim.state.x[base].copy()
    times, offs = rows[:, 0], rows[:, 1]
    tops = []
    for _ in range(360):
        sim.advance(1)
        want = np.interp(sim.state.t, times, offs)
        np.testing.assert_allclose(sim.state.x[base, 0] - start[:, 0], want, atol=1e-12)
        tops.append(sim.state.x[top, 0].mean())
    last = np.asarray(tops[-120:]) - np.mean(tops[-120:])
    spectrum = np.abs(np.fft.rfft(last))
    freqs = np.fft.rfftfreq(120, 1 / 120)
    assert freqs[np.argmax(spectrum)] == pytest.approx(7.0, abs=1.0)


def test_a_scenes_shake_table_is_the_same_run_as_its_path(tmp_path):
    """``[[handle]] shake = {...}`` runs bitwise as the same keyframes given as ``path``, in a
    simulator and in a run (whose saved scene keeps the table as written); a table with both,
    an unknown key or a missing one is refused by name."""
    from jellysim.io.trajectory import load_trajectory
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    base = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 64\n'
            'lower = [0.0, 0.0, 0.0]\nupper = [0.02, 0.02, 0.02]\n[integrator]\nsteps = 30\n'
            '[[handle]]\nkind = "pin"\nbox = [[-1, -1, -1], [1, 0.001, 1]]\n')
    shake = 'shake = {amplitude = [0.002, 0, 0], frequency = 4.0, seconds = 0.5}\n'
    rows = jellysim.shake_path((0.002, 0, 0), 4.0, seconds=0.5)
    path = "path = [" + ", ".join("[" + ", ".join(repr(float(v)) for v in r) + "]"
                                  for r in rows) + "]\n"
    runs = []
    for extra in (shake, path):
        sim = Scene.from_text(base + extra, name="s.toml").simulator()
        sim.advance(30)
        runs.append(sim.state.x.copy())
    assert np.array_equal(runs[0], runs[1])
    res = run_scene(Scene.from_text(base + shake, name="s.toml"), tmp_path / "run",
                    progress=False)
    assert np.array_equal(load_trajectory(res.trajectory).positions[-1], runs[0])
    for extra, said in ((shake + "path = [[1.0, 0, 0, 0]]\n", "give path or shake, not both"),
                        (shake.replace("seconds", "secs"), "shake: unknown key 'secs'"),
                        ('shake = {amplitude = [0.002, 0, 0], frequency = 4.0}\n',
                         "shake needs 'seconds'")):
        with pytest.raises(SceneError, match=said):
            Scene.from_text(base + extra, name="s.toml")


def test_a_delayed_shake_holds_the_base_until_it_starts():
    """Resonance trial: with ``start = 0.5`` the base drifted from t = 0 towards the first
    keyframe (0.19 of the amplitude by t = 0.5 s).  It now stays put, to rounding, until the
    start, and then follows the sine's segments."""
    sim, top = _cube()
    rows = jellysim.shake_path((0.001, 0.0, 0.0), 2.0, seconds=0.5, start=0.5)
    sim.pin(top, path=rows)
    held = sim.state.x[top].copy()
    for _ in range(30):
        sim.advance(1)
        np.testing.assert_allclose(sim.state.x[top], held, atol=1e-15)
    swing = 0.0
    for _ in range(30):
        sim.advance(1)
        want = np.interp(sim.state.t, rows[:, 0], rows[:, 1])
        np.testing.assert_allclose(sim.state.x[top, 0] - held[:, 0], want, atol=1e-12)
        swing = max(swing, float(abs(sim.state.x[top, 0] - held[:, 0]).max()))
    assert swing > 0.9e-3  # (it did shake, one whole period)


def test_a_scene_settles_a_body_whose_base_it_then_shakes():
    """Resonance trial: ``[body] settle`` with a shaking pin was refused, and the advice
    ("settle first, then pin it with its path") had no scene form.  The shaken points are held
    where they were pinned while the body settles; at t = 0 the body rests (sagged under its
    weight, velocities zero) and the base then follows its shake exactly."""
    from jellysim.scene import Scene

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 64\nsettle = true\n'
            'lower = [0.0, 0.0, 0.0]\nupper = [0.03, 0.03, 0.03]\n[integrator]\nsteps = 30\n'
            '[[handle]]\nkind = "pin"\nbox = [[-1, -1, -1], [1, 0.001, 1]]\n'
            'shake = {amplitude = [0.001, 0, 0], frequency = 3.0, seconds = 1.0}\n')
    sim = Scene.from_text(text, name="s.toml").simulator()
    x0 = sim.model.point_x0
    base = np.flatnonzero(x0[:, 1] < 0.001)
    assert sim.state.t == 0.0 and sim.state.step == 0 and not sim.state.v.any()
    np.testing.assert_array_equal(sim.state.x[base], x0[base])
    assert sim.state.x[:, 1].max() < 0.03 - 1e-5  # (it sagged while settling)
    rows = jellysim.shake_path((0.001, 0.0, 0.0), 3.0, seconds=1.0)
    for _ in range(30):
        sim.advance(1)
        want = np.interp(sim.state.t, rows[:, 0], rows[:, 1])
        np.testing.assert_allclose(sim.state.x[base, 0] - x0[base, 0], want, atol=1e-12)


def test_a_shake_faster_than_the_saved_frames_is_said(tmp_path):
    """Resonance trial: a 50 Hz shake saved at 60 frames/s read as a 10 Hz swing in the
    render, plot and table, with nothing said.  The run now says so, naming the false
    frequency |50 - 60| = 10 Hz; at 20 Hz (below half the rate) it says nothing."""
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    base = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
            'lower = [0.0, 0.0, 0.0]\nupper = [0.02, 0.02, 0.02]\n[integrator]\nsteps = 3\n'
            '[[handle]]\nkind = "pin"\nbox = [[-1, -1, -1], [1, 0.001, 1]]\n'
            'shake = {{amplitude = [0.0005, 0, 0], frequency = {f}, seconds = 1.0}}\n')
    for f, said in ((50.0, 1), (20.0, 0)):
        notes = []
        run_scene(Scene.from_text(base.format(f=f), name="s.toml"), tmp_path / str(f),
                  progress=False, notify=notes.append)
        alias = [n for n in notes if "faster than half the rate" in n]
        assert len(alias) == said
        if said:
            assert "false 10 Hz swing" in alias[0] and "[[handle]] #1 shakes at 50 Hz" in alias[0]


def test_a_path_faster_than_the_steps_and_a_crossing_between_keyframes_are_said(monkeypatch):
    """Re-trial (session 31): the pins follow their path at the step ends, straight between,
    so a 40 Hz shake at dt = 1/60 moved the base as a 20 Hz zig-zag with nothing said; the
    same shake at 3.52 Hz (17 steps a period, 1.7 % cut) is not said.  A path whose one
    segment carries a corner 0.4 m across a 3 cm sphere (its ends and midpoint outside it)
    was not said either; and a 960,001-keyframe shake beside a sphere out of its reach is
    not swept point by point (it took 97 s)."""
    sim, top = _cube()
    with pytest.warns(UserWarning, match=r"follow their path at the end of each step \(dt = "
                                         r"0\.0166667 s\).*cut short; use a smaller dt"):
        sim.pin(top, path=jellysim.shake_path((0.001, 0, 0), 40.0, seconds=1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.pin(top, path=jellysim.shake_path((0.001, 0, 0), 3.52, seconds=1.0))
    sphere = jellysim.Sphere(center=(0.12, 0.07, 0.0), radius=0.03)
    sim, top = _cube(obstacles=[sphere])
    with pytest.warns(UserWarning, match=r"into obstacle #1 \(a sphere\)"):
        sim.pin(top, path=[[0.5, 0.4, 0.0, 0.0]])
    far = jellysim.Sphere(center=(5.0, 0.07, 0.0), radius=0.03)
    sim, top = _cube(obstacles=[far])
    rows = jellysim.shake_path((0.001, 0, 0), 100.0, seconds=300.0)
    assert len(rows) == 960_001
    import jellysim.handle_warnings as hw

    def never(*args):
        raise AssertionError("a sphere out of the path's reach was swept")

    monkeypatch.setattr(hw, "_deepest", never)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (100 Hz at dt = 1/60 is said: not this test's)
        sim.pin(top, path=rows)  # (the bounding-box test skips it)
    with pytest.raises(SceneError, match="more than a million keyframes"):
        jellysim.shake_path((0.001, 0, 0), 1e308, seconds=1.0)
