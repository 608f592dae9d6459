"""Pictures, videos, exports, viewer, plots: read-only consumers of saved trajectories."""
import os
import shutil
from pathlib import Path
import subprocess
import warnings
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner

from jellysim.cli import cli
from jellysim.io.trajectory import load_trajectory
from jellysim.runner import run_scene
from jellysim.scene import Scene

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

SCENE = """
[body]
points = 120
lower = [0.0, 0.25, 0.0]
upper = [0.4, 0.55, 0.4]
seed = 2
[springs]
radius = 0.14
stiffness = 300.0
[mass]
point_mass = 0.002
[physics]
damping = 0.001
[integrator]
dt = 0.001
steps = 280
[output]
every = 40
vtu = true
"""
SIZE = (96, 64)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    (out / "scene.toml").write_text(SCENE)
    run_scene(Scene.from_text(SCENE, name="scene.toml"), out, progress=False)
    return out


@pytest.fixture(scope="module")
def traj(run_dir):
    return load_trajectory(run_dir / "trajectory.npz")


def _read_video(path):
    import imageio.v3 as iio

    return np.asarray(iio.imread(path))


def test_box_run_carries_its_surface_as_skin(traj):
    assert traj.skin is not None
    lo, hi = traj.skin.rest_vertices.min(0), traj.skin.rest_vertices.max(0)
    np.testing.assert_allclose(lo, [0.0, 0.25, 0.0], atol=1e-12)
    np.testing.assert_allclose(hi, [0.4, 0.55, 0.4], atol=1e-12)
    # the body falls: so does the skin, by the points' motion
    assert traj.skin_positions(traj.frame_count - 1)[:, 1].mean() < (
        traj.skin_positions(0)[:, 1].mean() - 0.05)


def test_mp4_decodes_with_expected_frames_size_not_blank_and_moving(traj, tmp_path):
    from jellysim.render import RenderOptions, render_trajectory

    before = traj.positions.copy()
    path = render_trajectory(traj, tmp_path / "run.mp4",
                             RenderOptions(size=SIZE, show_points=True, show_springs=True))
    np.testing.assert_array_equal(traj.positions, before)      # read-only consumer
    video = _read_video(path)
    assert video.shape == (traj.frame_count, SIZE[1], SIZE[0], 3)
    per_frame_std = video.reshape(len(video), -1).std(axis=1)
    assert per_frame_std.min() > 10.0                           # not blank
    change = np.abs(video[-1].astype(float) - video[0].astype(float)).mean()
    assert change > 2.0                                         # the body moved on screen


def test_python_renders_plots_and_tables_keep_what_exists_unless_overwrite(traj, tmp_path):
    """Notebook trial, session 30: render_trajectory, plot_trajectory and write_table replaced
    an existing file unsaid, and a second render of other frames into a folder mixed with the
    first's.  Now each refuses (the file's bytes kept) unless overwrite=True, which for a
    folder leaves only the new render's frames."""
    from jellysim.errors import OutputError
    from jellysim.plot import plot_trajectory, write_table
    from jellysim.render import RenderOptions, render_trajectory

    opts = RenderOptions(size=SIZE)
    for name, write in (("a.png", lambda p, **k: render_trajectory(traj, p, opts, **k)),
                        ("t.csv", lambda p, **k: write_table(traj, p, **k)),
                        ("e.svg", lambda p, **k: plot_trajectory(traj, p, **k))):
        path = write(tmp_path / name)
        first = path.read_bytes()
        with pytest.raises(OutputError, match=r"exists; pass overwrite=True"):
            write(path)
        assert path.read_bytes() == first
        assert write(path, overwrite=True) == path and path.is_file()
    folder = render_trajectory(traj, tmp_path / "frames", opts, frames=[0, 3])
    with pytest.raises(OutputError, match=r"already holds 2 file\(s\) like frame_00000.png"):
        render_trajectory(traj, folder, opts, frames=[5])
    assert sorted(p.name for p in folder.iterdir()) == ["frame_00000.png", "frame_00003.png"]
    render_trajectory(traj, folder, opts, frames=[5], overwrite=True)
    assert sorted(p.name for p in folder.iterdir()) == ["frame_00005.png"]


def test_gif_and_png_frames(traj, tmp_path):
    from jellysim.render import RenderOptions, render_trajectory

    opts = RenderOptions(size=SIZE)
    gif = _read_video(render_trajectory(traj, tmp_path / "a.gif", opts, frames=[0, 3, 6]))
    assert gif.shape[:3] == (3, SIZE[1], SIZE[0])
    folder = render_trajectory(traj, tmp_path / "frames", opts, frames=[0, 6])
    pngs = sorted(folder.glob("frame_*.png"))
    assert [p.name for p in pngs] == ["frame_00000.png", "frame_00006.png"]  # frame numbers
    import imageio.v3 as iio

    a, b = (iio.imread(p)[..., :3].astype(float) for p in pngs)
    assert a.std() > 10.0 and np.abs(a - b).mean() > 2.0


def _in_view(cam, pts, size):
    """Each point's depth along the camera's view [m] and the fraction of the half field of
    view (vertical or horizontal, whichever is more used) its image lies at: <= 1 in view."""
    pos, focal = np.array(cam.position), np.array(cam.focal_point)
    forward = (focal - pos) / np.linalg.norm(focal - pos)
    up = np.array(cam.up) - forward * (np.array(cam.up) @ forward)
    up /= np.linalg.norm(up)
    right = np.cross(forward, up)
    rel = pts - pos
    depth = rel @ forward
    tan_v = np.tan(np.radians(cam.view_angle) / 2)
    tan_h = tan_v * size[0] / size[1]
    return depth, np.maximum(np.abs(rel @ up) / depth / tan_v,
                             np.abs(rel @ right) / depth / tan_h)


def test_camera_keeps_every_frame_in_view():
    from jellysim.render.camera import frame_motion

    rng = np.random.default_rng(0)
    pts = rng.normal(size=(50, 3)) * [3.0, 0.5, 1.0] + [10, 2, -4]
    depth, used = _in_view(frame_motion(pts, (160, 90)), pts, (160, 90))
    assert np.all(depth > 0) and np.all(used <= 1.0)


@pytest.mark.parametrize("azimuth,elevation", [(None, None), (120.0, 5.0), (-45.0, 90.0)])
def test_camera_options_set_the_view_direction_and_keep_the_motion_in_view(azimuth, elevation):
    """--azimuth / --elevation: the camera sits in that direction from the focal point
    (defaults: the built-in three-quarter view); every point stays in view from any of them
    (from straight above too, where +y cannot be the image's up); --zoom 2 halves the
    distance."""
    from jellysim.render.camera import DEFAULT_DIRECTION, frame_motion, view_direction

    d = view_direction(azimuth, elevation)
    if azimuth is None:
        assert np.allclose(d, np.array(DEFAULT_DIRECTION) / np.linalg.norm(DEFAULT_DIRECTION))
    else:
        az, el = np.radians(azimuth), np.radians(elevation)
        assert np.allclose(d, [np.cos(el) * np.cos(az), np.sin(el), np.cos(el) * np.sin(az)])
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(80, 3)) * [0.03, 0.01, 0.02] + [0.1, 0.02, -0.05]
    cam = frame_motion(pts, (160, 90), direction=d)
    pos, focal = np.array(cam.position), np.array(cam.focal_point)
    assert np.allclose((pos - focal) / np.linalg.norm(pos - focal), d)
    forward = (focal - pos) / np.linalg.norm(focal - pos)
    up = np.array(cam.up) - forward * (np.array(cam.up) @ forward)
    assert np.linalg.norm(up) > 0.5  # a usable up vector, even looking straight down
    up /= np.linalg.norm(up)
    rel = pts - pos
    depth = rel @ forward
    tan_v = np.tan(np.radians(cam.view_angle) / 2)
    assert np.all(depth > 0) and np.all(np.abs(rel @ up) / depth <= tan_v)
    assert np.all(np.abs(rel @ np.cross(forward, up)) / depth <= tan_v * 160 / 90)
    near = frame_motion(pts, (160, 90), direction=d, zoom=2.0)
    assert np.linalg.norm(np.array(near.position) - focal) == pytest.approx(
        0.5 * np.linalg.norm(pos - focal), rel=1e-12)


def test_a_run_saved_faster_than_a_screen_plays_in_real_time(traj, tmp_path):
    """Session 11's trial: the default rate was clamped to 60 frames/s, so a run saved at 100
    frames/s played 1.67x slow in its USD and its video, and a 60 frames/s GIF was written with
    1/100 s delays, which browsers play at 1/10 s (6x slow).  Each now lasts the simulated
    time: the video and GIF show every k-th frame, the USD stage keeps every frame at the
    run's own rate.  (The same frames saved at 100 frames/s: `times` scaled.)"""
    import dataclasses

    from PIL import Image
    from pxr import Usd

    from jellysim.io.timing import real_time_playback
    from jellysim.io.usd import export_usd
    from jellysim.render import RenderOptions, render_trajectory

    fast = dataclasses.replace(traj, times=traj.times[0] + np.arange(traj.frame_count) / 100.0)
    span = traj.frame_count / 100.0  # the frames' simulated time, the last one's included
    import imageio.v2 as iio2

    mp4 = render_trajectory(fast, tmp_path / "fast.mp4", RenderOptions(size=SIZE))

    reader = iio2.get_reader(mp4, format="FFMPEG")
    shown, fps = reader.count_frames(), reader.get_meta_data()["fps"]
    reader.close()
    assert fps <= 60 and shown / fps == pytest.approx(span, abs=1.0 / fps + 1e-9)
    gif = render_trajectory(fast, tmp_path / "fast.gif", RenderOptions(size=SIZE))
    with Image.open(gif) as im:
        delays = []
        for k in range(im.n_frames):
            im.seek(k)
            delays.append(im.info["duration"])
    assert min(delays) >= 20  # browsers slow anything shorter
    assert sum(delays) / 1000.0 == pytest.approx(span, abs=max(delays) / 1000.0 + 1e-9)
    # a 30 frames/s run: 3, 3, 4 hundredths (1000 / 30 = 29.999... ms was truncated to 20:
    # 1.5x fast; then 30 ms throughout: 10 % fast), the total the run's time
    slow = dataclasses.replace(traj, times=traj.times[0] + np.arange(traj.frame_count) / 30.0)
    with Image.open(render_trajectory(slow, tmp_path / "slow.gif", RenderOptions(size=SIZE))) as im:
        slow_delays = []
        for k in range(im.n_frames):
            im.seek(k)
            slow_delays.append(im.info["duration"])
    assert set(slow_delays) <= {30, 40} and min(slow_delays) >= 20
    span30 = (traj.frame_count - 1) / 30.0
    assert abs(sum(slow_delays[:-1]) / 1000.0 - span30) <= 0.005 + 1e-9
    folder = render_trajectory(fast, tmp_path / "pngs", RenderOptions(size=SIZE))
    assert len(list(folder.glob("frame_*.png"))) == fast.frame_count  # pictures: every frame
    stage = Usd.Stage.Open(str(export_usd(fast, tmp_path / "fast.usdc")))
    assert stage.GetTimeCodesPerSecond() == 100.0
    assert (stage.GetEndTimeCode() - stage.GetStartTimeCode()) / 100.0 == pytest.approx(
        fast.times[-1] - fast.times[0], rel=1e-12)
    for rate in (24.0, 30.0, 60.0, 100.0, 144.0, 1000.0):   # any rate, for any length
        times = np.arange(601) / rate
        for gif_kind in (False, True):
            frames, fps = real_time_playback(times, np.arange(601), gif=gif_kind)
            assert fps <= (50 if gif_kind else 60) and frames[-1] == 600  # the end shown
            per_frame = 1.0 / fps - (frames[1] - frames[0]) / rate  # played - simulated [s]
            assert abs(per_frame) <= (0.005 if gif_kind else 1e-12)


def test_an_export_of_a_body_turned_inside_out_says_so(traj, tmp_path):
    """Session 11's trial: the report's step (examples/paper_cube.toml) mirrors the cube as it
    lands (positions-only Provot over all pairs keeps every distance, which a reflection keeps
    too), so its exported skin pointed inward from then on, silently.  The enclosed volume of
    the exported surface is checked per frame: a mirrored copy of a run is reported from its
    first mirrored frame, the run itself not; the paper cube's export warns and is written."""
    import dataclasses

    from jellysim.io.usd import inside_out_note

    assert inside_out_note(traj) is None
    flipped = traj.positions.copy()
    flipped[3:, :, 0] *= -1.0                     # frames 3.. mirrored in x
    note = inside_out_note(dataclasses.replace(traj, positions=flipped))
    assert f"inside out in {traj.frame_count - 3} of {traj.frame_count} frames" in note
    assert f"t = {traj.times[3]:.3g} s" in note
    open_skin = dataclasses.replace(traj.skin, faces=traj.skin.faces[1:])  # one face gone
    assert inside_out_note(dataclasses.replace(traj, positions=flipped, skin=open_skin)) is None
    run_scene(Scene.load(Path(__file__).parents[1] / "examples" / "paper_cube.toml"),
              tmp_path / "paper", progress=False, vtu=False, steps=70)
    r = CliRunner().invoke(cli, ["export", str(tmp_path / "paper"), "-o",
                                 str(tmp_path / "paper.glb")])
    assert r.exit_code == 0 and "inside out" in r.output
    assert (tmp_path / "paper.glb").stat().st_size > 0
    r = CliRunner().invoke(cli, ["render", str(tmp_path / "paper"), "-o",   # a picture of it
                                 str(tmp_path / "paper.png"), "--size", "64x48", "--quiet"])
    assert r.exit_code == 0 and "inside out" in r.output      # says so too (it did not)


def test_usd_has_one_time_sample_per_frame_equal_to_the_skin(traj, tmp_path):
    from pxr import Usd, UsdGeom

    from jellysim.io.usd import export_usd

    path = export_usd(traj, tmp_path / "run.usdc")
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask     # shareable, not mkstemp's 0600
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    meshes = [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)]
    assert len(meshes) == 1
    attr = meshes[0].GetPointsAttr()
    assert list(attr.GetTimeSamples()) == list(range(traj.frame_count))
    for k in range(traj.frame_count):
        np.testing.assert_allclose(np.array(attr.Get(k)), traj.skin_positions(k), atol=1e-6)
    idx = np.array(meshes[0].GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
    np.testing.assert_array_equal(idx, traj.skin.faces)
    # session 24's artist trial: no normals (Blender drew it faceted) and no material; now
    # time-sampled vertex normals and a translucent preview material
    from pxr import UsdShade

    # (a box's edges are creases: the normals are per face corner, each its face's side's)
    normals = meshes[0].GetNormalsAttr()
    assert list(normals.GetTimeSamples()) == list(range(traj.frame_count))
    assert meshes[0].GetNormalsInterpolation() == UsdGeom.Tokens.faceVarying
    for k in range(traj.frame_count):
        n = np.array(normals.Get(k), dtype=float)
        assert n.shape == (3 * len(idx), 3)
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
    rest = traj.skin_positions(0)
    n0 = np.array(normals.Get(0), dtype=float).reshape(-1, 3, 3)
    lo, hi = rest.min(axis=0), rest.max(axis=0)
    corners = rest[idx]                                   # (f, 3, 3)
    assert np.all(np.einsum("fcj,fcj->fc", corners - 0.5 * (lo + hi), n0) > 0)  # outward
    # every corner of a face lying in a side of the box has that side's normal, edges and
    # corners of the box included
    centroid = corners.mean(axis=1)
    on_hi = np.isclose(corners, hi, atol=1e-9).all(axis=1)
    on_lo = np.isclose(corners, lo, atol=1e-9).all(axis=1)
    side = np.where(on_hi, 1.0, 0.0) - np.where(on_lo, 1.0, 0.0)   # (f, 3): the face's side
    assert np.all(np.abs(side).sum(axis=1) == 1) and len(centroid) > 20
    np.testing.assert_allclose(n0, np.repeat(side[:, None, :], 3, axis=1), atol=1e-6)
    material = UsdShade.MaterialBindingAPI(meshes[0].GetPrim()).ComputeBoundMaterial()[0]
    shader = UsdShade.Shader(stage.GetPrimAtPath(material.GetPath().AppendChild("surface")))
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    assert shader.GetInput("opacity").Get() == pytest.approx(0.7)


def test_glb_morph_targets_reproduce_each_frame(traj, tmp_path):
    import trimesh

    from jellysim.geometry.creases import split_creases
    from jellysim.io.gltf import export_glb, glb_frame_positions, read_glb

    path = export_glb(traj, tmp_path / "run.glb")
    # the box's edges are creases: their vertices have one copy per face of the box (session
    # 14's trial: one averaged normal rounded them), the skin's own vertices first
    src, split = split_creases(traj.skin_positions(0), traj.skin.faces)
    assert len(src) > len(traj.skin.rest_vertices)
    np.testing.assert_array_equal(src[:len(traj.skin.rest_vertices)],
                                  np.arange(len(traj.skin.rest_vertices)))

    def skin(k):
        return traj.skin_positions(k)[src]

    doc, _ = read_glb(path)
    assert doc["asset"]["version"] == "2.0"
    prim = doc["meshes"][0]["primitives"][0]
    assert len(prim["targets"]) == traj.frame_count
    for k in range(traj.frame_count):
        np.testing.assert_allclose(glb_frame_positions(path, k), skin(k), atol=1e-5)
    # independent readers: pygltflib (morph targets, animation) and trimesh (base mesh)
    import pygltflib

    g = pygltflib.GLTF2().load_binary(str(path))
    blob = g.binary_blob()

    def acc(i):
        a = g.accessors[i]
        v = g.bufferViews[a.bufferView]
        width = {"SCALAR": 1, "VEC3": 3}[a.type]
        dtype = {pygltflib.FLOAT: np.float32, pygltflib.UNSIGNED_INT: np.uint32}[
            a.componentType]
        start = (v.byteOffset or 0) + (a.byteOffset or 0)
        return np.frombuffer(blob, dtype, a.count * width, start).reshape(a.count, width)

    p = g.meshes[0].primitives[0]
    base = acc(p.attributes.POSITION).astype(float)
    sampler = g.animations[0].samplers[0]
    times = acc(sampler.input).ravel()
    weights = acc(sampler.output).reshape(len(times), -1)
    np.testing.assert_allclose(times, traj.times - traj.times[0], atol=1e-6)
    for k in (1, traj.frame_count - 1):
        pos = base + sum(w * acc(t["POSITION"]) for w, t in zip(weights[k], p.targets))
        np.testing.assert_allclose(pos, skin(k), atol=1e-5)
    mesh = trimesh.load(path, force="mesh", process=False)
    assert len(mesh.faces) == len(traj.skin.faces)
    np.testing.assert_allclose(np.asarray(mesh.vertices), skin(0), atol=1e-5)
    # smooth normals (session 12's trial: none were written, so viewers shaded it flat): at
    # every frame the area-weighted mean of the faces' normals, from trimesh's face normals
    # and areas
    for k in (0, traj.frame_count - 1):
        n = acc(p.attributes.NORMAL).astype(float) + sum(
            w * acc(t["NORMAL"]) for w, t in zip(weights[k], p.targets))
        tm = trimesh.Trimesh(skin(k), split, process=False)
        ref = np.zeros((len(tm.vertices), 3))
        for c in range(3):
            np.add.at(ref, tm.faces[:, c], tm.face_normals * tm.area_faces[:, None])
        cos = np.einsum("ij,ij->i", n / np.linalg.norm(n, axis=1, keepdims=True),
                        ref / np.linalg.norm(ref, axis=1, keepdims=True))
        assert np.min(cos) > 0.9999
    # at rest, every vertex of the box's top face (its edges' included) faces straight up
    n0 = acc(p.attributes.NORMAL).astype(float)
    top = np.unique(split[np.all(np.isclose(skin(0)[split][:, :, 1],
                                            skin(0)[:, 1].max()), axis=1)])
    np.testing.assert_allclose(n0[top], np.tile([0.0, 1.0, 0.0], (len(top), 1)), atol=1e-6)


def test_pvd_series_every_frame_readable_by_meshio(run_dir, traj, tmp_path):
    import meshio

    from jellysim.io.vtk import export_pvd

    written = export_pvd(traj, tmp_path, "exp")
    for pvd in [run_dir / "body.pvd", run_dir / "skin.pvd", *written]:
        files = [d.get("file") for d in ET.parse(pvd).getroot().iter("DataSet")]
        assert len(files) == traj.frame_count
        for k, f in enumerate(files):
            mesh = meshio.read(pvd.parent / f)
            expected = traj.skin_positions(k) if "skin" in pvd.name else traj.positions[k]
            np.testing.assert_allclose(mesh.points, expected, atol=1e-12)
            kinds = {c.type for c in mesh.cells}
            if "skin" in pvd.name:
                assert kinds == {"triangle"}
            else:  # springs as lines, the tets' outer faces, the tets
                assert "line" in kinds and kinds <= {"line", "triangle", "tetra"}
                assert ("tetra" in kinds) == bool(len(traj.tets))


@pytest.mark.parametrize("fmt", ["obj", "ply"])
def test_mesh_sequence_readable(traj, tmp_path, fmt):
    import meshio

    from jellysim.io.meshseq import export_mesh_sequence

    paths = export_mesh_sequence(traj, tmp_path, fmt=fmt)
    assert len(paths) == traj.frame_count
    mesh = meshio.read(paths[-1])
    np.testing.assert_allclose(mesh.points, traj.skin_positions(-1), atol=1e-5)
    np.testing.assert_array_equal(mesh.cells_dict["triangle"], traj.skin.faces)
    if fmt == "obj":  # no UVs: each corner names its vertex and its vertex's normal, `a//a`
        normals = mesh.point_data["obj:vn"]
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
        lines = paths[-1].read_text().splitlines()
        corners = [c for line in lines if line.startswith("f ") for c in line.split()[1:]]
        assert len(corners) == 3 * len(traj.skin.faces)
        assert all(c.split("//")[0] == c.split("//")[1] for c in corners)


def test_diagnostics_match_hand_computed_values(traj):
    from jellysim.plot import diagnostics

    d = diagnostics(traj)
    k = 2
    x, v, m = traj.positions[k], traj.velocities[k], traj.masses
    assert d["kinetic"][k] == pytest.approx(0.5 * np.sum(m[:, None] * v * v), rel=1e-12)
    assert d["gravity"][k] == pytest.approx(9.8 * np.sum(m * x[:, 1]), rel=1e-12)
    assert d["com_height"][k] == pytest.approx(np.sum(m * x[:, 1]) / m.sum(), rel=1e-12)
    s = traj.springs
    L = np.linalg.norm(x[s[:, 1]] - x[s[:, 0]], axis=1)
    assert d["spring"][k] == pytest.approx(
        0.5 * np.sum(traj.stiffness * (L - traj.rest_length) ** 2), rel=1e-12)
    assert d["max_strain"][0] == pytest.approx(0.0, abs=1e-12)   # at rest


def test_diagnostics_of_many_springs_and_frames_stay_small(traj):
    """Scale trial (session 28): `export RUN -o x.csv` of a 10,948-point body's 181 frames
    peaked at 1.1 GB (every frame's spring vectors at once; now 0.31 GB, `inspect` 0.23).
    100 frames x 60,000 springs (144 MB a spring-vector array at once): the springs' energy
    and strain equal a frame-by-frame reference, and the peak traced memory stays under
    100 MB."""
    import dataclasses
    import tracemalloc

    from jellysim.plot import diagnostics

    rng = np.random.default_rng(1)
    n = traj.positions.shape[1]
    s = rng.integers(0, n, size=(60_000, 2))
    s = s[s[:, 0] != s[:, 1]]
    x = traj.positions[-1] + rng.normal(scale=1e-3, size=(100, n, 3))
    rest = np.linalg.norm(traj.positions[0][s[:, 1]] - traj.positions[0][s[:, 0]], axis=1)
    big = dataclasses.replace(traj, positions=x, velocities=np.zeros_like(x),
                              times=np.arange(100.0), steps=np.arange(100), springs=s,
                              rest_length=rest, stiffness=np.full(len(s), 50.0))
    tracemalloc.start()
    d = diagnostics(big)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 100e6, peak
    for k in (0, 57, 99):
        stretch = np.linalg.norm(x[k][s[:, 1]] - x[k][s[:, 0]], axis=1) - rest
        assert d["spring"][k] == pytest.approx(25.0 * np.sum(stretch**2), rel=1e-12)
        assert d["max_strain"][k] == pytest.approx(np.max(np.abs(stretch / rest)), rel=1e-12)


def test_cli_plot_png_and_svg(run_dir, tmp_path):
    r = CliRunner().invoke(cli, ["plot", str(run_dir / "trajectory.npz"), "-o",
                                 str(tmp_path / "e.png")])
    assert r.exit_code == 0, r.output
    import imageio.v3 as iio

    img = iio.imread(tmp_path / "e.png")
    assert img.shape[0] > 300 and img[..., :3].std() > 10
    r = CliRunner().invoke(cli, ["plot", str(run_dir / "trajectory.npz"), "-o",
                                 str(tmp_path / "e.svg")])
    assert r.exit_code == 0 and (tmp_path / "e.svg").read_text().lstrip().startswith("<?xml")
    # a sway is drawn signed, either side of its line (teacher trial: the plot had only the
    # distance moved, never negative): a body moved +2 / -3 / +1 mm along x is drawn so
    import dataclasses

    from jellysim.plot import diagnostics, sideways

    traj = load_trajectory(run_dir / "trajectory.npz")
    sway = np.zeros((traj.frame_count, 1, 3))
    sway[1:4, 0, 0] = [0.002, -0.003, 0.001]
    swayed = dataclasses.replace(traj, positions=np.repeat(traj.positions[:1], traj.frame_count,
                                                           axis=0) + sway)
    drawn = sideways(diagnostics(swayed))
    np.testing.assert_allclose(drawn["x - x(0)"][:4], [0.0, 0.002, -0.003, 0.001], atol=1e-12)
    assert np.all(drawn["z - z(0)"] == 0.0) and diagnostics(swayed)["travel"].min() >= 0.0


def test_cli_render_and_export_errors_are_clear(run_dir, tmp_path):
    t = str(run_dir / "trajectory.npz")
    r = CliRunner().invoke(cli, ["render", t, "-o", str(tmp_path / "x.avi")])
    assert r.exit_code == 2 and "unknown picture/video type" in r.output
    r = CliRunner().invoke(cli, ["render", str(tmp_path / "none.npz"), "-o", "x.mp4"])
    assert r.exit_code == 2 and "not found" in r.output
    r = CliRunner().invoke(cli, ["export", t, "-o", str(tmp_path / "x.fbx")])
    assert r.exit_code == 2 and "unknown export type" in r.output
    r = CliRunner().invoke(cli, ["export", t, "-o", str(tmp_path / "x.glb"), "--max-frames", "3"])
    assert r.exit_code == 0, r.output
    from jellysim.io.gltf import read_glb

    assert len(read_glb(tmp_path / "x.glb")[0]["meshes"][0]["primitives"][0]["targets"]) == 3


def test_cli_render_one_picture(run_dir, tmp_path):
    r = CliRunner().invoke(cli, ["render", str(run_dir / "trajectory.npz"), "-o",
                                 str(tmp_path / "last.png"), "--frame", "-1", "--size", "96x64",
                                 "--show", "all", "--color", "#33aa55", "--quiet"])
    assert r.exit_code == 0, r.output
    import imageio.v3 as iio

    img = iio.imread(tmp_path / "last.png")[..., :3].astype(int)
    assert img.shape == (64, 96, 3)
    greenish = (img[..., 1] > img[..., 0] + 20) & (img[..., 1] > img[..., 2])
    assert greenish.sum() > 20                   # the configured skin colour is drawn
    # the camera options reach the renderer: from above and zoomed in, the same frame shows
    # more of the skin (it fills more of the picture) and a different picture
    r = CliRunner().invoke(cli, ["render", str(run_dir / "trajectory.npz"), "-o",
                                 str(tmp_path / "top.png"), "--frame", "-1", "--size", "96x64",
                                 "--color", "#33aa55", "--quiet", "--elevation", "90",
                                 "--zoom", "2"])
    assert r.exit_code == 0, r.output
    top = iio.imread(tmp_path / "top.png")[..., :3].astype(int)
    green_top = (top[..., 1] > top[..., 0] + 20) & (top[..., 1] > top[..., 2])
    assert green_top.sum() > greenish.sum() and np.abs(top - img).mean() > 5


def _env_without_display():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    return env


@pytest.mark.parametrize("display", [None, ":99"], ids=["unset", "no-server"])
def test_view_without_display_fails_clearly(run_dir, display):
    """No DISPLAY, and (the reliability trial) a DISPLAY naming no X server, where VTK printed
    "bad X server connection" and the viewer exited 0 having shown nothing: both exit 2 with
    one line saying what to do."""
    env = _env_without_display()
    if display is not None:
        env["DISPLAY"] = display
    out = subprocess.run([sys.executable, "-m", "jellysim.cli", "view",
                          str(run_dir / "trajectory.npz")], capture_output=True, text=True,
                         env=env, timeout=120)
    assert out.returncode == 2, out.stderr
    assert "needs a display" in out.stderr and "Traceback" not in out.stderr


def test_viewer_screenshot_under_xvfb(run_dir, tmp_path):
    if shutil.which("xvfb-run") is None:
        pytest.skip("xvfb-run is not installed (apt-get install xvfb)")
    env = _env_without_display()
    env.pop("VTK_DEFAULT_OPENGL_WINDOW", None)
    shot = tmp_path / "view.png"
    out = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 800x600x24", sys.executable,
                          "-m", "jellysim.cli", "view", str(run_dir / "trajectory.npz"),
                          "--size", "320x240", "--screenshot", str(shot)],
                         capture_output=True, text=True, env=env, timeout=180)
    assert out.returncode == 0, out.stderr
    import imageio.v3 as iio

    img = iio.imread(shot)[..., :3]
    assert img.shape[:2] == (240, 320) and img.std() > 10


def test_live_view_of_a_scene_under_xvfb(tmp_path):
    """``jellysim view scene.toml`` opens the live window (30 frames simulated), draws the
    jello in red over the floor, saves the picture and closes."""
    if shutil.which("xvfb-run") is None:
        pytest.skip("xvfb-run is not installed (apt-get install xvfb)")
    env = _env_without_display()
    env.pop("VTK_DEFAULT_OPENGL_WINDOW", None)
    shot = tmp_path / "live.png"
    out = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 800x600x24", sys.executable,
                          "-m", "jellysim.cli", "view",
                          str(Path(__file__).parents[1] / "examples" / "gelatin_cube.toml"),
                          "--size", "320x240", "--screenshot", str(shot)],
                         capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    import imageio.v3 as iio

    img = iio.imread(shot)[..., :3].astype(int)
    red = (img[..., 0] > 120) & (img[..., 1] < 80) & (img[..., 2] < 90)
    assert img.shape[:2] == (240, 320) and red.mean() > 0.05  # the jello fills the view


def test_cli_run_with_video_and_usd(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.replace("steps = 280", "steps = 80"))
    r = CliRunner().invoke(cli, ["run", str(scene), "--out", str(tmp_path / "o"), "--quiet",
                                 "--no-vtu", "--video", str(tmp_path / "o.gif"),
                                 "--usd", str(tmp_path / "o.usdc")])
    assert r.exit_code == 0, r.output
    assert _read_video(tmp_path / "o.gif").shape[0] == 3
    from pxr import Usd

    stage = Usd.Stage.Open(str(tmp_path / "o.usdc"))
    assert stage.GetEndTimeCode() == 2


def test_cli_run_refuses_an_unwritable_video_folder_before_simulating(tmp_path):
    """A --video where no file can be created (a read-only or special file system: /proc,
    where even root cannot write) is refused before the run: no output folder is made."""
    if not Path("/proc").is_dir():
        pytest.skip("needs Linux's /proc (a folder no one can create files in)")
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE)
    r = CliRunner().invoke(cli, ["run", str(scene), "--out", str(tmp_path / "o"), "--quiet",
                                 "--video", "/proc/o.mp4"])
    assert r.exit_code != 0 and "cannot write /proc/o.mp4" in r.output
    assert not (tmp_path / "o").exists()


def test_cli_demo_reduced_frames_makes_a_valid_video(tmp_path):
    r = CliRunner().invoke(cli, ["demo", "--out", str(tmp_path), "--frames", "4",
                                 "--size", "128x72", "--quiet"])
    assert r.exit_code == 0, r.output
    video = _read_video(tmp_path / "demo.mp4")
    assert video.shape == (4, 72, 128, 3)
    assert video.reshape(4, -1).std(axis=1).min() > 10
    assert (tmp_path / "demo.usdc").stat().st_size > 0
    traj = load_trajectory(tmp_path / "demo" / "trajectory.npz")
    from jellysim.demo import demo_mesh

    mould = demo_mesh("jelly")[0]   # (its long fan edges subdivided: its own vertices first)
    assert traj.skin is not None and traj.skin.vertex_count >= len(mould)
    rest = traj.skin.rest_vertices[:len(mould)]
    assert np.allclose(rest - rest[0], mould - mould[0], atol=1e-12)


def test_diagnostics_count_the_tets_energy_of_a_physical_run(tmp_path):
    """A gelatin cube (FEM tets) dropped 2 cm, undamped: with the tets' Stable Neo-Hookean
    energy counted, the total energy never rises above its start (contact and friction only
    take energy out; before, the tets' energy was missing and the total seemed to grow)."""
    from jellysim.io.trajectory import load_trajectory
    from jellysim.plot import diagnostics
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    text = (Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml").read_text()
    text = text.replace("points = 1000", "points = 125").replace("steps = 180", "steps = 30")
    text = text.replace('\npreset = "gelatin"\n', '\npreset = "gelatin"\ndamping_ratio = 0.0\n')
    scene = Scene.from_text(text, name="gelatin_small.toml")
    res = run_scene(scene, tmp_path / "out", progress=False)
    traj = load_trajectory(res.trajectory)
    d = diagnostics(traj)
    from jellysim.physics.fem import elastic_energy

    k = int(np.argmax(d["tets"]))  # the run's own FEM model gives the same energy there
    assert d["tets"][k] == pytest.approx(
        elastic_energy(scene.build_model().fem, traj.positions[k]), rel=1e-9)
    print("total energy [J] first/max/last:", d["total"][0], d["total"].max(), d["total"][-1],
          "tets max", d["tets"].max())
    assert d["tets"][0] == pytest.approx(0.0, abs=1e-12) and d["tets"].max() > 0.0
    assert d["total"].max() <= d["total"][0] * (1 + 1e-3)
    assert d["total"][-1] < d["total"][0]  # the landing took some out


def test_the_plate_is_framed_whole(traj):
    """The demo's plate (1.6x the body's width) lies inside the picture: no near-white plate
    pixel on the border (session 9's trial: the cow's plate was cut off at the bottom); the
    camera frames the plate's rim as well as the body's motion."""
    from jellysim.render.offscreen import Renderer, RenderOptions

    img = Renderer(traj, RenderOptions(size=(320, 180), plate=True)).render(traj.frame_count - 1)
    # the plate's near-white: the one thing brighter than the background (7-11 levels) that
    # the floor fades into
    plate = np.all(img.astype(int) >= np.add((0xf4, 0xf1, 0xec), 4), axis=2)
    bare = Renderer(traj, RenderOptions(size=(320, 180))).render(traj.frame_count - 1)
    none = np.all(bare.astype(int) >= np.add((0xf4, 0xf1, 0xec), 4), axis=2).sum()
    # the plate is drawn (around the body on it, whose contact shadow darkens its middle:
    # 0.46 % of the picture, 0.53 % before the shadow was made continuous), nothing without it
    assert plate.sum() > 0.003 * plate.size and none < 0.1 * plate.sum()
    border = np.concatenate([plate[0], plate[-1], plate[:, 0], plate[:, -1]])
    assert not border.any()


def test_a_travelling_body_is_followed_not_shrunk_to_a_speck(traj):
    """A body that travels far (here the test run moved 30 body sizes along x per frame) is
    drawn at the size it has when it stays near: the automatic camera follows it across the
    floor (session 9's trial: a body slid 100 m rendered as a speck); a fixed camera, which
    frames the whole path, draws it far smaller.  The body is in the picture, off its border,
    at every frame, and the floor's tiles show it travelling."""
    import dataclasses

    from jellysim.render.offscreen import Renderer, RenderOptions

    size = float(np.max(np.ptp(traj.positions[0], axis=0)))
    shift = np.zeros((traj.frame_count, 1, 3))
    shift[:, 0, 0] = 30.0 * size * np.arange(traj.frame_count)
    moved = dataclasses.replace(traj, positions=traj.positions + shift)

    def body_pixels(t, camera, f):
        img = Renderer(t, RenderOptions(size=(160, 96), camera=camera)).render(f).astype(int)
        red = (img[..., 0] > img[..., 1] + 60) & (img[..., 0] > img[..., 2] + 40)
        return red

    still = body_pixels(traj, "auto", traj.frame_count - 1).sum()
    assert still > 100
    for f in (0, traj.frame_count - 1):
        red = body_pixels(moved, "auto", f)
        assert 0.5 * still < red.sum() < 2.0 * still, (f, red.sum(), still)
        assert not np.concatenate([red[0], red[-1], red[:, 0], red[:, -1]]).any()
    assert body_pixels(moved, "fixed", traj.frame_count - 1).sum() < 0.1 * still
    # the floor's tiles stay on the world, so the following camera's picture shows the
    # travel: the near floor (the image's bottom rows, under the body) changes between frames
    slow = shift.copy()
    slow[:, 0, 0] *= 0.3 / 30.0   # a third of a tile per frame (whole tiles would look alike)
    r = Renderer(dataclasses.replace(traj, positions=traj.positions + slow),
                 RenderOptions(size=(160, 96), camera="follow"))
    a, b = (r.render(f)[-12:].astype(int) for f in (1, 2))
    assert np.abs(a - b).mean() > 2.0


def test_a_python_run_of_a_tet_body_is_drawn_and_exported_by_its_outer_faces(tmp_path):
    """Session 10's trial: a run recorded from Python on a grid box (no skin, no surface
    triangles) could not be exported ("no surface triangles").  Its trajectory now carries
    the tets' outer faces: a closed surface (every edge shared by two faces) oriented outward,
    whose enclosed volume (divergence theorem) is the tets' total volume."""
    import jellysim as js
    from jellysim.geometry.tetra import tet_signed_volumes
    from jellysim.io.trajectory import Recorder
    from jellysim.io.usd import surface_of

    model = js.physical_model(js.Body.box(points=64), js.material("gelatin"))
    sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    rec = Recorder(model)
    rec.record(sim.state)
    sim.advance(3)
    rec.record(sim.state)
    t = load_trajectory(rec.save(tmp_path / "py" / "trajectory.npz"))
    frames, faces = surface_of(t)
    assert len(faces) and np.array_equal(faces, t.triangles)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    assert np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2)
    for f in (0, 1):
        p = frames[f][faces]
        enclosed = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
        tets = np.abs(tet_signed_volumes(t.positions[f], model.fem.tets)).sum()
        assert enclosed == pytest.approx(tets, rel=1e-9) and enclosed > 0


def test_a_tet_run_writes_its_tets_and_their_volume_ratio_for_paraview(tmp_path):
    """Session 10's trial: the ParaView frames held only springs.  A run of a tet body now
    writes its tets as VTK tetrahedra with the cell field volume_ratio J = V / V0: 1 at the
    first frame (the rest shape, exact), and at a later frame the same as computed here from
    the trajectory's positions (the tets alone: the trial found the springs' NaN cells painted
    over them), with the body's total volume conserved within the material's
    compressibility (nu = 0.48: a few per cent)."""
    import meshio

    from jellysim.geometry.tetra import tet_signed_volumes

    text = ('[material]\npreset = "gelatin"\n[body]\npoints = 64\n[integrator]\nsteps = 12\n'
            '[output]\nevery = 6\n')
    run_scene(Scene.from_text(text, name="s.toml"), tmp_path, progress=False)
    traj = load_trajectory(tmp_path)
    files = [d.get("file") for d in ET.parse(tmp_path / "body.pvd").getroot().iter("DataSet")]
    assert len(files) == traj.frame_count == 3
    for k, f in enumerate(files):
        mesh = meshio.read(tmp_path / f)
        blocks = [c.type for c in mesh.cells]
        tets = mesh.cells[blocks.index("tetra")].data
        j = mesh.cell_data["volume_ratio"][blocks.index("tetra")]
        rest = tet_signed_volumes(traj.rest_positions, tets)
        v = tet_signed_volumes(traj.positions[k], tets)
        assert np.all(rest > 0)
        np.testing.assert_allclose(j, v / rest, rtol=1e-12)
        if k == 0:
            assert np.all(j == 1.0)
        assert blocks == ["tetra"]   # its tets alone: no NaN cells painted over them
        assert abs(v.sum() / rest.sum() - 1.0) < 0.05


@pytest.mark.parametrize("size", [(960, 540), (540, 960), (400, 400)])
@pytest.mark.parametrize("azimuth,elevation", [(None, None), (80.0, 10.0), (None, 90.0)])
def test_the_framing_keeps_a_box_corners_inside_the_margin_and_is_tight(size, azimuth,
                                                                           elevation):
    """Session 10's trial: the README's gelatin cube had its front bottom corner cut off in 87
    of 91 frames (the bounding sphere was framed at 0.85 of its size).  Every corner of the
    motion's box now projects inside 90 % of each half field of view, and the framing is
    tight: some corner reaches that margin (within 1 %)."""
    from jellysim.render.camera import frame_motion, view_direction

    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.1, 0.1])
    corners = np.array([[a[0], b[1], c[2]] for a in (lo, hi) for b in (lo, hi) for c in (lo, hi)])
    cam = frame_motion(corners, size, direction=view_direction(azimuth, elevation))
    depth, used = _in_view(cam, corners, size)
    assert np.all(depth > 0) and used.max() <= 0.9 + 1e-9 and used.max() > 0.89


def test_overwriting_an_export_folder_keeps_files_that_are_not_its_frames(tmp_path):
    """Session 10's trial: `export --sequence obj DIR --overwrite` deleted the user's own
    DIR/skin_final.obj (the glob was skin_*.obj); only numbered frames are replaced now."""
    from jellysim.cli import cli as main

    out = tmp_path / "objs"
    run = tmp_path / "run"
    run_scene(Scene.from_text(SCENE, name="s.toml"), run, progress=False, vtu=False)
    assert CliRunner().invoke(main, ["export", str(run), "--sequence", "obj", "-o",
                                     str(out)]).exit_code == 0
    frames = sorted(out.glob("skin_*.obj"))
    (out / "skin_final.obj").write_text("# mine\n")
    r = CliRunner().invoke(main, ["export", str(run), "--sequence", "obj", "-o", str(out),
                                  "--overwrite"])
    assert r.exit_code == 0, r.output
    assert (out / "skin_final.obj").read_text() == "# mine\n"
    assert sorted(out.glob("skin_[0-9]*.obj")) == frames


def test_a_refused_render_or_recording_deletes_and_replaces_nothing(run_dir, traj, tmp_path):
    """Session 11's hostile trial: `render RUN -o pngs --overwrite --start 50` deleted the old
    PNG frames, then refused (no frame after 50 s); `Recorder.save` silently replaced a `jellysim
    run`'s trajectory.npz (its checkpoint and ParaView frames then belonged to another run);
    a Recorder saved before any record() made a file render and export crashed on.  Each is
    refused now before anything is touched."""
    from jellysim.errors import OutputError
    from jellysim.io.trajectory import Recorder
    from jellysim.simulator import Simulator

    pngs = tmp_path / "pngs"
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(pngs), "--size", "48x32",
                                 "--every", "3"])
    assert r.exit_code == 0, r.output
    before = {p.name: p.read_bytes() for p in pngs.iterdir()}
    for bad in (["--start", "50"], ["--frame", "99"], ["--background", "nocolour"]):
        r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(pngs), "--overwrite",
                                     *bad])
        assert r.exit_code != 0
        assert {p.name: p.read_bytes() for p in pngs.iterdir()} == before, bad
    model = Scene.from_text(SCENE, name="s.toml").build_model()
    rec = Recorder(model)
    with pytest.raises(OutputError, match="no frame recorded"):
        rec.save(tmp_path / "empty.npz")
    assert not (tmp_path / "empty.npz").exists()
    other = Scene.from_text(SCENE.replace("points = 120", "points = 50"),
                            name="t.toml").build_model()
    with pytest.raises(ValueError, match="this recorder's model has 120 points"):
        rec.record(Simulator(other, dt=1e-3).state)
    rec.record(Simulator(model, dt=1e-3).state)
    run_npz = run_dir / "trajectory.npz"
    kept = run_npz.read_bytes()
    with pytest.raises(OutputError, match=r"is in a jellysim run's folder \(.* beside it"):
        rec.save(run_npz)
    assert run_npz.read_bytes() == kept
    live = tmp_path / "live"  # a folder a live run (this process, here) is writing
    live.mkdir()
    (live / ".jellysim.lock").write_text(f"{os.getpid()} {__import__('socket').gethostname()}\n")
    with pytest.raises(OutputError, match=r"another jellysim run \(process"):
        rec.save(live / "trajectory.npz", overwrite=True)
    mine = tmp_path / "mine" / "trajectory.npz"   # a recording of one's own: saved again
    mine.parent.mkdir()
    rec.save(mine)
    rec.record(Simulator(model, dt=1e-3).state)
    assert load_trajectory(rec.save(mine)).frame_count == 2


def test_python_saves_and_exports_refuse_to_replace_what_is_not_theirs(traj, tmp_path):
    """Session 20's API trial: ``Recorder.save("notes.txt")`` overwrote the notes with a zip,
    ``save("out.glb")`` replaced a 1.3 MB export with a 6 kB npz, and the Python exports
    replaced files silently (a second ``export_mesh_sequence`` into the same folder left the
    first run's extra frames mixed with the new ones), where the CLI refuses.  Now: a
    recording must be named ``.npz``; a file that is not a recording is kept unless
    ``overwrite=True``; the exports refuse an existing output unless ``overwrite=True``, and
    a sequence overwritten by a shorter run holds exactly the new frames."""
    import dataclasses

    from jellysim.errors import OutputError
    from jellysim.io.gltf import export_glb
    from jellysim.io.meshseq import export_mesh_sequence
    from jellysim.io.trajectory import Recorder
    from jellysim.io.usd import export_usd
    from jellysim.simulator import Simulator

    model = Scene.from_text(SCENE, name="s.toml").build_model()
    rec = Recorder(model)
    rec.record(Simulator(model, dt=1e-3).state)
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    with pytest.raises(OutputError, match=r"notes.txt: a recording is saved as \.npz.*notes\.npz"):
        rec.save(notes)
    assert notes.read_text() == "my notes\n"
    foreign = tmp_path / "data.npz"     # someone's own arrays, not a recording
    np.savez(foreign, a=np.arange(3))
    kept = foreign.read_bytes()
    with pytest.raises(OutputError, match="not a jellysim recording: it would be lost"):
        rec.save(foreign)
    assert foreign.read_bytes() == kept
    assert load_trajectory(rec.save(foreign, overwrite=True)).frame_count == 1

    frames = tmp_path / "objs"
    first = export_mesh_sequence(traj, frames, fmt="obj")
    assert len(first) == traj.frame_count >= 4
    before = {p.name: p.read_bytes() for p in frames.iterdir()}
    short = dataclasses.replace(traj, positions=traj.positions[:3],
                                velocities=traj.velocities[:3], times=traj.times[:3],
                                steps=traj.steps[:3])
    with pytest.raises(OutputError, match=r"already holds .* pass overwrite=True"):
        export_mesh_sequence(short, frames, fmt="obj")
    assert {p.name: p.read_bytes() for p in frames.iterdir()} == before
    export_mesh_sequence(short, frames, fmt="obj", overwrite=True)
    assert sorted(p.name for p in frames.iterdir()) == [f"skin_{k:05d}.obj" for k in range(3)]
    import meshio
    assert np.allclose(meshio.read(frames / "skin_00002.obj").points, traj.skin_positions(2),
                       rtol=0, atol=1e-12)  # the new run's frame 2
    for export, name in ((export_usd, "run.usdc"), (export_glb, "run.glb")):
        path = export(traj, tmp_path / name)
        kept = path.read_bytes()
        with pytest.raises(OutputError, match=r"exists; pass overwrite=True"):
            export(short, path)
        assert path.read_bytes() == kept
        assert export(short, path, overwrite=True).read_bytes() != kept


def test_obstacles_are_drawn_and_a_run_without_ground_has_no_floor(tmp_path):
    """Session 10's trial: a body resting on a [[obstacle]] sphere seemed to float (the
    sphere was not drawn), and a run with the ground disabled still showed a floor under the
    falling body.  The obstacle now covers the pixels its silhouette projects to (its grey,
    distinct from the floor's), and a groundless run has no floor pixel."""
    from jellysim.render.offscreen import Renderer, RenderOptions

    text = SCENE.replace("steps = 280", "steps = 40").replace("lower = [0.0, 0.25, 0.0]",
                                                              "lower = [0.0, 0.45, 0.0]")
    text = text.replace("upper = [0.4, 0.55, 0.4]", "upper = [0.4, 0.75, 0.4]")
    text += '\n[[obstacle]]\nkind = "sphere"\ncenter = [0.2, 0.2, 0.2]\nradius = 0.2\n'
    for ground, out in (("", tmp_path / "a"), ("\n[ground]\nenabled = false\n", tmp_path / "b")):
        run_scene(Scene.from_text(text + ground, name="s.toml"), out, progress=False, vtu=False)
        t = load_trajectory(out)
        img = Renderer(t, RenderOptions(size=(160, 96))).render(0).astype(int)
        grey = (np.abs(img - [0x9d, 0xa3, 0xa8]).max(axis=2) < 40) & (
            np.abs(img[..., 0] - img[..., 2]) < 20)
        from jellysim.render.floor import TILE_DARK, TILE_LIGHT

        tiles = (np.abs(img - TILE_LIGHT).max(axis=2) < 6) | (
            np.abs(img - TILE_DARK).max(axis=2) < 6)
        assert grey.sum() > 0.02 * grey.size            # the sphere is drawn
        # the floor's tiles fill the lower part of the view; without a ground, none show
        assert (tiles.mean() > 0.2) == (not ground), tiles.mean()


def test_a_transparent_background_gives_the_jello_alone_for_slides(run_dir, tmp_path):
    """Session 10's trial: no way to drop the jello onto a slide.  `render --background
    transparent --no-floor` writes a PNG whose alpha is 0 where nothing is drawn (the corners)
    and positive on the body (its red pixels); a video, which has no alpha, is refused."""
    import imageio.v3 as iio

    out = tmp_path / "alone.png"
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(out), "--frame", "-1",
                                 "--size", "160x96", "--background", "transparent",
                                 "--no-floor", "--quiet"])
    assert r.exit_code == 0, r.output
    img = np.asarray(iio.imread(out))
    assert img.shape == (96, 160, 4)
    assert img[0, 0, 3] == img[-1, -1, 3] == 0
    red = img[..., 0].astype(int) > img[..., 1].astype(int) + 60    # the jello's colour
    assert red.sum() > 100 and np.all(img[red, 3] > 0)
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(tmp_path / "v.mp4"),
                                 "--background", "transparent"])
    assert r.exit_code != 0 and "no alpha channel" in r.output


def test_cli_demo_takes_a_mesh_of_ones_own(tmp_path):
    """Session 10's trial: no one-liner from "my mesh" to a jiggling video.  `jellysim demo
    --mesh torus.obj` drops it (10 cm, dessert gelatin) onto the plate: a video of the asked
    frames, the body 10 cm across and 1 cm above the plate at the start, its skin the mesh;
    --mesh with --scene cow is refused."""
    mesh = Path(__file__).parent / "data" / "torus.obj"
    r = CliRunner().invoke(cli, ["demo", "--mesh", str(mesh), "--out", str(tmp_path),
                                 "--frames", "3", "--points", "200", "--size", "64x48",
                                 "--no-usd", "--quiet"])
    assert r.exit_code == 0, r.output
    assert _read_video(tmp_path / "demo_torus.mp4").shape == (3, 48, 64, 3)
    traj = load_trajectory(tmp_path / "demo_torus")
    skin0 = traj.skin_positions(0)
    assert np.ptp(skin0, axis=0).max() == pytest.approx(0.1, rel=1e-9)
    assert skin0[:, 1].min() == pytest.approx(0.01, abs=1e-9)
    r = CliRunner().invoke(cli, ["demo", "--mesh", str(mesh), "--scene", "cow", "--out",
                                 str(tmp_path / "b")])
    assert r.exit_code != 0 and "give one of them" in r.output
    # a mesh that cannot be read leaves an earlier demo of that name untouched (the review:
    # --overwrite deleted it before reading the mesh)
    bad = tmp_path / "torus2.obj"
    bad.write_text("garbage\n")
    (tmp_path / "demo_torus2.mp4").write_bytes(b"keep")
    r = CliRunner().invoke(cli, ["demo", "--mesh", str(bad), "--out", str(tmp_path),
                                 "--overwrite", "--quiet"])
    assert r.exit_code != 0 and (tmp_path / "demo_torus2.mp4").read_bytes() == b"keep"
    assert not (tmp_path / "demo_torus2").exists()


def test_render_a_time_window_of_a_run(run_dir, tmp_path):
    """Session 10's trial: only one frame or every N-th could be rendered.  --start/--end
    (simulated seconds) render the frames in that window, at real-time speed, and a window
    with no frame is an error naming the run's span."""
    traj = load_trajectory(run_dir)
    t = traj.times
    want = np.flatnonzero((t >= t[2]) & (t <= t[4]))
    out = tmp_path / "part"
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(out), "--start",
                                 repr(float(t[2])), "--end", repr(float(t[4])), "--size",
                                 "64x48", "--quiet"])
    assert r.exit_code == 0, r.output
    assert len(list(out.glob("frame_*.png"))) == len(want) == 3
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(tmp_path / "x.png"),
                                 "--start", "99"])
    assert r.exit_code != 0 and "select no frame" in r.output
    r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(tmp_path / "y.png"),
                                 "--start", "0.2", "--end", "0.1"])
    assert r.exit_code != 0 and "is after --end" in r.output


def test_a_python_run_of_a_mesh_body_carries_its_smooth_surface(tmp_path):
    """Session 10's trial: a Python-recorded mould rendered as its jagged marching tets; the
    Recorder now carries the surface the body was built from (bound to its tets), so the
    saved trajectory's skin at rest is that surface, vertex for vertex."""
    import jellysim as js
    from jellysim.geometry.shapes import jelly_mould
    from jellysim.io.trajectory import Recorder

    body = js.Body.from_mesh(jelly_mould(), size=0.05, points=300, base=(0, 0, 0))
    sim = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60,
                       ground=js.GroundParams(model="contact"))
    rec = Recorder(sim.model)
    rec.record(sim.state)
    t = load_trajectory(rec.save(tmp_path / "t.npz"))
    assert t.skin is not None and t.skin.vertex_count >= len(body.skin_vertices)
    assert np.array_equal(t.skin.rest_vertices[:len(body.skin_vertices)], body.skin_vertices)
    np.testing.assert_allclose(t.skin_positions(0)[:len(body.skin_vertices)],
                               body.skin_vertices, atol=1e-9)


def test_plot_refuses_to_replace_a_file_unless_overwrite(run_dir, tmp_path):
    """Session 10's trial: `jellysim plot -o existing.png` replaced it silently, where render
    and export refuse; now it refuses too, and --overwrite replaces it."""
    out = tmp_path / "e.png"
    out.write_bytes(b"mine")
    r = CliRunner().invoke(cli, ["plot", str(run_dir), "-o", str(out)])
    assert r.exit_code != 0 and "--overwrite" in r.output and out.read_bytes() == b"mine"
    r = CliRunner().invoke(cli, ["plot", str(run_dir), "-o", str(out), "--overwrite"])
    assert r.exit_code == 0 and out.read_bytes()[:4] == b"\x89PNG"


def test_runs_rendered_side_by_side_share_one_camera(run_dir, tmp_path):
    """Session 10's trial: "soft vs firm" had to be assembled by hand.  `render A B` draws the
    runs side by side, one camera for both (one scale): the same run twice gives two
    identical halves; beside a run 2 m away the first is drawn smaller than alone (the camera
    frames both motions); a following camera is refused (the panels would not share a
    scale)."""
    import imageio.v3 as iio

    out = tmp_path / "pair.png"
    r = CliRunner().invoke(cli, ["render", str(run_dir), str(run_dir), "-o", str(out),
                                 "--frame", "2", "--size", "96x64", "--quiet"])
    assert r.exit_code == 0, r.output
    img = np.asarray(iio.imread(out))
    assert img.shape == (64, 192, 3)
    assert np.array_equal(img[:, :96], img[:, 96:])
    red = img[..., 0].astype(int) > img[..., 1].astype(int) + 60
    assert red[:, :96].sum() > 50
    r = CliRunner().invoke(cli, ["render", str(run_dir), str(run_dir), "-o",
                                 str(tmp_path / "f.png"), "--camera", "follow"])
    assert r.exit_code != 0 and "one fixed camera" in r.output
    # one scale: beside a run that travels far, the first run is drawn smaller than alone
    import dataclasses

    from jellysim.render import RenderOptions, render_trajectory

    traj = load_trajectory(run_dir)
    far = dataclasses.replace(traj, positions=traj.positions + [2.0, 0.0, 0.0])
    alone = np.asarray(iio.imread(render_trajectory(traj, tmp_path / "a.png", RenderOptions(
        size=(96, 64)), frames=[2])))
    pair = np.asarray(iio.imread(render_trajectory(traj, tmp_path / "b.png", RenderOptions(
        size=(96, 64)), frames=[2], beside=[far])))

    def reds(im):
        return int((im[..., 0].astype(int) > im[..., 1].astype(int) + 60).sum())

    assert pair.shape == (64, 192, 3) and reds(pair[:, 96:]) > 0
    assert reds(pair[:, :96]) < 0.5 * reds(alone)


def test_a_python_recording_draws_the_floor_where_its_ground_was(tmp_path):
    """Session 12's artist trial: a recording of a Simulator without a ground was drawn with
    a floor at y = 0 that hid the falling body.  ``Recorder.record(sim)`` keeps the ground (its
    height, or none), and a recording of states alone draws no floor."""
    import jellysim as js
    from jellysim.io.trajectory import Recorder, load_trajectory
    from jellysim.render.offscreen import ground_height

    model = js.physical_model(js.Body.box(points=27), js.material("gelatin"))
    for ground, want in ((None, None), (js.GroundParams(model="contact", height=-0.05), -0.05),
                         ("states", None)):
        sim = js.Simulator(model, dt=1 / 60, ground=None if ground == "states" else ground)
        rec = Recorder(model)
        for _ in range(3):
            rec.record(sim.state if ground == "states" else sim)
            sim.advance(1)
        traj = load_trajectory(rec.save(tmp_path / f"{want}_{ground is None}.npz"))
        assert ground_height(traj) == want


def test_usd_time_codes_are_the_simulated_times(tmp_path, traj):
    """Session 12's artist trial: a run whose last frame interval is shorter (50 steps saved
    every 7) put its last USD sample 0.1 s late, and ``export --fps 24`` played a 60 frames/s
    run in slow motion (a time code per frame at 24 per second).  Time codes are now the
    frames' simulated times x the stage's rate."""
    import dataclasses

    from pxr import Usd, UsdGeom

    from jellysim.io.usd import export_usd

    n = traj.frame_count
    times = np.minimum(np.arange(n) * 7 / 60.0, (7 * (n - 1) - 3) / 60.0)  # last one shorter
    uneven = dataclasses.replace(traj, times=traj.times[0] + times)
    for fps in (None, 24.0):
        stage = Usd.Stage.Open(str(export_usd(uneven, tmp_path / f"u{fps}.usda", fps=fps)))
        rate = stage.GetTimeCodesPerSecond()
        samples = UsdGeom.Mesh(stage.GetPrimAtPath("/jello/skin")).GetPointsAttr() \
            .GetTimeSamples()
        assert len(samples) == n
        assert np.allclose(np.array(samples) / rate, times, atol=1e-9)
        assert stage.GetEndTimeCode() / rate == pytest.approx(times[-1], abs=1e-9)
        # double-sided, as the glTF export says it is (an open skin shows its inside)
        assert UsdGeom.Mesh(stage.GetPrimAtPath("/jello/skin")).GetDoubleSidedAttr().Get()


def test_render_can_draw_the_demos_plate(run_dir, tmp_path):
    """Session 12's artist trial: re-rendering the demo's run lost its plate; `render
    --plate` draws it (a white disc under the body: many more near-white pixels)."""
    import imageio.v2 as iio2

    white = []
    for extra in ([], ["--plate"]):
        out = tmp_path / f"p{len(extra)}.png"
        r = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(out), "--frame", "-1",
                                     "--size", "160x90", *extra])
        assert r.exit_code == 0, r.output
        img = iio2.imread(out)[..., :3].astype(int)
        white.append(int(np.sum(img.min(axis=2) > 215)))  # the plate: (239, 235, 224) lit
    assert white[1] > white[0] + 200


def test_review_edge_cases_of_the_exports_and_the_skin(tmp_path, traj):
    """Session 12's review: frames sharing a time collapsed into one USD sample; a vertex of
    no face got a zero glb normal (glTF wants unit ones); a skin far larger than its body made
    trimesh's subdivision raise 'max_iter exceeded'."""
    import dataclasses

    import trimesh
    from pxr import Usd, UsdGeom

    import jellysim as js
    from jellysim.io.gltf import _vertex_normals
    from jellysim.io.usd import export_usd
    from jellysim.skin import bind_body_skin

    times = traj.times.copy()
    times[2] = times[1]                       # a state recorded twice
    stage = Usd.Stage.Open(str(export_usd(dataclasses.replace(traj, times=times),
                                          tmp_path / "twice.usda")))
    samples = UsdGeom.Mesh(stage.GetPrimAtPath("/jello/skin")).GetPointsAttr().GetTimeSamples()
    assert len(samples) == traj.frame_count          # none lost, and still in real time:
    rate = stage.GetTimeCodesPerSecond()
    assert samples[-1] / rate == pytest.approx(times[-1] - times[0], abs=1e-6)
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]])      # vertex 3: no face
    assert np.allclose(np.linalg.norm(_vertex_normals(v, np.array([[0, 1, 2]])), axis=1), 1.0)
    cube = trimesh.creation.box(extents=[0.05] * 3)
    body = js.Body.from_mesh((cube.vertices, cube.faces), size=None, points=1000)
    needle = trimesh.creation.cylinder(radius=0.0005, height=30.0, sections=3)
    skin = bind_body_skin(body, needle.vertices, needle.faces)   # (extrapolated: warned)
    assert skin.vertex_count >= len(needle.vertices)


def test_a_gif_asked_faster_than_it_can_play_is_said(tmp_path, traj):
    """Session 12's review: `--fps 100` for a GIF silently played at 50 frames/s (delays are
    whole hundredths, at least 2); now said (30 frames/s plays at 33.3, said too); 25 frames/s
    plays as asked, silently."""
    import warnings

    from jellysim.render import RenderOptions, render_trajectory

    with pytest.warns(UserWarning, match=r"fps = 100 plays at 50 frames/s"):
        render_trajectory(traj, tmp_path / "f.gif", RenderOptions(size=SIZE), fps=100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        render_trajectory(traj, tmp_path / "s.gif", RenderOptions(size=SIZE), fps=25.0)


def test_the_floor_and_shadow_lie_strictly_under_a_resting_skin(traj):
    """Skin vertices that dip below the ground are lifted exactly onto it (Skin.deform), so a
    floor drawn at the ground's height z-fought them: a saw-toothed contact patch through the
    translucent jello (session 14's trial).  The floor and its contact shadow are now drawn
    below every skin point of every frame."""
    from jellysim.render.offscreen import Renderer, RenderOptions, ground_height

    r = Renderer(traj, RenderOptions(size=SIZE))
    gh = ground_height(traj)
    floor = float(r.floor.points[:, 1].max())
    shadow = float(r.shadow.points[:, 1].max())
    lowest = min(float(np.asarray(r._surface_frames(f))[:, 1].min())
                 for f in range(traj.frame_count))
    assert lowest == pytest.approx(gh, abs=1e-12)  # the resting skin touches the ground
    assert floor == shadow < lowest  # (the shadow drawn over the floor by a polygon offset)
    # the demo's plate is painted on the floor (a plate standing on the ground showed a
    # resting body sunk 0.4 % into it, with light patches where its skin crossed the top):
    # the floor and shadow stay where they were, the plate under the body's last position
    r = Renderer(traj, RenderOptions(size=SIZE, plate=True))
    assert float(r.floor.points[:, 1].max()) == float(r.shadow.points[:, 1].max()) < lowest
    px, pz, radius = r._floor.plate
    last = np.asarray(traj.positions[-1])
    assert np.hypot(px - last[:, 0].mean(), pz - last[:, 2].mean()) < 0.5 * radius
    assert set(r.plotter.actors) >= {"floor", "shadow"} and "plate" not in r.plotter.actors


def test_the_floor_reads_as_a_floor_with_a_horizon_and_a_contact_shadow(traj):
    """Session 20's trial: the default floor was one flat colour filling the frame, the
    background's (nothing showed where the jello stood, and `--background` changed nothing).
    The floor now shows two tile colours below the body, fades into the background colour at
    a horizon (the top row is the background, whichever it is), and a resting body darkens the
    floor just around its footprint and nowhere else; lifted two body sizes up, its shadow
    all but goes."""
    import dataclasses

    from jellysim.render.floor import SHADOW_DARKEST, TILE_DARK, TILE_LIGHT
    from jellysim.render.offscreen import Renderer, RenderOptions

    last = traj.frame_count - 1
    for bg in ("#f4f1ec", "#203040"):
        img = Renderer(traj, RenderOptions(size=(320, 180), background=bg)).render(last)
        img = img.astype(int)
        want = np.array([int(bg[i:i + 2], 16) for i in (1, 3, 5)])
        assert np.abs(img[0] - want).max() <= 2          # above the horizon: the background
        for tile in (TILE_LIGHT, TILE_DARK):              # a checker below it, not a flat tint
            assert (np.abs(img - tile).max(axis=2) <= 3).mean() > 0.05
    opts = RenderOptions(size=(320, 180), antialias=False)  # (pixel for pixel: no smoothing)
    lit = Renderer(traj, dataclasses.replace(opts, shadow=False)).render(last).astype(int)
    shaded = Renderer(traj, opts).render(last).astype(int)
    darker = (lit - shaded).min(axis=2) >= 4
    red = (lit[..., 0] > lit[..., 1] + 60) & (lit[..., 0] > lit[..., 2] + 40)
    assert (shaded - lit)[~red].max() <= 1                # a shadow only darkens the floor
    assert darker.mean() > 0.003
    rows, cols = np.nonzero(red)
    h, w = np.ptp(rows) + 1, np.ptp(cols) + 1
    r2, c2 = np.nonzero(darker)                           # all of it at the body's foot
    assert r2.min() >= rows.min() + 0.3 * h and r2.max() <= rows.max() + 0.3 * h
    assert c2.min() >= cols.min() - 0.3 * w and c2.max() <= cols.max() + 0.3 * w
    # the shadow's strength: full under a body on the floor, faint under one held aloft
    floor = Renderer(traj, opts)._floor
    x = np.asarray(traj.positions[last], dtype=np.float64)
    size = float(np.max(np.ptp(x, axis=0)))
    assert floor.shade(x).min() == pytest.approx(SHADOW_DARKEST, abs=0.02)
    assert floor.shade(x + [0.0, 2.0 * size, 0.0]).min() > 0.9


def test_the_contact_shadow_does_not_pop_when_the_body_moves_a_micrometre(traj):
    """The artist trial: the demo's jello at rest made its shadow pop for single frames
    (frames 154, 166, 170, 178: ~2,000 floor pixels, up to 41 of 255), its points moving by
    micrometres.  The shadow's grid followed the footprint's centre by fractions of a cell and
    each point was rounded to one cell, so a micrometre could flip a cell (0.165 of the
    shade).  The grid is now fixed to the floor and each point spreads over its four nearest
    cells by bilinear weights: the shade is continuous in the points' positions, so shifts of
    a thousandth of a cell, anywhere across a cell, change it by about that much, and a shift
    by a whole cell moves the shadow with the body."""
    from jellysim.render.offscreen import Renderer, RenderOptions

    last = traj.frame_count - 1
    floor = Renderer(traj, RenderOptions(size=(320, 180)))._floor
    x = np.asarray(traj.positions[last], dtype=np.float64)
    cell = floor.cell
    rng = np.random.default_rng(5)

    def field(points):  # the shade as a function of the floor's (x, z) [m]
        from scipy.interpolate import RegularGridInterpolator

        shade = floor.shade(points)
        xz = np.asarray(floor.shadow.points)[:, [0, 2]]
        xs, zs = np.unique(xz[:, 0]), np.unique(xz[:, 1])
        grid = np.empty((len(xs), len(zs)))
        grid[np.searchsorted(xs, xz[:, 0]), np.searchsorted(zs, xz[:, 1])] = shade
        return RegularGridInterpolator((xs, zs), grid, bounds_error=False, fill_value=1.0)

    worst = 0.0
    for k in range(40):  # the body across a whole cell; each point nudged by ~cell / 1000
        base = x + [k * cell / 40.0, 0.0, 0.37 * k * cell / 40.0]
        nudged = base + rng.normal(0.0, cell / 1000.0, x.shape) * [1.0, 0.0, 1.0]
        before = field(base)
        probe = np.asarray(floor.shadow.points)[:, [0, 2]]
        worst = max(worst, float(np.abs(field(nudged)(probe) - before(probe)).max()))
    print(f"largest change of the shade: {worst:.2e}")
    assert worst < 0.005  # (rounded to a cell: 0.022 here)
    moved = field(x + [cell, 0.0, 0.0])
    probe = np.asarray(floor.shadow.points)[:, [0, 2]]
    np.testing.assert_allclose(moved(probe + [cell, 0.0]), field(x)(probe), atol=1e-6)


def test_an_fps_other_than_the_runs_says_how_fast_it_plays(traj, tmp_path):
    """`render --fps N` shows each saved frame once at N frames/s: for a run saved every
    0.04 s (25 frames/s), fps = 50 plays at 2x real time and is said (session 14's trial took
    `--fps 24` on a 30 frames/s run for a resampling and got 0.8x, unsaid); the run's own rate
    says nothing."""
    from jellysim.render import RenderOptions, render_trajectory

    step = float(np.median(np.diff(traj.times)))
    assert step == pytest.approx(0.04)
    with pytest.warns(UserWarning, match=r"plays at 2x real time"):
        render_trajectory(traj, tmp_path / "fast.mp4", RenderOptions(size=SIZE), fps=50.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        render_trajectory(traj, tmp_path / "same.mp4", RenderOptions(size=SIZE), fps=25.0)


def test_a_python_recording_keeps_how_it_ran(tmp_path):
    """Session 14's researcher trial: a Recorder file of a Python run kept only E, nu and the
    ground, so a published run could not be re-run from it.  It now keeps the simulator's
    options; a Simulator rebuilt from them on the same model repeats the frames bitwise."""
    import jellysim as js
    from jellysim.io.trajectory import Recorder, load_trajectory

    model = js.physical_model(js.Body.box(points=64), js.material("gelatin", damping_ratio=0.05))
    ground = js.GroundParams(model="contact", friction=0.45, restitution=0.1)
    sim = js.Simulator(model, dt=1 / 90, ground=ground)
    rec = Recorder(model)
    for _ in range(4):
        rec.record(sim)
        sim.advance(2)
    p = load_trajectory(rec.save(tmp_path / "run.npz")).params["simulator"]
    assert p["dt"] == 1 / 90 and p["integrator"] == "symplectic"
    assert p["fem"]["damping_ratio"] == 0.05 and p["ground"]["friction"] == 0.45
    again = js.Simulator(model, dt=p["dt"], integrator=p["integrator"],
                         ground=js.GroundParams(**p["ground"]))
    assert again.substeps == p["substeps"]
    for k in range(4):
        np.testing.assert_array_equal(again.state.x, rec.positions[k])
        again.advance(2)


def test_a_jpeg_still_is_the_png_picture(traj, tmp_path):
    """Session 21's trial: `render -o x.jpg` was refused (artists reach for JPEG).  A .jpg
    (or .jpeg) is the last frame's picture, as the .png is, within JPEG's loss; a transparent
    background is refused for it (no alpha channel)."""
    import imageio.v3 as iio

    from jellysim.errors import JellysimError
    from jellysim.render.offscreen import RenderOptions
    from jellysim.render.video import render_trajectory

    opts = RenderOptions(size=(160, 96))
    png = iio.imread(render_trajectory(traj, tmp_path / "a.png", opts)).astype(int)
    for name in ("a.jpg", "a.jpeg"):
        jpg = iio.imread(render_trajectory(traj, tmp_path / name, opts)).astype(int)
        assert jpg.shape == png.shape and np.abs(jpg - png).mean() < 3.0
    with pytest.raises(JellysimError, match="no alpha channel"):
        render_trajectory(traj, tmp_path / "t.jpg", RenderOptions(size=(160, 96),
                                                                   background="transparent"))


def test_a_transparent_picture_with_a_floor_fades_the_floor_out(traj):
    """Session 21's trial: with `--background transparent` the floor faded into opaque white
    and ended in a hard slanted edge (alpha 0 -> 255 within five rows): a white band on a dark
    slide.  Its opacity now fades out towards the horizon instead: nothing above it (alpha 0
    along the top rows), opaque floor in front of the body, and along a column beside the body
    the alpha only grows from the horizon down, through the fade's middle values."""
    from jellysim.render.offscreen import Renderer, RenderOptions

    img = Renderer(traj, RenderOptions(size=(320, 180), background="transparent")).render(
        traj.frame_count - 1).astype(int)
    assert img.shape == (180, 320, 4)
    alpha = img[..., 3]
    assert alpha[:3].max() <= 3 and alpha[-3:].min() >= 250
    column = alpha[:, 8]                                   # the floor's left edge, no body
    assert np.all(np.diff(column) >= -2)                   # only grows, top to bottom
    assert np.sum((column > 30) & (column < 225)) >= 6     # a fade, not a hard edge
    red = (img[..., 0] > img[..., 1] + 60) & (alpha > 0)
    assert red.sum() > 100                                 # the body is drawn


def test_multisampling_is_turned_off_only_where_it_changes_nothing(traj):
    """Off-screen renders turn pyvista's 8x multisampling off on a software rasteriser (it
    cost 1.7x the time there: BENCHMARKS.md "The demo", session 24).  Where that is done the
    picture with multisampling must be the same (else the saving costs smooth edges); on a
    GPU it stays on.  There the edges are smoothed by VTK's FXAA pass instead (the artist
    trial: jagged silhouettes shimmered in the video): the jello's outline gets pixels
    between its colour and the floor's, where without it each pixel is one or the other."""
    import pyvista as pv

    from jellysim.render import offscreen as off
    from jellysim.render.offscreen import RenderOptions, Renderer

    soft = off._software_gl(pv)
    pictures = {}
    try:
        for asked in (True, False):
            off._SOFTWARE_GL[:] = [asked]
            with Renderer(traj, RenderOptions(size=(320, 180), plate=True,  # (no FXAA:
                                              antialias=not asked)) as r:  # pixel for pixel)
                samples = r.plotter.render_window.GetMultiSamples()
                assert (samples == 0) == asked
                pictures[asked] = r.render(traj.frame_count // 2).astype(int)
    finally:
        off._SOFTWARE_GL[:] = [soft]
    if soft:
        differ = np.abs(pictures[True] - pictures[False]).sum(axis=2) > 3
        assert differ.mean() < 1e-3, differ.sum()
        with Renderer(traj, RenderOptions(size=(320, 180), plate=True)) as r:
            assert r.plotter.renderer.GetUseFXAA()
            smooth = r.render(traj.frame_count // 2).astype(int)

        def blended(img):  # pixels next to the outline, neither the jello's red nor not
            red = (img[..., 0] > img[..., 1] + 60) & (img[..., 0] > img[..., 2] + 40)
            edge = red ^ np.roll(red, 1, axis=1)
            part = (img[..., 0] > img[..., 1] + 15) & ~red
            return int((part & (edge | np.roll(edge, -1, axis=1))).sum())

        assert blended(smooth) > 2 * blended(pictures[True]) + 10


def test_an_odd_image_size_is_said_as_it_is_rounded(traj):
    """The artist trial: --size 641x361 gave a 642x362 video without a word."""
    from jellysim.render.offscreen import RenderOptions, Renderer

    with pytest.warns(UserWarning, match=r"image size 161x97 rounded up to 162x98"):
        with Renderer(traj, RenderOptions(size=(161, 97))) as r:
            assert r.render(0).shape == (98, 162, 3)


def test_render_clock_and_labels_write_text_in_their_corners_only(run_dir, tmp_path):
    """--clock writes the frame's time in the upper right, --label a caption in the upper
    left: dark text pixels there, and nothing else of the picture changes; one label per
    run is asked."""
    import imageio.v3 as iio

    def render(*extra):
        out = tmp_path / f"f{len(extra)}.png"
        res = CliRunner().invoke(cli, ["render", str(run_dir), "-o", str(out), "--frame", "3",
                                       "--size", "320x180", "--quiet", *extra])
        assert res.exit_code == 0, res.output
        return np.asarray(iio.imread(out)).astype(int)[..., :3]

    plain, marked = render(), render("--clock", "--label", "soft")
    changed = np.abs(marked - plain).max(axis=2) > 0
    rows, cols = np.nonzero(changed)
    assert rows.size > 20 and rows.max() < 180 // 4          # text, in the top quarter
    left, right = cols < 320 // 2, cols >= 320 // 2
    assert left.sum() > 10 and right.sum() > 10                # both corners
    dark = marked.sum(axis=2) < 3 * 110
    assert dark[:45, 200:].any() and dark[:45, :120].any()
    res = CliRunner().invoke(cli, ["render", str(run_dir), str(run_dir), "-o",
                                   str(tmp_path / "two.png"), "--label", "one"])
    assert res.exit_code != 0 and "1 --label given for 2 run(s)" in res.output
    # captioned panels side by side: the clock goes to each panel's foot (at the top right
    # it ran into the next panel's caption: "time 0.500 s  torus", the artist trial)
    two = [render(str(run_dir), "--label", "one", "--label", "two", *clock)
           for clock in ((), ("--clock",))]
    rows, cols = np.nonzero(np.abs(two[1] - two[0]).max(axis=2) > 0)
    assert rows.size > 20 and rows.min() > 3 * 180 // 4           # at the foot only
    assert (cols < 320).sum() > 10 and (cols >= 320).sum() > 10    # of both panels


def test_a_zoom_centres_on_the_body_not_the_middle_of_its_fall(traj):
    """Teacher trial (session 28): `render --frame -1 --zoom 3` of a cube dropped 20 cm showed
    empty floor: the zoom moved towards the middle of the whole fall.  It now centres on the
    body at the frame asked (the last by default; the fixed and the following camera alike),
    which is then whole in the picture and 3x as wide as unzoomed (8-10x the pixels)."""
    import dataclasses

    from jellysim.render.offscreen import Renderer, RenderOptions

    size = float(np.max(np.ptp(traj.positions[0], axis=0)))
    lift = np.zeros((traj.frame_count, 1, 3))   # high at the start, at rest at the end
    lift[:, 0, 1] = 5.0 * size * (1.0 - np.arange(traj.frame_count) / (traj.frame_count - 1))
    drop = dataclasses.replace(traj, positions=traj.positions + lift)

    def red(o, f):
        img = Renderer(drop, o).render(f).astype(int)
        return (img[..., 0] > img[..., 1] + 60) & (img[..., 0] > img[..., 2] + 40)

    last = drop.frame_count - 1
    plain = red(RenderOptions(size=(160, 96), camera="fixed"), last).sum()
    assert plain > 20
    for camera in ("fixed", "follow"):
        for f in (last, 1):
            o = RenderOptions(size=(160, 96), camera=camera, zoom=3.0, zoom_on=f)
            body = red(o, f)
            assert 5 * plain < body.sum(), (camera, f, body.sum(), plain)
            assert not np.concatenate([body[0], body[-1], body[:, 0], body[:, -1]]).any()
    # a zoom never crops the body itself (the re-trial: a following camera, already framed
    # on the body, zoomed 3x stood inside a block and drew the picture solid red)
    for camera in ("fixed", "follow"):
        body = red(RenderOptions(size=(160, 96), camera=camera, zoom=20.0), last)
        assert 0 < body.sum() < 0.9 * body.size
        assert not np.concatenate([body[0], body[-1], body[:, 0], body[:, -1]]).any()


def test_points_are_drawn_whole_over_the_floor(traj):
    """Scale trial (session 28): `render --show points` drew only the right half of the body:
    VTK's sphere imposters lost to the floor's depth left of the picture's centre under
    software GL.  The points now span the picture as the skin does (the same camera)."""
    from jellysim.render.offscreen import Renderer, RenderOptions

    def columns(**kw):
        img = Renderer(traj, RenderOptions(size=(320, 180), **kw)).render(0).astype(int)
        mark = (img[..., 0] > img[..., 1] + 50) & (img[..., 0] > img[..., 2] + 30)
        cols = np.flatnonzero(mark.any(axis=0))
        return cols.min(), cols.max()

    skin = columns()
    points = columns(show_points=True, show_skin=False)
    assert points[1] - points[0] > 0.8 * (skin[1] - skin[0]), (points, skin)
    assert points[0] < 0.5 * (skin[0] + skin[1]) < points[1]
