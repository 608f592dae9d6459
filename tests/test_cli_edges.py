"""Command-line edges: ``python -m jellysim``, ``--show all``, ``--out`` / ``--overwrite``,
exports that stay where they are told."""
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import jellysim
from jellysim.cli import cli
from jellysim.io.trajectory import load_trajectory

SRC = str(Path(jellysim.__file__).resolve().parents[1])

SCENE = """
[body]
points = 30
lower = [0.0, 0.2, 0.0]
upper = [0.2, 0.4, 0.2]
seed = 1
[springs]
radius = 0.12
stiffness = 50.0
[mass]
point_mass = 0.01
[integrator]
dt = 0.002
steps = {steps}
[provot]
enabled = false
[output]
every = 5
"""


def _run(tmp_path, out, steps, *extra):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.format(steps=steps))
    return CliRunner().invoke(cli, ["run", str(scene), "--out", str(out), "--quiet", *extra])


def test_python_dash_m_jellysim_is_the_cli(tmp_path):
    env = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-m", "jellysim", "--version"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert jellysim.__version__ in res.stdout


@pytest.mark.parametrize("show, expect", [
    ((), (True, False, False)),
    (("springs",), (False, False, True)),
    (("all",), (True, True, True)),
    (("ALL", "skin"), (True, True, True)),
])
def test_show_all_shows_skin_points_and_springs(show, expect):
    from jellysim.cli_visual import _options

    o = _options("64x48", "#ff0000", 0.5, show, False)
    assert (o.show_skin, o.show_points, o.show_springs) == expect


def test_out_refuses_a_non_empty_folder_and_overwrite_clears_the_old_run(tmp_path):
    out = tmp_path / "o"
    assert _run(tmp_path, out, 40).exit_code == 0       # 9 frames: body_00000..00008.vtu
    old_frames = sorted(p.name for p in out.glob("body_*.vtu"))
    assert len(old_frames) == 9
    (out / "notes.txt").write_text("mine")
    res = _run(tmp_path, out, 10)
    assert res.exit_code == 2 and "--overwrite" in res.output and "Traceback" not in res.output
    assert sorted(p.name for p in out.glob("body_*.vtu")) == old_frames   # untouched
    res = _run(tmp_path, out, 10, "--overwrite")                             # 3 frames
    assert res.exit_code == 0, res.output
    frames = sorted(p.name for p in out.glob("body_*.vtu"))
    assert frames == [f"body_{k:05d}.vtu" for k in range(3)]              # no stale frame
    assert load_trajectory(out / "trajectory.npz").frame_count == 3
    assert (out / "notes.txt").read_text() == "mine"                       # not a run's file


def test_demo_refuses_an_earlier_demo_without_overwrite(tmp_path):
    from jellysim.demo import run_demo
    from jellysim.errors import JellysimError

    (tmp_path / "demo.mp4").write_bytes(b"old")
    with pytest.raises(JellysimError, match="--overwrite"):
        run_demo(tmp_path, frames=2, progress=False)
    assert (tmp_path / "demo.mp4").read_bytes() == b"old"


def test_an_interrupted_demo_resumes_by_the_command_it_prints_to_the_uninterrupted_run(
        tmp_path, monkeypatch):
    """A new user's Ctrl-C'd demo said "continue with: jellysim run demo --resume out/demo",
    which fails (there is no scene file "demo"), and left the older demo's video and USD
    beside the new partial run.  Now: the printed command is the demo's own, the stale
    video and USD go once the new run has started, and the resumed demo's frames are bitwise
    those of an uninterrupted one."""
    import shlex

    import numpy as np

    import jellysim.demo as demo
    from jellysim.errors import JellysimError, RunInterrupted

    opts = dict(frames=12, size=(160, 90), points=300, progress=False)
    first = demo.run_demo(tmp_path / "a", **opts)
    whole = load_trajectory(first["trajectory"])
    out = tmp_path / "b"
    demo.run_demo(out, **opts)                                   # an earlier, finished demo
    real = demo.run_scene
    monkeypatch.setattr(demo, "run_scene", lambda *a, **k: real(
        *a, **k, **({} if k.get("resume") else {"stop_after": 5})))
    with pytest.raises(RunInterrupted) as stopped:
        demo.run_demo(out, overwrite=True, **opts)
    said = str(stopped.value).split("continue with: ")[-1]
    assert shlex.split(said) == ["jellysim", "demo", "--out", str(out), "--points", "300",
                                 "--frames", "12", "--resume"]
    assert not (out / "demo.mp4").exists() and not (out / "demo.usdc").exists()
    with pytest.raises(JellysimError, match="interrupted demo.*--resume"):
        demo.run_demo(out, **opts)                               # not started afresh unasked
    done = demo.run_demo(out, resume=True, **opts)
    again = load_trajectory(done["trajectory"])
    assert again.frame_count == whole.frame_count == 12
    assert np.array_equal(again.positions, whole.positions)
    assert (out / "demo.mp4").stat().st_size > 0 and (out / "demo.usdc").is_file()
    with pytest.raises(JellysimError, match="no interrupted demo"):
        demo.run_demo(out, resume=True, **opts)


def test_a_demo_stopped_while_rendering_is_finished_by_the_command_it_prints(tmp_path,
                                                                            monkeypatch):
    """A new user's Ctrl-C during the demo's rendering said only "interrupted: demo stopped";
    --resume then refused ("no interrupted demo") and a plain rerun refused the folder, so
    only --overwrite (simulating again) was left.  Now the stop prints the demo's --resume
    command, an earlier demo's video and USD go, and --resume renders the saved run without
    simulating it again."""
    import shlex

    import jellysim.demo as demo
    from jellysim.errors import JellysimError, RunInterrupted

    opts = dict(frames=6, size=(160, 90), points=300, progress=False)
    out = tmp_path / "d"
    demo.run_demo(out, **opts)                                   # an earlier, finished demo
    real = demo.render_trajectory

    def stop(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(demo, "render_trajectory", stop)
    with pytest.raises(RunInterrupted) as stopped:
        demo.run_demo(out, overwrite=True, **opts)
    assert "while rendering" in str(stopped.value)
    said = shlex.split(str(stopped.value).split("make the video with: ")[-1])
    assert said == ["jellysim", "demo", "--out", str(out), "--points", "300", "--frames", "6",
                    "--resume"]
    assert not (out / "demo.mp4").exists() and not (out / "demo.usdc").exists()
    saved = (out / "demo" / "trajectory.npz").read_bytes()
    with pytest.raises(JellysimError, match="simulated but not rendered.*--resume"):
        demo.run_demo(out, **opts)
    with pytest.raises(JellysimError, match="other options"):
        demo.run_demo(out, resume=True, **{**opts, "frames": 8})
    monkeypatch.setattr(demo, "render_trajectory", real)
    monkeypatch.setattr(demo, "run_scene", None)                 # (not simulated again)
    done = demo.run_demo(out, resume=True, **opts)
    assert done["reused"] and done["frames"] == 6
    assert (out / "demo" / "trajectory.npz").read_bytes() == saved
    assert (out / "demo.mp4").stat().st_size > 0 and (out / "demo.usdc").is_file()


@pytest.fixture(scope="module")
def traj_path(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("edge")
    out = tmp / "run"
    assert _run(tmp, out, 20, "--no-vtu").exit_code == 0
    return out / "trajectory.npz"


def test_export_pvd_keeps_its_frames_in_a_sibling_folder(traj_path, tmp_path, monkeypatch):
    import meshio

    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli, ["export", str(traj_path), "-o", "run.pvd"])
    assert res.exit_code == 0, res.output
    traj = load_trajectory(traj_path)
    loose = sorted(p.name for p in tmp_path.iterdir() if p.is_file())
    assert loose == ["run.pvd", "run_skin.pvd"]      # the frames did not spill into the CWD
    for pvd, expected in (("run.pvd", traj.positions),
                          ("run_skin.pvd", [traj.skin_positions(k)
                                            for k in range(traj.frame_count)])):
        files = [d.get("file") for d in ET.parse(pvd).getroot().iter("DataSet")]
        assert len(files) == traj.frame_count and all(f.startswith("run/") for f in files)
        for k, f in enumerate(files):
            np.testing.assert_allclose(meshio.read(f).points, expected[k], atol=1e-12)


def test_export_sequence_takes_the_folder_as_an_argument(traj_path, tmp_path):
    import meshio

    traj = load_trajectory(traj_path)
    if traj.skin is None and not len(traj.triangles):
        # a box run carries its box surface as the skin; nothing to export otherwise
        pytest.fail("a box run should carry a skin")
    folder = tmp_path / "frames"
    res = CliRunner().invoke(cli, ["export", str(traj_path), "--sequence", "obj", str(folder)])
    assert res.exit_code == 0, res.output
    files = sorted(folder.glob("*.obj"))
    assert len(files) == traj.frame_count
    np.testing.assert_allclose(meshio.read(files[-1]).points, traj.skin_positions(traj.frame_count - 1), atol=1e-6)
    res = CliRunner().invoke(cli, ["export", str(traj_path), "a.glb", "-o", "b.glb"])
    assert res.exit_code == 2 and "two outputs" in res.output
    res = CliRunner().invoke(cli, ["export", str(traj_path)])
    assert res.exit_code == 2 and "no output" in res.output


def test_outputs_never_replace_or_mix_with_earlier_files_unasked(traj_path, tmp_path):
    """export / render / build refuse to replace an existing file (its bytes are kept) or to
    write frames into a folder holding an earlier output's frames (they would mix); with
    --overwrite the file is replaced and the stale frames are deleted first, so the folder
    holds exactly the new ones."""
    run = CliRunner().invoke
    traj = load_trajectory(traj_path)
    keep = tmp_path / "keep.glb"
    keep.write_bytes(b"precious")
    res = run(cli, ["export", str(traj_path), "-o", str(keep)])
    assert res.exit_code == 2 and "--overwrite" in res.output and keep.read_bytes() == b"precious"
    assert run(cli, ["export", str(traj_path), "-o", str(keep), "--overwrite"]).exit_code == 0
    assert keep.read_bytes()[:4] == b"glTF"
    seq = tmp_path / "seq"
    assert run(cli, ["export", str(traj_path), "--sequence", "obj", str(seq)]).exit_code == 0
    (seq / "skin_00099.obj").write_text("stale frame of another run")
    res = run(cli, ["export", str(traj_path), "--sequence", "obj", str(seq)])
    assert res.exit_code == 2 and "would mix" in res.output
    res = run(cli, ["export", str(traj_path), "--sequence", "obj", str(seq), "--overwrite"])
    assert res.exit_code == 0 and len(list(seq.glob("*.obj"))) == traj.frame_count
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in range(7):
        (frames / f"frame_{k:05d}.png").write_bytes(b"old")
    args = ["render", str(traj_path), "-o", str(frames), "--every", "2", "--quiet",
            "--size", "64x48"]
    res = run(cli, args)
    assert res.exit_code == 2 and "7 file(s)" in res.output
    assert run(cli, args + ["--overwrite"]).exit_code == 0
    assert len(list(frames.glob("frame_*.png"))) == len(range(0, traj.frame_count, 2))
    # a file standing where a folder is needed, and an unwritable place: one line, no traceback
    res = run(cli, ["export", str(traj_path), "-o", str(keep / "x.usdc")])
    assert res.exit_code == 2 and "is a file, not a folder" in res.output
    assert "Traceback" not in res.output


def test_run_set_overrides_a_scene_value_and_records_it(tmp_path):
    out = tmp_path / "o"
    res = _run(tmp_path, out, 10, "--set", "body.points=12", "--set", "physics.damping=0.5")
    assert res.exit_code == 0, res.output
    traj = load_trajectory(out / "trajectory.npz")
    assert traj.positions.shape[1] == 12
    assert traj.params["body"]["points"] == 12 and traj.params["physics"]["damping"] == 0.5
    assert "--set body.points=12" in traj.scene_toml
    res = _run(tmp_path, tmp_path / "p", 10, "--set", "bodypoints=3")
    assert res.exit_code == 2 and "SECTION.KEY=VALUE" in res.output
    res = _run(tmp_path, tmp_path / "q", 10, "--set", "body.pionts=3")
    assert res.exit_code == 2 and "did you mean 'points'" in res.output


def test_a_staged_output_replaces_old_frames_only_once_all_new_are_written(tmp_path):
    """A render to a folder of frames with --overwrite stopped half-way (Ctrl-C) left a new
    user 7 of the 61 old frames: the old ones were deleted first.  Staged, an interrupted
    write leaves every old frame as it was and no staging folder; a finished one leaves
    exactly the new frames (none of a longer earlier run) and files that are not frames."""
    from jellysim.io.atomic import staged_output

    out = tmp_path / "frames"
    out.mkdir()
    for k in range(10):
        (out / f"frame_{k:05d}.png").write_text(f"old {k}")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt):
        with staged_output(out, ["frame_[0-9]*.png"]) as stage:
            for k in range(3):
                (stage / f"frame_{k:05d}.png").write_text(f"new {k}")
            raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"frame_{k:05d}.png" for k in range(10)] + ["notes.txt"])
    assert all((out / f"frame_{k:05d}.png").read_text() == f"old {k}" for k in range(10))
    with staged_output(out, ["frame_[0-9]*.png"]) as stage:
        for k in range(3):
            (stage / f"frame_{k:05d}.png").write_text(f"new {k}")
    assert sorted(p.name for p in out.iterdir()) == [
        "frame_00000.png", "frame_00001.png", "frame_00002.png", "notes.txt"]
    assert (out / "frame_00002.png").read_text() == "new 2"


def test_ctrl_c_in_a_command_that_writes_nothing_is_one_line_and_exit_130(tmp_path,
                                                                        monkeypatch):
    """Session 20's trial: Ctrl-C in `inspect` (or in `run` while it was still building the
    body) printed click's bare `Aborted!` with exit status 1, as if it had failed.  It now says
    which command stopped, with the interrupt's status 130, and `run` leaves no folder."""
    import jellysim.scene as sc

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(sc.Scene, "build_model", interrupted)
    scene = Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml"
    runner = CliRunner()
    for args in (["inspect", str(scene)], ["run", str(scene), "--out", str(tmp_path / "o")]):
        res = runner.invoke(cli, args)
        assert res.exit_code == 130, res.output
        assert f"interrupted: {args[0]} stopped" in res.output and "Aborted" not in res.output
        assert args[0] != "run" or "before its first step; nothing was written" in res.output
    assert not (tmp_path / "o").exists()
    # a second Ctrl-C stops the stepping at once, after frames and a checkpoint were written
    # (the review of session 21: the line said "nothing was written")
    import jellysim.cli as jcli

    def stopped_at_once(scene, out, **kw):
        (Path(out) / "checkpoint.npz").write_bytes(b"x")
        raise KeyboardInterrupt

    monkeypatch.undo()
    monkeypatch.setattr(jcli, "run_scene", stopped_at_once)
    res = runner.invoke(cli, ["run", str(scene), "--out", str(tmp_path / "o")])
    assert res.exit_code == 130 and "nothing was written" not in res.output
    assert f"continue with: jellysim run {scene} --resume {tmp_path / 'o'}" in \
        res.output.replace("\n", "")


def test_render_and_export_with_overwrite_stopped_half_way_keep_the_earlier_output(
        traj_path, tmp_path, monkeypatch):
    """The CLI's folder outputs (PNG frames, a .pvd and its frames, an OBJ sequence) go
    through the staging: each is written once, then re-written with --overwrite by a writer
    that stops (KeyboardInterrupt) after two files; the first output stays whole."""
    import jellysim.cli_visual as cv

    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    first = {}
    for args in (["render", str(traj_path), "-o", "frames", "--size", "64x48", "--every", "5",
                  "--quiet"],
                 ["export", str(traj_path), "-o", "run.pvd"],
                 ["export", str(traj_path), "--sequence", "obj", "seq"]):
        res = runner.invoke(cli, args)
        assert res.exit_code == 0, res.output
    for p in sorted(tmp_path.rglob("*")):
        if p.is_file():
            first[p.relative_to(tmp_path)] = p.read_bytes()
    assert len(first) > 10

    def stops_after_two(name):
        def write(traj, where, *a, **k):
            where = Path(where)
            folder = where if not where.suffix else where.parent
            folder.mkdir(parents=True, exist_ok=True)
            for k in range(2):
                (folder / name.format(k)).write_bytes(b"half")
            raise KeyboardInterrupt
        return write

    import imageio.v3 as iio3  # (render_trajectory stages a folder's frames itself: its
    real_imwrite = iio3.imwrite  # image writer stops after two)
    pictures = []

    def imwrite_stops_after_two(uri, image, **kw):
        pictures.append(uri)
        if len(pictures) > 2:
            raise KeyboardInterrupt
        return real_imwrite(uri, image, **kw)

    monkeypatch.setattr(iio3, "imwrite", imwrite_stops_after_two)
    monkeypatch.setattr(cv, "export_pvd_file", stops_after_two("run.pvd"))
    import meshio   # (export_mesh_sequence stages its frames itself: its writers stop)

    calls = []

    def meshio_stops_after_two(path, mesh, file_format=None):
        calls.append(path)
        if len(calls) > 2:
            raise KeyboardInterrupt
        Path(path).write_bytes(b"half")

    monkeypatch.setattr(meshio, "write", meshio_stops_after_two)
    from jellysim.io import meshseq  # (its OBJ frames are written by its own _write_obj)

    monkeypatch.setattr(meshseq, "_write_obj", lambda path, *a, **k: meshio_stops_after_two(
        path, None))
    for args in (["render", str(traj_path), "-o", "frames", "--size", "64x48", "--overwrite",
                  "--quiet"],
                 ["export", str(traj_path), "-o", "run.pvd", "--overwrite"],
                 ["export", str(traj_path), "--sequence", "obj", "seq", "--overwrite"]):
        res = runner.invoke(cli, args)
        assert res.exit_code == 130 and "nothing half-written was kept" in res.output, (
            res.output)
    now = {p.relative_to(tmp_path): p.read_bytes() for p in sorted(tmp_path.rglob("*"))
           if p.is_file()}
    assert now == first
    assert not [p for p in tmp_path.rglob(".new-*")]


def test_ctrl_c_while_a_run_writes_its_video_says_the_run_is_saved_and_how_to_finish(
        tmp_path, monkeypatch):
    """Session 20's CLI trial: Ctrl-C while `run --video V --usd U` rendered V printed a bare
    `Aborted!` (the run was complete and saved, V and U were not written, and neither a
    re-run nor --resume would make them).  Now it says so, with the commands that do, and
    leaves no half-written V; the printed export command then writes U."""
    import shlex

    import jellysim.cli_visual as cv

    def interrupted(*a, **k):
        raise KeyboardInterrupt
    monkeypatch.setattr(cv, "render_trajectory", interrupted)
    out, video, usd = tmp_path / "run", tmp_path / "v.gif", tmp_path / "u.usda"
    res = _run(tmp_path, out, 40, "--video", str(video), "--usd", str(usd), "--no-vtu")
    assert res.exit_code == 130, res.output
    assert "the run is complete" in res.output and "nothing half-written was kept" in res.output
    assert f"jellysim render {out / 'trajectory.npz'} -o {video}" in res.output
    assert not video.exists() and not usd.exists()
    assert load_trajectory(out / "trajectory.npz").frame_count == 9   # the whole run saved
    export = res.output.split(" and ")[-1].strip()
    assert export == f"jellysim export {out / 'trajectory.npz'} -o {usd}"
    done = CliRunner().invoke(cli, shlex.split(export)[1:])
    assert done.exit_code == 0, done.output
    assert usd.is_file()


def test_an_interrupted_overwrite_run_drops_the_earlier_runs_video(tmp_path, monkeypatch):
    """`run --overwrite --video V` stopped half-way left the earlier run's V beside the new
    partial run (it matched no run left there).  Now V goes with the earlier run; the printed
    resume command keeps --video, and resuming writes the new V."""
    import jellysim.cli as cli_module

    out, video = tmp_path / "run", tmp_path / "v.gif"
    res = _run(tmp_path, out, 40, "--video", str(video), "--no-vtu")
    assert res.exit_code == 0, res.output
    assert video.is_file()
    real = cli_module.run_scene
    monkeypatch.setattr(cli_module, "run_scene", lambda *a, **k: real(
        *a, **k, **({} if k.get("resume") else {"stop_after": 10})))
    res = _run(tmp_path, out, 40, "--video", str(video), "--no-vtu", "--overwrite")
    assert res.exit_code == 3, res.output
    assert "--resume" in res.output and f"--video {video}" in res.output
    assert not video.exists()
    monkeypatch.setattr(cli_module, "run_scene", real)
    res = CliRunner().invoke(cli, ["run", str(tmp_path / "s.toml"), "--resume", str(out),
                                   "--quiet", "--no-vtu", "--video", str(video)])
    assert res.exit_code == 0, res.output
    assert video.is_file() and load_trajectory(out / "trajectory.npz").frame_count == 9


def test_output_piped_to_a_reader_that_has_gone_ends_quietly():
    """Session 21's trial: `jellysim inspect ... | head -4` and `jellysim scene-help | head -3`
    printed `error: Broken pipe`.  A reader that has gone (here: the pipe closed before the
    command writes) ends the command quietly, with a shell's 141 (128 + SIGPIPE)."""
    scene = Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml"
    for args in (["inspect", str(scene)], ["scene-help"]):
        p = subprocess.Popen([sys.executable, "-m", "jellysim.cli", *args],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        p.stdout.close()               # gone before the first line
        err = p.stderr.read().decode()
        assert p.wait(timeout=60) == 141, err
        assert "error" not in err and "Traceback" not in err and "Exception" not in err, err


def test_a_run_without_its_final_state_is_not_extended_in_silence(tmp_path):
    """Session 24's researcher trial: an mpiexec run keeps no checkpoint and no final state.
    Extending it (`--resume DIR --steps N`) printed "nothing to resume ... (it failed, or an
    older jellysim wrote it)" and exited 0, so a pipeline took it for done; `run --resume
    DIR` without the scene said "no checkpoint (a run leaves one when it is interrupted...)".
    Both now name mpiexec, exit 2, and say how to go on; with no more steps asked it stays a
    quiet no-op (exit 0).  (A finished serial run with its final state deleted stands in for
    an mpiexec run: the same files.)"""
    out = tmp_path / "run"
    assert _run(tmp_path, out, 20).exit_code == 0
    (out / "checkpoint.final.npz").unlink()
    again = _run(tmp_path, out, 20, "--resume", str(out), "--steps", "40")
    assert again.exit_code == 2, again.output
    assert "cannot extend" in again.output and "mpiexec" in again.output
    assert "--overwrite" in again.output
    bare = CliRunner().invoke(cli, ["run", "--resume", str(out), "--steps", "40", "--quiet"])
    assert bare.exit_code == 2, bare.output
    assert "has finished and kept no checkpoint" in bare.output and "mpiexec" in bare.output
    same = _run(tmp_path, out, 20, "--resume", str(out))
    assert same.exit_code == 0 and "nothing to resume" in same.output
    assert len(load_trajectory(out).times) == 5  # (steps 0-20, a frame every 5) untouched


def test_a_serial_run_says_it_ignores_partition(tmp_path):
    """The researcher trial: `run --partition metis` without mpiexec was accepted silently."""
    res = _run(tmp_path, tmp_path / "p", 10, "--partition", "metis")
    assert res.exit_code == 0, res.output
    assert "--partition metis applies under mpiexec only" in res.output


def test_an_output_path_through_a_file_or_a_read_only_folder_is_named_as_given(traj_path,
                                                                              tmp_path):
    """The artist trial: `run --out afile/r` and `export --sequence obj afile/seq` said "Not a
    directory" (render and export said which part was a file); a read-only folder's error
    named a hidden staging folder (`rofs/.new-ec9frqa1`).  Every command now names the path
    given and the part that is a file; an error on a staging folder names its folder."""
    import errno

    from jellysim.io.atomic import describe_os_error

    afile = tmp_path / "afile"
    afile.write_text("not a folder")
    res = _run(tmp_path, afile / "r", 2)
    assert res.exit_code == 2 and f"{afile} is a file, not a folder" in res.output
    res = CliRunner().invoke(cli, ["export", str(traj_path), "--sequence", "obj",
                                   str(afile / "seq")])
    assert res.exit_code == 2 and f"{afile} is a file, not a folder" in res.output
    assert afile.read_text() == "not a folder"
    rofs = tmp_path / "rofs"
    line = describe_os_error(OSError(errno.EROFS, "Read-only file system",
                                     str(rofs / ".new-ec9frqa1")))
    assert line.startswith(f"{rofs}: Read-only file system (") and ".new-" not in line
    res = CliRunner().invoke(cli, ["render", str(tmp_path / "no_run"), "-o",
                                   str(tmp_path / "x.png")])
    assert res.exit_code == 2 and "jellysim run SCENE --out FOLDER" in res.output
    # a name without a suffix is a folder of frames: a file there said "afile: File exists"
    res = CliRunner().invoke(cli, ["render", str(traj_path), "-o", str(afile), "--quiet"])
    assert res.exit_code == 2 and "a file of that name is where a folder is needed" in (
        res.output) and afile.read_text() == "not a folder"


def test_resume_with_overwrite_is_refused_and_the_summary_counts_the_writing(tmp_path,
                                                                            monkeypatch):
    """The reliability trial: `run --resume DIR --overwrite` resumed and ignored --overwrite;
    and the run's summary gave the stepping's seconds alone (8.82 s of a 26.5 s run that
    wrote 501 frames).  The two options together are refused; a run whose writing took a
    good part of the time says how long it took in all."""
    import time

    import jellysim.cli as cli_module

    out = tmp_path / "run"
    real = cli_module.run_scene

    def slow_writer(*a, **k):  # (as a run whose frames take 1.5 s more to write)
        result = real(*a, **k)
        time.sleep(1.5)
        return result

    monkeypatch.setattr(cli_module, "run_scene", slow_writer)
    res = _run(tmp_path, out, 10, "--no-vtu")
    assert res.exit_code == 0, res.output
    head = res.output.splitlines()[0]
    seconds = float(head.split(" frames in ")[1].split(" s ")[0])
    in_all = float(head.split("; ")[1].split(" s in all")[0])
    assert in_all >= seconds + 1.5 and "with building the body and writing the frames" in head
    res = CliRunner().invoke(cli, ["run", "--resume", str(out), "--overwrite"])
    assert res.exit_code == 2 and "give one of them" in res.output
    assert load_trajectory(out).steps[-1] == 10


def test_temporary_files_of_a_killed_writer_are_cleared_by_the_next_write(tmp_path):
    """The reliability trial: a render killed with SIGKILL (no cleanup runs) left its
    temporary `.dd2.mp4.kevucuw0.mp4` beside the video for good; the re-trial: a write of
    another name in that folder left it too.  Temporary files and staging folders carry
    their process's number: the next write in that folder, of any name, deletes those of
    processes that are gone, and leaves a live process's (a write under way) and names of
    another form."""
    import os

    from jellysim.io.atomic import atomic_write, staged_output

    dead = 2 ** 22 + 12345                      # (beyond Linux's pid range: no such process)
    orphans = [tmp_path / f".dd2.mp4.{dead}-kevucuw0.mp4", tmp_path / f".new-{dead}-a1b2c3d4"]
    orphans[0].write_bytes(b"half a video")
    orphans[1].mkdir()
    (orphans[1] / "frame_00000.png").write_bytes(b"x")
    kept = [tmp_path / f".dd2.mp4.{os.getppid()}-zzzzzzzz.mp4",
            tmp_path / ".dd2.mp4.oldstyle.mp4", tmp_path / ".my.notes.123-4"]
    for k in kept:
        k.write_bytes(b"not ours to delete")
    atomic_write(tmp_path / "other.glb", lambda fh: fh.write(b"glb"))
    assert not any(o.exists() for o in orphans)
    frames = tmp_path / "frames"     # (a folder is swept once per process: a fresh one)
    stale = frames / f".new-{dead}-a1b2c3d4"
    stale.mkdir(parents=True)
    with staged_output(frames, ["frame_*.png"]):
        pass
    assert not stale.exists()
    assert all(k.read_bytes() == b"not ours to delete" for k in kept)
    assert (tmp_path / "other.glb").read_bytes() == b"glb"


def test_overwrite_deletes_the_runs_record_before_its_frames(tmp_path, monkeypatch):
    """The reliability trial: `run --overwrite` killed (SIGKILL) while deleting the earlier
    run left its trajectory.npz ("complete", 901 frames) beside 346 of its skin frames, its
    body.pvd and final checkpoint gone.  The files that say a run is there go first, the
    ParaView series next, the frames last: stopped anywhere, no complete-looking run is left
    beside a part of its frames."""
    from pathlib import Path

    from jellysim.runner import prepare_out_dir

    out = tmp_path / "run"
    assert _run(tmp_path, out, 10).exit_code == 0
    order, real = [], Path.unlink

    def unlink(self, *a, **k):
        order.append(self.name)
        return real(self, *a, **k)

    monkeypatch.setattr(Path, "unlink", unlink)
    prepare_out_dir(out, overwrite=True)
    frames = [k for k, name in enumerate(order) if name.endswith(".vtu")]
    record = [order.index(n) for n in ("trajectory.npz", "checkpoint.final.npz", "body.pvd")]
    assert frames and max(record) < min(frames)
    assert order.index("trajectory.npz") < order.index("body.pvd")
    assert not list(out.iterdir())
