"""Scene files (validation errors), the CLI, outputs, and the stability guard."""
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from jellysim.cli import cli
from jellysim.errors import SceneError, SimulationError
from jellysim.io.trajectory import load_trajectory
from jellysim.runner import run_scene
from jellysim.scene import Scene

ROOT = Path(__file__).resolve().parents[1]

BASE = """
[body]
points = 40
distribution = "uniform"
lower = [0.0, 1.0, 0.0]
upper = [0.2, 1.2, 0.2]
seed = 3

[springs]
radius = 0.12
stiffness = 1e-6  # weak springs: free fall to round-off

[mass]
point_mass = 0.01

[integrator]
name = "symplectic"
dt = 0.01
steps = 20

[provot]
enabled = false

[ground]
enabled = false

[output]
every = 5
"""


def with_line(section: str, line: str, text: str = BASE) -> str:
    """Add or replace a key in a section of the base scene."""
    key = line.split("=")[0].strip()
    if f"[{section}]" not in text:
        text = text + f"\n[{section}]\n"
    out, in_section = [], False
    for row in text.splitlines():
        if row.startswith("["):
            in_section = row == f"[{section}]"
            out.append(row)
            if in_section:
                out.append(line)
            continue
        if in_section and row.split("=")[0].strip() == key:
            continue
        out.append(row)
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("section,line,words", [
    ("springs", "radus = 0.3", ["[springs]", "unknown key 'radus'", "did you mean 'radius'"]),
    ("integrator", 'dt = "fast"', ["[integrator] dt", "wrong type", "a number > 0 (s)"]),
    ("integrator", "dt = 0.0", ["[integrator] dt", "out of range", "a number > 0 (s)"]),
    ("integrator", "dt = -0.01", ["[integrator] dt", "out of range", "> 0"]),
    ("integrator", "dt = nan", ["[integrator] dt", "not a finite number"]),
    ("springs", "stiffness = -2.0", ["[springs] stiffness", "out of range", "(N/m)"]),
    ("springs", "radius = 0", ["[springs] radius", "out of range", "(m)"]),
    ("springs", "radius = inf", ["[springs] radius", "not a finite number"]),
    ("mass", "point_mass = 0.0", ["[mass] point_mass", "out of range", "(kg)"]),
    ("mass", "density = -5", ["[mass] density", "out of range", "(kg/m^3)"]),
    ("integrator", "steps = 2.5", ["[integrator] steps", "wrong type", "integer"]),
    ("integrator", 'name = "rk4"', ["[integrator] name", "unknown choice", "'paper'"]),
    ("physics", "gravity = [0, -9.8]", ["[physics] gravity", "three numbers"]),
    ("provot", "tau = 1.5", ["[provot] tau", "out of range", "(0, 1)"]),
    ("provot", "enabled = 1", ["[provot] enabled", "true or false"]),
])
def test_bad_scene_values_give_one_clear_line(tmp_path, section, line, words):
    path = tmp_path / "bad.toml"
    path.write_text(with_line(section, line))
    with pytest.raises(SceneError) as info:
        Scene.load(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg
    for w in words:
        assert w in msg, (w, msg)


def test_an_inverted_box_is_named_before_the_keys_it_lacks():
    """A box with upper below lower under the gelatin preset (which leaves radius and points
    to defaults) is blamed on its corners, not on a missing [springs] radius."""
    text = ('[body]\ntype = "box"\nlower = [0.1, 0.1, 0.1]\nupper = [0.0, 0.0, 0.1]\n'
            '[material]\npreset = "gelatin"\n[integrator]\ndt = 0.01\nsteps = 10\n')
    with pytest.raises(SceneError, match=r"\[body\] upper = \[0.0, 0.0, 0.1\] must exceed "
                                         r"lower = \[0.1, 0.1, 0.1\] in every coordinate"):
        Scene.from_text(text, name="inverted.toml")


@pytest.mark.parametrize("section,key", [("integrator", "dt"), ("integrator", "steps"),
                                         ("body", "points"), ("springs", "radius")])
def test_missing_value(tmp_path, section, key):
    text = "\n".join(r for r in BASE.splitlines() if not r.startswith(f"{key} ="))
    path = tmp_path / "missing.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match=rf"\[{section}\] missing value '{key}'"):
        Scene.load(path)


def test_unknown_section_missing_section_and_bad_toml(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(BASE + "\n[grond]\nmu = 0.1\n")
    with pytest.raises(SceneError, match=r"unknown section \[grond\].*did you mean \[ground\]"):
        Scene.load(p)
    p.write_text(BASE.replace("[integrator]", "[integ]"))
    with pytest.raises(SceneError):
        Scene.load(p)
    p.write_text("[body\npoints = 3")
    with pytest.raises(SceneError, match="not valid TOML"):
        Scene.load(p)
    with pytest.raises(SceneError, match="not found"):
        Scene.load(tmp_path / "nope.toml")


def test_cli_bad_scene_exits_with_one_line_no_traceback(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(with_line("integrator", "dt = -1.0"))
    res = CliRunner().invoke(cli, ["run", str(p), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "Traceback" not in res.output
    assert "[integrator] dt" in res.output and "> 0" in res.output


def test_cli_failed_run_shows_the_warning_that_explains_it(tmp_path):
    """A run that blows up prints the stability warning it was given before the error (it
    used to be swallowed with the run's other messages), with the scene key that fixes it."""
    p = tmp_path / "stiff.toml"
    p.write_text("""
[body]
type = "box"
points = 200
[springs]
radius = 0.3
stiffness = 5.0e7
[integrator]
name = "symplectic"
dt = 0.01
steps = 50
substeps = 1
[provot]
enabled = false
""")
    res = CliRunner().invoke(cli, ["run", str(p), "--out", str(tmp_path / "o"), "--quiet"])
    assert res.exit_code == 2 and "Traceback" not in res.output
    warn, err = res.output.index("warning: dt = 0.01 s exceeds"), res.output.index("error:")
    assert warn < err and "substeps >=" in res.output[warn:err] and "unstable" in res.output


def test_cli_run_free_fall_outputs(tmp_path):
    """End to end: a spring-free cloud in free fall; outputs agree with the exact answer."""
    import meshio

    p = tmp_path / "fall.toml"
    p.write_text(BASE)
    out = tmp_path / "out"
    res = CliRunner().invoke(cli, ["run", str(p), "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    traj = load_trajectory(out / "trajectory.npz")
    assert traj.frame_count == 5 and traj.status == "complete"
    assert np.allclose(traj.times, [0, 0.05, 0.1, 0.15, 0.2])
    n = traj.steps[-1]
    exp_y = traj.rest_positions[:, 1] - 9.8 * 0.01**2 * n * (n + 1) / 2
    assert np.allclose(traj.positions[-1][:, 1], exp_y, atol=1e-12)
    assert traj.params["integrator"]["dt"] == 0.01 and "[body]" in traj.scene_toml
    pvd = (out / "body.pvd").read_text()
    files = [line.split('file="')[1].split('"')[0] for line in pvd.splitlines() if "file=" in line]
    assert len(files) == 5
    for k, f in enumerate(files):
        mesh = meshio.read(out / f)
        assert np.allclose(mesh.points, traj.positions[k])
        assert np.array_equal(mesh.cells_dict["line"], traj.springs)


def test_paper_cube_holds_with_all_pairs_and_flattens_with_springs_only(tmp_path):
    """The example's documented behaviour (report section 5.2)."""
    scene = Scene.load(ROOT / "examples" / "paper_cube.toml")
    assert scene.params["provot"]["pairs"] == "all"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the example runs without a stability warning
        model = scene.build_model()
        sim = scene.simulator(model)
    assert model.point_count == 600 and 9000 < model.spring_count < 11000
    sim.advance(100)
    y = sim.state.x[:, 1]
    assert y.min() >= 0.0 and y.min() < 1e-9  # landed, nothing below the ground
    assert y.max() - y.min() > 0.8  # the 1 m cube keeps its height
    raw = dict(scene.params)
    raw["provot"] = dict(raw["provot"], pairs="springs")
    soft = Scene.from_dict(raw)
    sim = soft.simulator(soft.build_model())
    sim.advance(100)
    assert sim.state.x[:, 1].max() < 0.5  # springs-only: the cube flattens


def test_stability_estimate_matches_two_mass_analytic():
    from jellysim.body import Body
    from jellysim.model import finalize
    from jellysim.stability import estimate_stability

    m, k = 0.3, 12.0
    model = finalize(Body(points=np.array([[0.0, 0, 0], [0.5, 0, 0]]), springs=np.array([[0, 1]])),
                     stiffness=k, point_mass=m)
    est = estimate_stability(model, "symplectic", 0.01)
    assert 2 * k / m <= est.lambda_max <= 1.06 * 2 * k / m
    assert est.dt_max == pytest.approx(2 / np.sqrt(est.lambda_max))


def test_guard_warns_and_runaway_stops_with_step_and_keeps_frames(tmp_path):
    # one step per dt asked for (substeps = 'auto' would count enough of them to be stable)
    text = BASE.replace("stiffness = 1e-6", "stiffness = 400.0").replace(
        "steps = 20", "steps = 400").replace("dt = 0.01", "dt = 0.01\nsubsteps = 1")
    scene = Scene.from_text(text, name="unstable.toml")
    model = scene.build_model()
    with pytest.warns(UserWarning, match="exceeds the estimated stable limit"):
        scene.simulator(model)
    # perturb so the unstable modes are excited
    with pytest.raises(SimulationError) as info:
        run_scene(scene, tmp_path / "o", progress=False)
    err = info.value
    assert f"step {err.step}" in str(err) and "try dt <=" in str(err)
    traj = load_trajectory(tmp_path / "o" / "trajectory.npz")
    assert traj.status.startswith("failed")
    assert traj.frame_count >= 2 and np.all(np.isfinite(traj.positions[:-1]))
    assert traj.steps[-1] == err.step
    pvd = (tmp_path / "o" / "body.pvd").read_text()
    assert pvd.count("<DataSet") == traj.frame_count
    # the same scene at a dt below the estimate runs to the end
    stable = Scene.from_text(text.replace("dt = 0.01", "dt = 0.002"), name="stable.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run_scene(stable, tmp_path / "ok", progress=False)


def test_package_import_is_light():
    code = ("import sys, jellysim; heavy = [m for m in ('numba', 'scipy', 'meshio', 'trimesh', "
            "'pyvista', 'rich', 'click') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


MESH_SCENE = """
[body]
type = "mesh"
path = "{path}"
points = 300
size = 0.1
base = [0.0, 0.05, 0.0]
seed = 1

[springs]
connect = "{connect}"
stiffness = 50.0

[integrator]
name = "symplectic"
dt = 0.0005
steps = 4

[provot]
enabled = false

[output]
every = 2
"""


@pytest.mark.parametrize("connect", ["radius", "delaunay"])
def test_mesh_scene_places_scales_builds_and_carries_the_mesh_as_skin(tmp_path, connect):
    from conftest import mesh_path
    from jellysim.geometry import load_mesh

    src = mesh_path("sphere.obj")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "ball.obj").write_bytes(src.read_bytes())
    p = tmp_path / "ball.toml"
    p.write_text(MESH_SCENE.format(path="sub/ball.obj", connect=connect))  # relative path
    scene = Scene.load(p)
    body = scene.build_body()
    lo, hi = body.points.min(axis=0), body.points.max(axis=0)
    # size: largest extent 0.1 m (a unit sphere of radius 1 scaled by 0.05); base: bottom centre
    v, f = scene.surface
    assert np.ptp(v, axis=0).max() == pytest.approx(0.1, rel=1e-12)
    vlo, vhi = v.min(axis=0), v.max(axis=0)
    assert np.allclose([0.5 * (vlo[0] + vhi[0]), vlo[1], 0.5 * (vlo[2] + vhi[2])], [0, 0.05, 0])
    assert np.all(lo >= vlo - 1e-12) and np.all(hi <= vhi + 1e-12)
    centre = 0.5 * (vlo + vhi)
    reach = np.linalg.norm(v - centre, axis=1).max()  # the icosphere's vertices bound it
    assert np.all(np.linalg.norm(body.points - centre, axis=1) <= reach * (1 + 1e-12))
    vol = abs(load_mesh(src).defects.volume) * 0.05**3
    assert body.volume == pytest.approx(vol, rel=1e-9)
    res = run_scene(scene, tmp_path / "out", progress=False)
    traj = load_trajectory(res.trajectory)
    assert traj.skin is not None and len(traj.skin.faces) == len(f)
    # the skin at rest is the placed input mesh itself
    assert np.allclose(traj.skin_positions(0), v, atol=1e-12)


def test_surface_samples_option(tmp_path):
    """[body] surface_samples: on by default for Delaunay bodies (points on the surface, the
    tets fill the mesh), off gives the report's way; refused where it has no meaning."""
    from conftest import mesh_path
    from jellysim.geometry.tetra import tet_signed_volumes as tet_volumes

    (tmp_path / "cube.obj").write_bytes(mesh_path("cube.obj").read_bytes())
    p = tmp_path / "cube.toml"
    text = MESH_SCENE.format(path="cube.obj", connect="delaunay")
    filled = {}
    for flag in (None, "false"):
        p.write_text(text if flag is None else text.replace(
            'type = "mesh"', f'type = "mesh"\nsurface_samples = {flag}'))
        body = Scene.load(p).build_body()
        assert body.meta["surface_samples"] is (flag is None)
        filled[flag] = np.abs(tet_volumes(body.points, body.tets)).sum() / body.volume
    assert filled[None] > 0.998 - 1e-9 > 0.99 > filled["false"]  # thin tets: <= 0.2 %
    p.write_text(MESH_SCENE.format(path="cube.obj", connect="marching").replace(
        'type = "mesh"', 'type = "mesh"\nsurface_samples = true'))
    with pytest.raises(SceneError, match="surface_samples is used only by"):
        Scene.load(p)
    # radius: off by default (exactly `points` points), on when asked
    for flag, expected in ((None, False), ("true", True)):
        text = MESH_SCENE.format(path="cube.obj", connect="radius")
        p.write_text(text if flag is None else text.replace(
            'type = "mesh"', f'type = "mesh"\nsurface_samples = {flag}'))
        assert Scene.load(p).build_body().meta["surface_samples"] is expected


def test_relax_option(tmp_path):
    """[body] relax: the Delaunay body's interior points are relaxed by default (its worst tet
    is far better than the report's random points'), 0 keeps them; refused elsewhere."""
    from conftest import mesh_path
    from jellysim.geometry.tetra import tet_quality

    (tmp_path / "cube.obj").write_bytes(mesh_path("cube.obj").read_bytes())
    p = tmp_path / "cube.toml"
    text = MESH_SCENE.format(path="cube.obj", connect="delaunay")
    worst = {}
    for flag in (None, 0):
        p.write_text(text if flag is None else text.replace(
            'type = "mesh"', f'type = "mesh"\nrelax = {flag}'))
        body = Scene.load(p).build_body()
        assert (body.meta["relax"] > 0) is (flag is None)
        worst[flag] = float(np.quantile(tet_quality(body.points, body.tets), 0.01))
    assert worst[None] > 1.5 * worst[0]
    for connect in ("radius", "marching"):
        p.write_text(MESH_SCENE.format(path="cube.obj", connect=connect).replace(
            'type = "mesh"', 'type = "mesh"\nrelax = 3'))
        with pytest.raises(SceneError, match="relax is used only by"):
            Scene.load(p)
    p.write_text(text.replace('type = "mesh"', 'type = "mesh"\nrelax = -1'))
    with pytest.raises(SceneError, match="relax"):
        Scene.load(p)


def test_snap_option(tmp_path):
    """[springs] snap: a marching body is warped onto the surface by default (it fills more of
    the sphere); false keeps the report's staircase, whose points all lie on the grid and whose
    tets are the grid's own (six of one volume per cube); refused for other builders, and the
    CLI's --no-snap builds the same staircase."""
    from conftest import mesh_path
    from jellysim.geometry.jellyfile import read_body
    from jellysim.geometry.tetra import tet_signed_volumes as tet_volumes

    (tmp_path / "sphere.obj").write_bytes(mesh_path("sphere.obj").read_bytes())
    p = tmp_path / "sphere.toml"
    text = MESH_SCENE.format(path="sphere.obj", connect="marching")
    filled, bodies = {}, {}
    for flag in (None, "false"):
        p.write_text(text if flag is None else text.replace(
            'connect = "marching"', f'connect = "marching"\nsnap = {flag}'))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            body = bodies[flag] = Scene.load(p).build_body()
        # the staircase's loss is said (below 80 % of the mesh), the warped body's is not
        assert any("fills only" in str(w.message) for w in caught) is (flag is not None)
        filled[flag] = np.abs(tet_volumes(body.points, body.tets)).sum()
    stair = bodies["false"]
    h = stair.meta["h"]
    steps = (stair.points - stair.points.min(axis=0)) / h
    assert np.abs(steps - np.round(steps)).max() < 1e-9  # every point a grid node
    assert np.allclose(np.abs(tet_volumes(stair.points, stair.tets)), h**3 / 6, rtol=1e-9)
    assert filled[None] > 1.05 * filled["false"]
    p.write_text(MESH_SCENE.format(path="sphere.obj", connect="delaunay").replace(
        'connect = "delaunay"', 'connect = "delaunay"\nsnap = false'))
    with pytest.raises(SceneError, match="snap is used only by"):
        Scene.load(p)
    out = tmp_path / "stair.jello"
    res = CliRunner().invoke(cli, ["build", str(tmp_path / "sphere.obj"), "-o", str(out), "--connect",
                                    "marching", "--points", "300", "--size", "0.1", "--no-snap"])
    assert res.exit_code == 0, res.output
    built = read_body(out)
    steps = (built.points - built.points.min(axis=0)) / built.meta["h"]
    assert np.abs(steps - np.round(steps)).max() < 1e-9
    res = CliRunner().invoke(cli, ["build", str(tmp_path / "sphere.obj"), "-o", str(tmp_path / "d.jello"),
                                    "--connect", "delaunay", "--no-snap"])
    assert res.exit_code != 0 and "connect='marching' only" in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize("suffix", [".jello", ".npz"])
def test_a_built_body_file_carries_its_mesh_as_the_skin(tmp_path, suffix):
    """jellysim build writes the (scaled) mesh into the body file; a file scene placing the
    body elsewhere runs with that mesh as its skin, moved with the body, and the skin follows
    the falling body (a uniform fall: every skin vertex moves as the points do)."""
    from conftest import mesh_path
    from jellysim.geometry import load_mesh

    src = mesh_path("sphere.obj")
    out = tmp_path / f"ball{suffix}"
    res = CliRunner().invoke(cli, ["build", str(src), "-o", str(out), "--connect", "marching",
                                   "--points", "300", "--size", "0.1"])
    assert res.exit_code == 0, res.output
    mesh = load_mesh(src)
    scaled = mesh.vertices * (0.1 / np.ptp(mesh.vertices, axis=0).max())
    text = MESH_SCENE.format(path=out.name, connect="radius").replace('"mesh"', '"file"')
    text = text.replace("size = 0.1\n", "").replace("base = [0.0, 0.05, 0.0]",
                                                     "base = [1.0, 0.5, -2.0]")
    text = text.replace("points = 300\n", "").replace('connect = "radius"\n', "")
    p = tmp_path / "ball.toml"
    p.write_text(text)
    scene = Scene.load(p)
    body = scene.build_body()
    lo, hi = body.points.min(axis=0), body.points.max(axis=0)
    assert np.allclose([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])], [1.0, 0.5, -2.0])
    traj = load_trajectory(run_scene(scene, tmp_path / "o", progress=False).trajectory)
    shift = body.points[0] - read_body_points(out)[0]  # where the scene moved the body
    rest = traj.skin_positions(0)
    assert np.array_equal(traj.skin.faces, mesh.faces)
    assert np.abs(rest - (scaled + shift)).max() < 1e-12  # the mesh itself, moved along
    moved = traj.positions[-1] - traj.positions[0]
    assert np.abs(moved - moved.mean(axis=0)).max() < 1e-12 and moved[:, 1].mean() < -1e-6
    assert np.abs(traj.skin_positions(len(traj.times) - 1) - rest - moved.mean(axis=0)).max() \
        < 1e-12


def test_a_body_file_with_its_own_stiffness_runs_from_a_scene(tmp_path):
    """A .jello body whose springs carry their own stiffness runs as it is (the model's springs
    keep the file's k, spring by spring); a scene [springs] stiffness beside it, or no
    stiffness anywhere, is one clear error naming the file."""
    from jellysim.body import Body
    from jellysim.geometry.jellyfile import write_body

    pts = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
    pairs = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
    k = np.array([500.0, 400.0, 300.0, 200.0, 100.0, 50.0])
    write_body(tmp_path / "tet.jello", Body(points=pts, springs=pairs, stiffness=k, volume=1e-3 / 6))
    text = MESH_SCENE.format(path="tet.jello", connect="radius").replace('"mesh"', '"file"')
    text = text.replace("size = 0.1\n", "").replace("points = 300\n", "")
    text = text.replace('connect = "radius"\n', "").replace("stiffness = 50.0\n", "")
    p = tmp_path / "tet.toml"
    p.write_text(text)
    model = Scene.load(p).build_model()
    assert np.array_equal(model.spring_stiffness, k)
    p.write_text(text.replace("[springs]\n", "[springs]\nstiffness = 50.0\n"))
    with pytest.raises(SceneError, match=r"tet.jello gives every spring its own stiffness"):
        Scene.load(p).build_model()
    write_body(tmp_path / "tet.jello", Body(points=pts, springs=pairs, volume=1e-3 / 6))
    p.write_text(text)
    with pytest.raises(SceneError, match=r"tet.jello has no spring stiffness; give \[springs\]"):
        Scene.load(p).build_model()


def read_body_points(path):
    from jellysim.geometry.jellyfile import read_body

    return read_body(path).points


def test_file_scene_and_missing_paths(tmp_path):
    from jellysim.body import Body
    from jellysim.geometry.jellyfile import write_body

    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    write_body(tmp_path / "tet.jello", Body(points=pts, springs=np.array(
        [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]), volume=1 / 6))
    text = MESH_SCENE.format(path="tet.jello", connect="radius").replace('"mesh"', '"file"')
    text = text.replace("size = 0.1\n", "").replace("base = [0.0, 0.05, 0.0]", "base = [5, 2, 5]")
    p = tmp_path / "tet.toml"
    # keys a body file does not read are refused, not ignored (it has its own points, springs)
    text = text.replace("points = 300\n", "").replace('connect = "radius"\n', "")
    for key, where, line in (("points", "seed = 1\n", "points = 300\n"),
                             ("connect", "[springs]\n", 'connect = "delaunay"\n'),
                             ("size", "seed = 1\n", "size = 2.0\n"),
                             ("lower", "seed = 1\n", "lower = [0.0, 1.0, 0.0]\n")):
        p.write_text(text.replace(where, where + line))
        with pytest.raises(SceneError, match=rf"{key} is not used for \[body\] type = 'file'"):
            Scene.load(p)
    p.write_text(text)
    body = Scene.load(p).build_body()
    assert np.allclose(body.points - pts, [5 - 1 / 2, 2, 5 - 1 / 2])
    # the .jello file holds the springs: no [springs] section needed (k from [material])
    no_springs = text.replace('[springs]\nstiffness = 50.0\n',
                              "[material]\nyoungs_modulus = 1e4\n")
    assert "[springs]" not in no_springs
    p.write_text(no_springs)
    model = Scene.load(p).build_model()
    assert model.spring_count == 6 and np.all(model.spring_stiffness > 0)
    p.write_text(text.replace('path = "tet.jello"\n', ""))
    with pytest.raises(SceneError, match=r"\[body\] missing value 'path'"):
        Scene.load(p)
    p.write_text(MESH_SCENE.format(path="nope.obj", connect="radius"))
    with pytest.raises(SceneError, match="nope.obj"):
        Scene.load(p).build_body()


def test_spot_example_runs_from_a_plain_clone_and_stands(tmp_path):
    """examples/spot_drop.toml uses the packaged mesh: the cow lands on its hooves, no tet
    inverts, and it stays up (dropped 2 cm, its firm-gelatin legs splay: measured 78 % of its
    height at rest; placed gently it stands at 94 %, tests/test_bunny.py)."""
    scene = Scene.load(ROOT / "examples" / "spot_drop.toml")
    model = scene.build_model()
    sim = scene.simulator(model)
    h0 = np.ptp(model.point_x0[:, 1])
    sim.advance(60)  # 1 s: the drop (2 cm) and the landing
    x = sim.state.x
    assert x[:, 1].min() >= -1e-9 and x[:, 1].min() < 1e-6  # landed, not through the plate
    assert 0.7 * h0 < np.ptp(x[:, 1]) <= 1.01 * h0  # up on its legs, not collapsed
    assert sim.min_tet_volume_ratio > 0


def test_the_shipped_mesh_is_named_so_a_copied_scene_still_finds_it(tmp_path):
    """Session 20's trial: examples/spot_drop.toml read `../src/jellysim/data/spot.obj` and
    failed once copied out of the clone.  `jellysim:spot.obj` names the mesh shipped inside
    the package: the copied scene builds the same body as the clone's, and the name works for
    `inspect`, `build` and `Body.from_mesh`; a name jellysim does not ship is one error that
    lists what it does ship."""
    import jellysim as js
    from jellysim.errors import MeshError
    from jellysim.geometry.mesh import load_mesh

    copy = tmp_path / "elsewhere" / "spot_drop.toml"
    copy.parent.mkdir()
    copy.write_text((ROOT / "examples" / "spot_drop.toml").read_text())
    assert 'path = "jellysim:spot.obj"' in copy.read_text()
    here = Scene.load(copy, overrides=["body.points=300"]).build_body()
    there = Scene.load(ROOT / "examples" / "spot_drop.toml",
                       overrides=["body.points=300"]).build_body()
    np.testing.assert_array_equal(here.points, there.points)
    shipped = load_mesh("jellysim:spot.obj")
    np.testing.assert_array_equal(shipped.vertices,
                                  load_mesh(ROOT / "src/jellysim/data/spot.obj").vertices)
    body = js.Body.from_mesh("jellysim:spot.obj", size=0.1, points=300, connect="radius",
                             sampling="uniform")
    assert float(np.ptp(body.points, axis=0).max()) <= 0.1 + 1e-9
    r = CliRunner().invoke(cli, ["build", "jellysim:spot.obj", "--size", "0.1", "--points",
                                 "300", "-o", str(tmp_path / "spot.jello")])
    assert r.exit_code == 0, r.output
    with pytest.raises(MeshError, match=r"jellysim ships no mesh named 'bunny.obj'; it ships "
                                        r"jellysim:spot.obj"):
        load_mesh("jellysim:bunny.obj")
    bad = tmp_path / "bad.toml"
    bad.write_text(copy.read_text().replace("jellysim:spot.obj", "jellysim:../README.md"))
    with pytest.raises(SceneError, match=r"bad.toml: \[body\] path: jellysim:\.\./README"):
        Scene.load(bad).build_body()


OBSTACLE_SCENE = """
[body]
points = 300
distribution = "uniform"
lower = [-0.05, 0.12, -0.05]
upper = [0.05, 0.22, 0.05]
seed = 2

[springs]
radius = 0.03
stiffness = 200.0

[mass]
point_mass = 0.002

[physics]
damping = 0.001

[integrator]
name = "symplectic"
dt = 0.0005
steps = 800

[provot]
tau = 0.05
loops = 3

[ground]
model = "contact"

[[obstacle]]
kind = "sphere"
center = [0.0, 0.05, 0.0]
radius = 0.05
friction = 0.3

[[obstacle]]
kind = "box"
lower = [0.2, 0.0, 0.2]
upper = [0.3, 0.1, 0.3]
"""


def test_scene_obstacles_hold_the_body_off_and_outside():
    scene = Scene.from_text(OBSTACLE_SCENE, name="obstacles.toml")
    assert [o["kind"] for o in scene.params["obstacle"]] == ["sphere", "box"]
    sim = scene.simulator(scene.build_model())
    sim.advance(scene.steps)  # 0.4 s: the blob falls 7 cm onto the ball
    x = sim.state.x
    r = np.linalg.norm(x - [0.0, 0.05, 0.0], axis=1)
    assert r.min() >= 0.05 - 1e-9  # nothing inside the sphere
    assert x[:, 1].min() >= -1e-9
    assert np.any(r < 0.05 + 0.01)  # it rests on it


@pytest.mark.parametrize("edit,words", [
    (("radius = 0.05", "radius = -1.0"), ["[[obstacle]] #1 radius", "out of range"]),
    (('kind = "box"', 'kind = "cone"'), ["[[obstacle]] #2 kind", "unknown choice"]),
    (("radius = 0.05\n", ""), ["[[obstacle]] #1 missing value 'radius'", "sphere"]),
    (('kind = "sphere"', 'kind = "sphere"\nnormal = [0, 1, 0]'), ["'normal' is not used"]),
    (("friction = 0.3", "fricton = 0.3"), ["unknown key 'fricton'", "did you mean 'friction'"]),
    (("upper = [0.3, 0.1, 0.3]", "upper = [0.1, 0.1, 0.3]"), ["[[obstacle]] #2", "must exceed"]),
])
def test_bad_obstacles_give_one_clear_line(edit, words):
    text = OBSTACLE_SCENE.replace(*edit, 1)
    with pytest.raises(SceneError) as info:
        Scene.from_text(text, name="obstacles.toml")
    msg = str(info.value)
    assert "\n" not in msg and "obstacles.toml" in msg
    for w in words:
        assert w in msg, (w, msg)


def test_grid_box_radius_defaults_to_1_8_spacings():
    """A grid box needs no [springs] radius: 1.8 spacings joins each point to its 26
    lattice neighbours (axes, face and body diagonals, up to sqrt(3) spacings); a random
    field still must give one."""
    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 125\n'
            'distribution = "grid"\nlower = [0.0, 0.0, 0.0]\nupper = [0.04, 0.04, 0.04]\n'
            "[integrator]\nsteps = 2\n")
    scene = Scene.from_text(text, name="grid.toml")
    assert scene.params["springs"]["radius"] == pytest.approx(1.8 * 0.008)
    model = scene.build_model()
    inner = np.all((model.point_x0 > 1e-9) & (model.point_x0 < 0.04 - 1e-9), axis=1)
    degree = np.bincount(model.spring_ij.ravel(), minlength=model.point_count)
    assert np.all(degree[inner] == 26)
    with pytest.raises(SceneError, match=r"\[springs\] missing value 'radius'"):
        Scene.from_text(text.replace('distribution = "grid"', 'distribution = "uniform"'),
                        name="field.toml")


def test_run_result_separates_the_first_steps_start_up():
    """The first advance call of a fresh process also compiles numba's kernels: the start-up
    is what it took beyond the later calls' pace (10 steps in 5 s, then 90 in 0.9 s: 4.9 s),
    and nothing can be told from a run of one call or a resumed run's first call alone."""
    from jellysim.runner import RunResult

    def result(first, steps=100, seconds=5.9, resumed=None):
        return RunResult(Path("."), Path("t.npz"), None, 10, steps, seconds,
                         resumed_from=resumed, first_chunk=first)

    assert result((10, 5.0)).startup_seconds() == pytest.approx(4.9)
    assert result((10, 0.1), seconds=1.0).startup_seconds() == 0.0  # steady pace
    assert result((100, 5.9)).startup_seconds() == 0.0  # one call: nothing to compare
    assert result((10, 5.0), steps=120, resumed=20).startup_seconds() == pytest.approx(4.9)
    assert result(None).startup_seconds() == 0.0


def test_steps_on_the_command_line_stands_for_a_missing_integrator_steps(tmp_path):
    """Session 10's trial: `jellysim run s.toml --steps 20` on a scene without [integrator]
    steps said only "missing value 'steps'".  --steps now gives it (the run takes 20 steps),
    and without it the error says --steps N."""
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.trajectory import load_trajectory

    path = tmp_path / "s.toml"
    path.write_text("[springs]\nstiffness = 300.0\nradius = 0.16\n[body]\npoints = 60\n"
                    "lower = [0, 0.05, 0]\nupper = [0.3, 0.35, 0.3]\n[mass]\npoint_mass = "
                    "0.002\n[integrator]\ndt = 0.001\n[output]\nvtu = false\n")
    r = CliRunner().invoke(cli, ["run", str(path), "--out", str(tmp_path / "a"), "--steps",
                                 "20", "--quiet"])
    assert r.exit_code == 0, r.output
    assert load_trajectory(tmp_path / "a").steps[-1] == 20
    r = CliRunner().invoke(cli, ["run", str(path), "--out", str(tmp_path / "b"), "--quiet"])
    assert r.exit_code != 0 and "missing value 'steps'" in r.output and "--steps N" in r.output


def _run_and_inspect(tmp_path, text):
    """``jellysim run`` the scene ``text`` (as ``s.toml``), then ``jellysim inspect`` it:
    the run's folder and the inspect rows by name."""
    p = tmp_path / "s.toml"
    p.write_text(text)
    out = tmp_path / "o"
    assert CliRunner().invoke(cli, ["run", str(p), "--out", str(out), "--quiet",
                                    "--no-vtu"]).exit_code == 0
    res = CliRunner().invoke(cli, ["inspect", str(out)])
    assert res.exit_code == 0, res.output
    return out, {line[2:15].strip(): line[16:] for line in res.output.splitlines()[1:]}


def test_inspect_a_run_gives_its_free_fall_figures(tmp_path):
    """`jellysim inspect OUT` of a free-falling body (BASE: weak springs, no ground, 20 steps
    of 0.01 s): its centre falls by the symplectic steps' sum g dt^2 (1 + ... + 20), its
    kinetic energy is M (g t)^2 / 2 and its gravity energy -M g^2 dt^2 210 (J), to 1e-6; it
    keeps its shape (its tets' volume ratio 1)."""
    out, rows = _run_and_inspect(tmp_path, BASE)
    from jellysim.io.trajectory import load_trajectory

    g = -float(load_trajectory(out).gravity[1])  # (the scene's default: 9.8 m/s^2)
    dt, n, mass = 0.01, 20, 40 * 0.01
    assert rows["frames"].startswith("5 (t = 0 to 0.2 s, steps 0 to 20)")
    assert rows["status"] == "complete"
    kinetic = float(rows["kinetic [J]"].split()[0])
    assert kinetic == pytest.approx(0.5 * mass * (g * n * dt) ** 2, rel=1e-6)
    gravity = float(rows["gravity [J]"].split()[0])
    assert gravity == pytest.approx(-mass * g * g * dt * dt * n * (n + 1) / 2, rel=1e-6)
    assert float(rows["springs [J]"].split()[0]) < 1e-12  # (weak springs, a rigid fall)
    assert float(rows["tet volume"].split()[2]) == pytest.approx(1.0, abs=1e-4)


def test_set_addresses_an_obstacle_table_by_its_number():
    """Session 15's lecturer trial: a friction sweep over an [[obstacle]] needed one file per
    value.  `--set obstacle.N.key=value` sets the N-th table's key (checked as the file's
    are); a wrong number or a missing table is one clear line."""
    text = BASE.replace("[ground]\nenabled = false", "[ground]\nenabled = false\n\n"
                        "[[obstacle]]\nkind = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 1, 0]\n"
                        "\n[[obstacle]]\nkind = \"sphere\"\ncenter = [0, 0.5, 0]\nradius = 0.1\n")
    scene = Scene.from_text(text, name="s.toml", overrides=("obstacle.2.friction=0.9",
                                                            "obstacle.1.slip_distance=0.002"))
    first, second = scene.params["obstacle"]
    assert second["friction"] == 0.9 and first["friction"] == 0.6
    assert first["slip_distance"] == 0.002
    sim = scene.simulator()
    assert sim.obstacles[1].friction == 0.9 and sim.obstacles[0].slip_distance == 0.002
    with pytest.raises(SceneError, match=r"has 2 \[\[obstacle\]\] table\(s\); N runs from 1 "
                                         r"to 2"):
        Scene.from_text(text, name="s.toml", overrides=("obstacle.3.friction=0.9",))
    with pytest.raises(SceneError, match=r"address one by its number, obstacle\.N\.key=value"):
        Scene.from_text(text, name="s.toml", overrides=("obstacle.friction=0.9",))
    with pytest.raises(SceneError,
                       match=r"\[\[obstacle\]\] #2 unknown key 'frction' \(did you mean"):
        Scene.from_text(text, name="s.toml", overrides=("obstacle.2.frction=0.9",))
    with pytest.raises(SceneError, match=r"no \[\[handle\]\] table to set"):
        Scene.from_text(text, name="s.toml", overrides=("handle.1.force=[0, 1, 0]",))


def test_a_run_that_will_be_slow_says_how_long_and_why(tmp_path, monkeypatch):
    """Session 20's trial: a Delaunay cow (4,518 points, 855 substeps per frame) ran 89 s for
    1 s of jello with nothing said but a progress bar.  After its second frame a run whose
    pace leaves more than SLOW_RUN_SECONDS says how long the rest takes at that pace, why
    (substeps per step, points) and what is faster; a run faster than that says nothing."""
    import jellysim.run_notes as notes

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 125\n'
            'lower = [0, 0, 0]\nupper = [0.05, 0.05, 0.05]\n[integrator]\nsteps = 6\n'
            '[output]\nevery = 1\nvtu = false\n')
    said = []
    run_scene(Scene.from_text(text), tmp_path / "a", notify=said.append)
    assert not [m for m in said if "at this pace" in m]
    monkeypatch.setattr(notes, "SLOW_RUN_SECONDS", 0.0)
    monkeypatch.setattr(notes, "PACE_STEPS", 1)
    said.clear()
    result = run_scene(Scene.from_text(text), tmp_path / "b", notify=said.append)
    (line,) = [m for m in said if "at this pace" in m]
    model = Scene.from_text(text).build_model()
    substeps = Scene.from_text(text).simulator(model).substeps
    assert f"({model.point_count:,} points, {substeps} substeps per step of" in line
    assert substeps > 1 and "Ctrl-C stops it" in line
    assert result.steps == 6  # (said, not stopped)


def test_the_pace_is_judged_after_the_thread_count_is_chosen(tmp_path, monkeypatch):
    """Scale trial (session 28): a 10,948-point body was told "about 4 min more" at the pace
    of its first steps, while the thread chooser alternated 1 and 2 threads; it took 2.2.  The
    pace window now starts once the first try is decided: when the run judges it, the choice
    is made, and the window holds none of the try's steps."""
    import jellysim.run_notes as notes
    import jellysim.runner as runner

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 1000\n'
            'lower = [0, 0, 0]\nupper = [0.05, 0.05, 0.05]\n[integrator]\nsteps = 16\n'
            '[output]\nevery = 1\nvtu = false\n')
    scene = Scene.from_text(text)
    sim = scene.simulator(scene.build_model())
    assert sim._thread_choice and not sim._thread_choice.chosen  # (6,000 tets: it applies)
    judged = []

    def say(notify, sim, seconds, steps, left):
        judged.append((sim._thread_choice.chosen, steps, left))
        return True

    monkeypatch.setattr(runner, "_say_if_slow", say)
    run_scene(scene, tmp_path / "a", notify=lambda m: None, progress=True)
    (chosen, steps, left), = judged
    assert chosen and steps + left <= 16 - 10  # (the try: 10 frames of 1 step)


def test_the_pace_is_judged_over_several_steps_not_one_slow_frame():
    """A radius cow's second step took 2.2 s (its first contact), its next 58 steps 0.12 s
    each: judged on that one step the run said "about 2 min more" and ended 7 s later.  The
    pace is now judged over PACE_STEPS steps (or PACE_SECONDS): one slow step is no verdict,
    five steps at the true pace say nothing, five slow ones say how long."""
    from types import SimpleNamespace

    import jellysim.run_notes as notes

    sim = SimpleNamespace(substeps=88, dt=1 / 60, model=SimpleNamespace(point_count=1478))
    said = []
    assert notes._say_if_slow(said.append, sim, 2.2, 1, 58) is False and not said
    assert notes._say_if_slow(said.append, sim, 2.2 + 4 * 0.12, 5, 54) is True and not said
    assert notes._say_if_slow(said.append, sim, 5 * 3.0, 5, 54) is True
    (line,) = said
    assert "about 3 min more" in line and "88 substeps per step" in line
    assert notes._say_if_slow(said.append, sim, 11.0, 1, 54) is True and len(said) == 2


def test_docs_scene_md_is_what_scene_help_prints():
    """docs/scene.md says it is generated by `jellysim scene-help`: a new user found its
    `threads` row behind the code's; it must be the schema's text, row for row."""
    from jellysim.scene import schema_markdown

    doc = (Path(__file__).resolve().parents[1] / "docs" / "scene.md").read_text()
    assert doc.split("\n", 4)[4].strip() == schema_markdown().strip(), (
        "regenerate: (head -4 docs/scene.md; jellysim scene-help) > new.md")


def test_inspect_a_physical_run_gives_its_tets_elastic_energy(tmp_path):
    """The researcher trial: `inspect` showed no elastic energy for a tet body (`plot` did).
    It now gives the tets' energy at the first frame (the rest shape: 0) and at the end,
    equal to ``Simulator.energy()`` of a simulator set to the last frame's positions."""
    text = ("[material]\npreset = 'gelatin'\n[body]\ntype = 'box'\npoints = 64\n"
            "lower = [0, 0.01, 0]\nupper = [0.04, 0.05, 0.04]\n[integrator]\nsteps = 12\n")
    out, rows = _run_and_inspect(tmp_path, text)
    words = rows["tets [J]"].replace(";", " ").split()
    end, first = float(words[0]), float(words[words.index("frame") + 1])
    from jellysim.io.trajectory import load_trajectory

    scene = Scene.load(tmp_path / "s.toml")
    sim = scene.simulator(scene.build_model())
    sim.state.x[:] = load_trajectory(out).positions[-1]
    assert abs(first) < 1e-12
    assert end > 1e-6 and end == pytest.approx(sim.energy()["elastic"], rel=1e-6)
