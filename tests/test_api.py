"""The Python API: top-level names, Body.from_mesh, sizes and units, finalize's traps."""
import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import jellysim
from conftest import mesh_path


def test_every_public_name_resolves_and_import_stays_light():
    for name in jellysim.__all__:
        assert getattr(jellysim, name) is not None, name
    from jellysim.build import build_body
    from jellysim.physics.contact import Plane
    from jellysim.scene import Scene

    assert jellysim.build_body is build_body and jellysim.Plane is Plane
    assert jellysim.Scene is Scene
    paper = Path(__file__).resolve().parents[1] / "examples" / "paper_cube.toml"
    assert Scene.from_file(paper).params == Scene.load(paper).params
    assert set(jellysim.__all__) <= set(dir(jellysim))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        jellysim.nope  # noqa: B018
    code = ("import sys, jellysim; jellysim.GroundModel; heavy = [m for m in ('numba', 'scipy', "
            "'meshio', 'trimesh', 'pyvista') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


@pytest.fixture(scope="module")
def spot():
    from jellysim.geometry import load_mesh

    return load_mesh(mesh_path("sphere.obj"))


def test_body_from_mesh_scales_to_size_and_masses_follow(spot):
    base = (0.0, 0.02, 0.0)
    body = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.1, points=300, seed=1,
                                   base=base, connect="delaunay")
    lo, hi = body.points.min(axis=0), body.points.max(axis=0)
    # Delaunay: the surface vertices are among the points: the body spans the scaled mesh
    # exactly
    assert np.ptp(body.points, axis=0).max() == pytest.approx(0.1, rel=1e-12)
    assert [0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])] == pytest.approx(base, abs=1e-12)
    factor = 0.1 / np.ptp(spot.vertices, axis=0).max()
    volume = abs(spot.defects.volume) * factor**3
    assert body.volume == pytest.approx(volume, rel=1e-12)
    assert body.masses.sum() == pytest.approx(jellysim.REPORT_DENSITY * volume, rel=1e-9)
    assert body.meta["density"] == jellysim.REPORT_DENSITY and body.meta["size"] == 0.1
    # the density it was built with is accepted again; another one is an error, not ignored
    assert jellysim.finalize(body, stiffness=1.0, density=1141.0).total_mass == pytest.approx(
        body.masses.sum())
    with pytest.raises(ValueError, match=r"density=500 .*masses is already set.*size="):
        jellysim.finalize(body, stiffness=1.0, density=500.0)
    with pytest.raises(ValueError, match="point_mass given, but body.masses"):
        jellysim.finalize(body, stiffness=1.0, point_mass=0.1)
    light = jellysim.finalize(dataclasses.replace(body, masses=None), stiffness=1.0,
                              density=500.0)
    assert light.total_mass == pytest.approx(500.0 * volume, rel=1e-12)


def test_finalize_takes_a_stiffness_per_spring():
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    springs = np.array([[2, 3], [0, 1], [0, 2]])        # not sorted: finalize sorts them
    body = jellysim.Body(points=pts, springs=springs, volume=1.0)
    model = jellysim.finalize(body, stiffness=np.array([3.0, 1.0, 2.0]))
    got = {tuple(ij): k for ij, k in zip(model.spring_ij.tolist(), model.spring_stiffness)}
    assert got == {(0, 1): 1.0, (0, 2): 2.0, (2, 3): 3.0}
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        jellysim.finalize(body, stiffness=np.ones(2))
    with pytest.raises(ValueError, match=">= 0 N/m"):
        jellysim.finalize(body, stiffness=np.array([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="body.stiffness is already set and differs"):
        jellysim.finalize(dataclasses.replace(body, stiffness=np.ones(3)), stiffness=2.0)


def test_gelatin_path_from_python_reaches_the_asked_modulus():
    """Body.from_mesh -> calibrate_springs -> finalize(stiffness=array): the network's
    modulus is the one asked for and the masses are the body's."""
    body = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.1, points=200, seed=2)
    k = jellysim.calibrate_springs(body, 1.0e4)
    model = jellysim.finalize(body, stiffness=k)
    assert model.total_mass == pytest.approx(body.masses.sum())
    E = jellysim.network_youngs_modulus(body, k)
    assert E == pytest.approx(1.0e4, rel=0.02)


def test_cli_build_size_and_inspect_units(tmp_path):
    from jellysim.cli import cli
    from jellysim.geometry.jellyfile import read_body

    out = tmp_path / "s.jello"
    res = CliRunner().invoke(cli, ["build", str(mesh_path("sphere.obj")), "--size", "0.05",
                                   "--points", "200", "--connect", "delaunay", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert np.ptp(read_body(out).points, axis=0).max() == pytest.approx(0.05, rel=1e-12)
    res = CliRunner().invoke(cli, ["inspect", str(mesh_path("sphere.obj"))])
    assert res.exit_code == 0 and "read as metres" in res.output and "[m^3]" in res.output


def test_body_from_a_vertices_faces_pair_and_bad_mesh_argument():
    """``Body.from_mesh(jelly_mould())``: the generated (vertices, faces) pair is a mesh; the
    body's volume is the closed surface's (divergence theorem) and it sits on y = 0."""
    from jellysim.errors import BuildError
    from jellysim.geometry.shapes import jelly_mould

    v, f = jelly_mould()
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
    body = jellysim.Body.from_mesh((v, f), size=None, points=300)  # marching, warped
    assert body.volume == pytest.approx(volume, rel=0.02)
    # its bottom nodes moved onto the mesh's base, to the warp's bisection step
    h = body.meta["h"]
    assert body.points[:, 1].min() == pytest.approx(0.0, abs=math.sqrt(3) * h / 2**14)
    with pytest.raises(BuildError, match=r"\(vertices, faces\) pair"):
        jellysim.Body.from_mesh(42)


def test_python_api_misuse_gets_one_clear_error():
    """A finalized Model where a Body is needed, a misspelt integrator, a negative step count:
    each a one-line error naming the fix, not an AttributeError from inside, a bare enum
    message or a silent no-op; the state is untouched."""
    from jellysim.errors import SceneError

    body = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.04, points=60,
                                   base=(0, 0, 0))
    with pytest.raises(TypeError, match=r"takes a Body.*not finalize\(body\)"):
        jellysim.physical_model(jellysim.finalize(body, stiffness=2.0))
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    with pytest.raises(SceneError, match=r"integrator must be one of \[.*'symplectic'"):
        jellysim.Simulator(model, dt=1 / 60, integrator="simplectic")
    for dt in ("a", None, True, 0.0):  # was a numpy TypeError for a string
        with pytest.raises(SceneError, match=r"dt must be a positive number of seconds"):
            jellysim.Simulator(model, dt=dt)
    sim = jellysim.Simulator(model, dt=1 / 60)
    x0 = sim.state.x.copy()
    for bad in (-1, 1.5, True):
        with pytest.raises(SceneError, match="whole number >= 0"):
            sim.advance(bad)
    sim.advance(0)
    assert np.array_equal(sim.state.x, x0) and sim.state.step == 0
    # session 8's new-user trial: each of these was a TypeError/AttributeError from inside or
    # was accepted and failed thousands of substeps later
    with pytest.raises(ValueError, match=r"material youngs_modulus must be a number, got '1e4'"):
        jellysim.material("gelatin", youngs_modulus="1e4")
    with pytest.raises(TypeError, match=r"ground must be a jellysim.GroundParams"):
        jellysim.Simulator(model, dt=1 / 60, ground="contact")
    with pytest.raises(ValueError, match=r"scale must be a finite number"):
        sim.set_gravity_scale([0], float("nan"))
    with pytest.raises(ValueError, match=r"every number of an obstacle must be finite"):
        jellysim.Simulator(model, dt=1 / 60, obstacles=[jellysim.Sphere(
            center=(float("nan"), 0.0, 0.0), radius=0.01)])
    assert np.array_equal(sim.state.x, x0) and sim.state.step == 0


def test_a_scene_dictionary_takes_tuples_and_numpy_values():
    """Scene.from_dict reads what Python code naturally passes (a tuple, a numpy array, numpy
    scalars) as the TOML reader's lists and numbers: the same scene, the same body."""
    text = {"body": {"type": "box", "points": 50, "lower": [0.0, 0.0, 0.0],
                     "upper": [0.1, 0.1, 0.1], "velocity": [0.0, -1.0, 0.0]},
            "springs": {"radius": 0.04, "stiffness": 50.0},
            "integrator": {"dt": 1e-3, "steps": 2}}
    numpyish = {"body": {"type": "box", "points": np.int64(50), "lower": (0, 0, 0),
                         "upper": np.full(3, 0.1), "velocity": (0.0, np.float32(-1.0), 0.0)},
                "springs": {"radius": np.float64(0.04), "stiffness": 50.0},
                "integrator": {"dt": 1e-3, "steps": 2}}
    a, b = jellysim.Scene.from_dict(text), jellysim.Scene.from_dict(numpyish)
    assert a.params == b.params
    assert np.array_equal(a.build_body().points, b.build_body().points)


def test_a_scene_rebuilt_from_its_own_parameters_is_the_same_scene():
    """Scene.from_dict(scene.params) with [[handle]] and [[obstacle]] tables (it refused the
    validated tables' own filled-in keys): the same parameters and the same run, its pinned
    points held exactly where they started."""
    text = """
[material]
preset = "gelatin"
[body]
lower = [0.0, 0.05, 0.0]
upper = [0.04, 0.09, 0.04]
points = 64
[integrator]
steps = 6
[[handle]]
kind = "pin"
box = [[-1.0, 0.085, -1.0], [1.0, 1.0, 1.0]]
[[obstacle]]
kind = "sphere"
center = [0.02, 0.0, 0.02]
radius = 0.03
"""
    first = jellysim.Scene.from_text(text)
    again = jellysim.Scene.from_dict(first.params)
    assert again.params == first.params
    runs = []
    for scene in (first, again):
        sim = scene.simulator()
        sim.advance(scene.steps)
        runs.append(sim.state.x.copy())
    x0 = first.build_body().points
    top = x0[:, 1] >= 0.085
    assert top.any() and not top.all()
    assert np.array_equal(runs[0], runs[1])
    assert np.array_equal(runs[0][top], x0[top])
    assert runs[0][~top, 1].min() < x0[~top, 1].min() - 1e-5  # the rest hangs and sags


def test_a_body_density_the_material_overrides_is_said():
    """Body.from_mesh(density=500) then the gelatin material: the physical model's masses are
    the material's (1141 kg/m^3 x the tets' volume), and a warning says so and how to keep the
    body's; with the same density, no warning and the masses are density x tet volume."""
    import warnings

    from jellysim.geometry.tetra import tet_signed_volumes

    body = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.04, points=60,
                                   base=(0, 0, 0), density=500.0)
    tet_volume = tet_signed_volumes(body.points, body.tets).sum()
    with pytest.warns(UserWarning, match=r"built with density = 500.*material\(\.\.\., "
                                         r"density=500\)"):
        model = jellysim.physical_model(body, jellysim.material("gelatin"))
    assert model.point_mass.sum() == pytest.approx(1141.0 * tet_volume, rel=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        same = jellysim.physical_model(body, jellysim.material("gelatin", density=500.0))
    assert same.point_mass.sum() == pytest.approx(500.0 * tet_volume, rel=1e-9)


def test_body_box_is_the_scene_box_and_a_ten_centimetre_grid_by_default():
    """``Body.box()``: a 10 cm cube on the ground as an 11^3 lattice whose mirrored Kuhn tets
    fill it exactly and whose springs reach the 26 nearest points (an interior point has
    26); the same body a scene's ``[body] type = "box"`` builds; bad corners are refused."""
    from jellysim.geometry.tetra import tet_signed_volumes
    from jellysim.scene import Scene

    js = jellysim
    body = js.Body.box()
    assert body.point_count == 11**3
    assert np.allclose(body.points.min(axis=0), 0.0) and np.allclose(body.points.max(axis=0), 0.1)
    vol = tet_signed_volumes(body.points, body.tets)
    assert np.all(vol > 0) and np.sum(vol) == pytest.approx(1e-3, rel=1e-12)
    degree = np.bincount(body.springs.ravel(), minlength=body.point_count)
    inner = np.all((body.points > 1e-9) & (body.points < 0.1 - 1e-9), axis=1)
    assert np.all(degree[inner] == 26)
    scene = Scene.from_text("[body]\ntype = 'box'\npoints = 1000\ndistribution = 'grid'\n"
                            "upper = [0.1, 0.1, 0.1]\n[springs]\nstiffness = 1.0\n"
                            "[integrator]\ndt = 0.01\nsteps = 1\n")
    other = scene.build_body()
    assert np.array_equal(other.points, body.points)
    assert np.array_equal(other.springs, body.springs)
    assert np.array_equal(other.tets, body.tets)
    with pytest.raises(ValueError, match="upper > lower"):
        js.Body.box((0, 0, 0), (0.1, 0.0, 0.1))
    with pytest.raises(ValueError, match="radius"):
        js.Body.box(distribution="uniform")


def test_cli_build_defaults_to_the_python_body(tmp_path):
    """`jellysim build MESH --size S --points N` and `Body.from_mesh(MESH, size=S, points=N)`
    make the same body (both marching: the trial's teapot came out mangled from the CLI's
    former radius default and sound from Python)."""
    from jellysim.cli import cli
    from jellysim.geometry.jellyfile import read_body

    out = tmp_path / "s.jello"
    res = CliRunner().invoke(cli, ["build", str(mesh_path("sphere.obj")), "--size", "0.05",
                                   "--points", "300", "-o", str(out)])
    assert res.exit_code == 0, res.output
    cli_body = read_body(out)
    py_body = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.05, points=300)
    assert np.allclose(cli_body.points, py_body.points, rtol=0, atol=1e-12)
    assert np.array_equal(cli_body.tets, py_body.tets)
    # a --radius alone still means radius springs (older command lines), with surface points
    # as Body.from_mesh's radius bodies (--no-surface-samples: the report's 300 inside);
    # with another builder it is refused, not ignored
    for flag, kind in (([], "jello"), (["--no-surface-samples"], "report")):
        res = CliRunner().invoke(cli, ["build", str(mesh_path("sphere.obj")), "--size", "0.05",
                                       "--points", "300", "--radius", "0.012", "-o",
                                       str(tmp_path / f"r{kind}.jello"), *flag])
        assert res.exit_code == 0, res.output
        r = read_body(tmp_path / f"r{kind}.jello")
        d = np.linalg.norm(r.points[r.springs[:, 0]] - r.points[r.springs[:, 1]], axis=1)
        py = jellysim.Body.from_mesh(mesh_path("sphere.obj"), size=0.05, points=300,
                                     connect="radius", radius=0.012,
                                     surface_samples=kind == "jello")
        np.testing.assert_allclose(r.points, py.points, rtol=0, atol=1e-12)
        assert d.max() < 0.012 and (r.point_count == 300) == (kind == "report")
    res = CliRunner().invoke(cli, ["build", str(mesh_path("sphere.obj")), "--connect",
                                   "marching", "--radius", "0.012", "-o",
                                   str(tmp_path / "m.jello")])
    assert res.exit_code != 0 and "radius (of the radius springs) applies to" in res.output


def test_the_python_api_refuses_what_a_scene_refuses():
    """Session 11's hostile trial: Python accepted what a scene refuses (ProvotParams(tau=2,
    loops=-3), GroundParams(mu=5, nu=-1): mu > 1 multiplied a sliding speed), truncated
    substeps=1.5, took a negative drag stiffness, and failed deep inside on Body(points=list),
    physical_model(body, "gelatin"), obstacles=js.Plane(...), a body starting inside an
    obstacle, and a NaN put in sim.state.x.  Each is a clear error now, naming the parameter;
    the natural spellings work."""
    import jellysim as js
    from jellysim.errors import SceneError
    from jellysim.params import ProvotParams

    for bad, match in ((dict(tau=2.0), "provot tau"), (dict(loops=-3), "provot loops"),
                       (dict(pairs="al"), r"provot pairs must be one of \['springs', 'all'\]")):
        with pytest.raises(ValueError, match=match):
            ProvotParams(**bad)
    for bad, match in ((dict(mu=5.0), "ground mu"), (dict(nu=-1.0), "ground nu")):
        with pytest.raises(ValueError, match=match):
            js.GroundParams(**bad)
    with pytest.raises(ValueError, match="ground friction must be a number >= 0"):
        js.GroundParams(model="contact", friction=float("nan"))
    with pytest.raises(SceneError, match="Scene.from_dict takes a dictionary"):
        js.Scene.from_dict([1, 2])
    body = js.Body(points=[[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]], springs=[[0, 1]])
    assert body.points.dtype == np.float64 and "volume unknown" in repr(body)
    with pytest.raises(ValueError, match=r"points must have shape \(n, 3\)"):
        js.Body(points=np.zeros(3), springs=[])
    with pytest.raises(ValueError, match="springs must be a .* integer point indices"):
        js.Body(points=np.zeros((2, 3)), springs=[[0, 1.5]])
    cube = js.Body.box(points=27)                         # (27 cells: 64 points)
    model = js.physical_model(cube, "gelatin")            # a preset's name works
    assert model.point_mass.sum() == pytest.approx(1141.0 * 1e-3, rel=1e-9)
    with pytest.raises(TypeError, match="material must be a jellysim.Material"):
        js.physical_model(cube, 3)
    with pytest.raises(SceneError, match="substeps must be an integer"):
        js.Simulator(model, dt=1 / 60, substeps=1.5)
    for bad in (0, -3, 2.7):  # (accepted, and reported as sim.threads)
        with pytest.raises(SceneError, match="threads must be an integer >= 1"):
            js.Simulator(model, dt=1 / 60, threads=bad)
    # a sweep's numpy values (np.arange, float32 arrays) are numbers too
    gel = js.material("gelatin", youngs_modulus=np.int64(10000), damping_ratio=np.float32(0.05))
    assert gel.youngs_modulus == 10000.0 and gel.damping_ratio == 0.05
    scene = jellysim.Scene.from_dict({"material": {"preset": "gelatin",
                                                   "damping_ratio": np.float32(0.05)},
                                      "integrator": {"steps": 2}})
    assert scene.params["material"]["damping_ratio"] == 0.05 and "0.05\n" in scene.text
    from jellysim.scene_spec import plain  # (a 0-d array is a number, as tolist() gave)

    assert plain({"a": np.array(5.0)}) == {"a": 5.0}
    one = js.Simulator(model, dt=1 / 60, obstacles=js.Sphere(center=(0.05, 0.3, 0.05),
                                                            radius=0.1))
    assert len(one.obstacles) == 1                       # one obstacle, not a list, works
    with pytest.raises(TypeError, match=r"obstacles\[0\] is 'plane'"):
        js.Simulator(model, dt=1 / 60, obstacles=["plane"])
    with pytest.raises(SceneError, match=r"obstacle #1 .*: 64 of 64 points of the body start "
                                         r"inside this obstacle"):
        js.Simulator(model, dt=1 / 60, obstacles=[js.Box(lower=(-1, -1, -1), upper=(1, 1, 1))])
    sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    with pytest.raises(SceneError, match="drag: stiffness must be a spring constant > 0"):
        sim.drag(0, (0.0, 0.2, 0.0), stiffness=-5.0)
    sim.state.x[3, 1] = np.nan
    with pytest.raises(SceneError, match=r"sim.state.x holds NaN or infinite values at 1 points"):
        sim.advance(1)
    sim.state.x[3, 1] = model.point_x0[3, 1]
    sim.state.v[5, 0] = 1e308    # finite, but no step can hold it: said as such, not a blow-up
    with pytest.raises(SceneError, match=r"sim.state.v is 1e\+308 m/s at point 5: one step of "
                                         r"dt = 0.0166667 s would carry it past the runaway"):
        sim.advance(1)
    assert sim.state.step == 0


def test_from_mesh_says_when_its_default_size_rescales_the_mesh():
    """Body.from_mesh scales the mesh to 10 cm unless told (build_body, the CLI and scenes keep
    metres): a 2-unit sphere scaled by the default is said (its extent and both fixes), and
    so is an 8 cm one (a new user's 8 cm mesh became 10 cm, twice the mass, unsaid); an
    explicit size, size=None, or a mesh already 10 cm across is not.  The body is the size
    asked either way."""
    import warnings

    from jellysim.geometry.mesh import load_mesh

    sphere = mesh_path("sphere.obj")
    with pytest.warns(UserWarning, match=r"largest extent, 2 in its own units, is scaled to "
                                         r"0\.1 m .*size=None"):
        body = jellysim.Body.from_mesh(sphere, points=300)
    mesh = load_mesh(sphere)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        small = jellysim.Body.from_mesh(sphere, size=0.05, points=300)
        metres = jellysim.Body.from_mesh(sphere, size=None, points=300)
        exact = jellysim.Body.from_mesh((0.05 * mesh.vertices, mesh.faces), points=300)
    with pytest.warns(UserWarning, match=r"largest extent, 0\.08 in its own units, is scaled "
                                         r"to 0\.1 m"):
        near = jellysim.Body.from_mesh((0.04 * mesh.vertices, mesh.faces), points=300)
    for b, extent in ((body, 0.1), (small, 0.05), (metres, 2.0), (near, 0.1), (exact, 0.1)):
        assert np.ptp(b.points, axis=0).max() == pytest.approx(extent, rel=0.05)


def test_a_simulator_given_a_body_or_a_dict_for_state_says_what_it_needs():
    """Session 20's API trial: ``Simulator(body, dt=...)`` (a Body, not a Model) and
    ``state={"x": ...}`` failed with an AttributeError deep in the contact checks."""
    import jellysim as js
    from jellysim.errors import ParameterError

    body = js.Body.box(points=27)
    with pytest.raises(ParameterError, match=r"model must be a jellysim\.Model, got a Body: "
                                             r"make the body a model first.*physical_model"):
        js.Simulator(body, dt=1 / 60)
    model = js.physical_model(body, js.material("gelatin"))
    with pytest.raises(ParameterError, match=r"state must be a jellysim\.State .* got a dict"):
        js.Simulator(model, dt=1 / 60, state={"x": 1})
    sim = js.Simulator(model, dt=1 / 60)
    again = js.Simulator(model, dt=1 / 60, state=sim.state)   # a State is taken
    assert np.array_equal(again.state.x, model.point_x0)


def test_a_body_with_values_no_step_could_use_is_refused_where_it_is_made():
    """Session 20's trial: `Body(...)` took NaN points, a spring to a point the body does not
    have, a negative mass or an infinite stiffness, and only `finalize` (or a run, much later)
    said so; `Body.from_mesh(points=300.5)`, `points='500'` and `base=(0, 0)` failed inside
    numpy or were silently accepted, and an unknown keyword was named as build_body's.  Each
    is now one ParameterError naming the row or the argument; good values still build."""
    from jellysim.errors import ParameterError

    x = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]]
    ok = jellysim.Body(points=x, springs=[[0, 1], [1, 2]], masses=[1e-3] * 3,
                       stiffness=[5.0, 0.0], rest_length=[0.01, 0.02])
    assert ok.springs.shape == (2, 2)
    given = np.array([[1, 0], [1, 2]])           # (j, i) is the spring (i, j): turned, the
    turned = jellysim.Body(points=x, springs=given)  # caller's array left as it was
    assert turned.springs.tolist() == [[0, 1], [1, 2]] and given.tolist() == [[1, 0], [1, 2]]
    assert repr(jellysim.finalize(turned, stiffness=1.0, point_mass=1e-3)) == (
        "Model(3 points, 2 springs, springs only, 0.003 kg)")
    for kw, says in (
            (dict(points=[*x[:2], [float("nan"), 0.0, 0.0]]), r"points\[2\] is \[nan"),
            (dict(springs=[[0, 1], [1, 3]]), r"springs\[1\] = \[1, 3\].*in \[0, 2\]"),
            (dict(springs=[[-1, 1]]), r"springs\[0\] = \[-1, 1\]"),
            (dict(springs=[[2, 2]]), r"springs\[0\] = \[2, 2\] joins a point to itself"),
            (dict(masses=[1e-3, -1e-3, 1e-3]), r"masses\[1\] is -0.001.*> 0 \[kg\]"),
            (dict(stiffness=[5.0, float("inf")]), r"stiffness\[1\] is inf.*>= 0 \[N/m\]"),
            (dict(rest_length=[0.01]), r"rest_length must have shape \(2,\)"),
            (dict(rest_length=[0.01, -1.0]), r"rest_length\[1\] is -1.0"),
            (dict(tets=[[0, 1, 2, 3]]), r"tets\[0\] = \[0, 1, 2, 3\]"),
            (dict(triangles=[[0, 1, 2], [0, 1, 9]]), r"triangles\[1\] = \[0, 1, 9\]"),
            # session 21's trial: the same spring twice, no points, points that are not
            # real numbers
            (dict(springs=[[0, 1], [1, 0]]), r"springs\[0\] and springs\[1\] both join "
                                             r"points \[0, 1\]"),
            (dict(points=np.zeros((0, 3)), springs=np.zeros((0, 2), int)), r"n >= 1"),
            (dict(points=np.ones((3, 3), bool)), r"real coordinates .* of bool"),
            (dict(points=np.ones((3, 3)) * 1j), r"real coordinates .* of complex128")):
        args = dict(points=x, springs=[[0, 1], [1, 2]]) | kw
        with pytest.raises(ParameterError, match=says):
            jellysim.Body(**args)
    sphere = mesh_path("sphere.obj")
    for kw, says in ((dict(points=300.5), r"points must be a whole number.*got 300.5"),
                     (dict(points="500"), r"points must be a whole number.*got '500'"),
                     (dict(base=(0, 0)), r"base must be 3 finite coordinates.*got \(0, 0\)"),
                     (dict(base=(0, "a", 0)), r"base must be 3 finite coordinates"),
                     (dict(colour="red"), r"Body.from_mesh: unknown keyword 'colour'.*radius")):
        with pytest.raises(ParameterError, match=says):
            jellysim.Body.from_mesh(sphere, size=0.04, **kw)
    body = jellysim.Body.from_mesh(sphere, size=0.04, points=np.int64(200), base=(0, 0, 0),
                                   connect="radius", sampling="uniform")
    assert float(body.points[:, 1].min()) >= 0.0 and len(body.points) >= 200
    again = jellysim.Body.from_mesh(sphere, size=0.04, points=2e2, base=(0, 0, 0),
                                    connect="radius", sampling="uniform")  # (a whole number)
    assert np.array_equal(again.points, body.points)


def test_the_force_gauges_refuse_a_springs_model_alike():
    """Session 20's trial: on a springs model `pin_force()` refused but `drag_force()`
    returned zeros, a reading that looked like "nothing pulls".  Both now refuse with the same
    message, naming how to get the physical path; on the physical path both read."""
    import jellysim as js
    from jellysim.errors import SceneError

    body = js.Body.box(points=27)
    springs = js.Simulator(js.finalize(body, stiffness=50.0, point_mass=1e-3), dt=1e-3)
    for gauge in (springs.pin_force, springs.drag_force):
        with pytest.raises(SceneError, match=r"needs the physical path.*physical_model"):
            gauge()
    sim = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    assert np.array_equal(sim.pin_force(), np.zeros(3))
    assert np.array_equal(sim.drag_force(), np.zeros(3))


def test_cli_build_takes_the_delaunay_epsilon_and_keeps_an_existing_file(tmp_path):
    """Session 20's trial: the Delaunay builder's near-duplicate distance (the report's
    epsilon) was not on the command line.  `build --epsilon E` removes the later of two points
    closer than E [m] (no two left closer, fewer points than the default's), and is refused with
    a builder that does not use it.  An existing output is kept without --overwrite, also for
    the shipped mesh's name (`jellysim:spot.obj`, which is not a path on disk)."""
    from scipy.spatial import cKDTree

    from jellysim.cli import cli
    from jellysim.geometry.jellyfile import read_body

    runner = CliRunner()
    base = ["build", "jellysim:spot.obj", "--size", "0.1", "--points", "400", "--connect",
            "delaunay", "--no-surface-samples"]
    counts = {}
    for eps in (None, 0.006):
        out = tmp_path / f"e{eps}.jello"
        res = runner.invoke(cli, base + ["-o", str(out)] + (
            ["--epsilon", str(eps)] if eps else []))
        assert res.exit_code == 0, res.output
        body = read_body(out)
        counts[eps] = len(body.points)
        if eps:
            d = cKDTree(body.points).query(body.points, k=2)[0][:, 1]
            assert d.min() > eps
    assert counts[0.006] < counts[None]
    res = runner.invoke(cli, ["build", "jellysim:spot.obj", "--size", "0.1", "--epsilon",
                              "0.001", "-o", str(tmp_path / "m.jello")])
    assert res.exit_code != 0 and "--connect marching does not use it" in res.output
    kept = (tmp_path / "e0.006.jello").read_bytes()
    res = runner.invoke(cli, base + ["-o", str(tmp_path / "e0.006.jello")])
    assert res.exit_code != 0 and "--overwrite" in res.output
    assert (tmp_path / "e0.006.jello").read_bytes() == kept


def test_finalize_says_when_a_radius_body_gets_another_density_than_it_was_built_at():
    """Session 21's API trial: a radius mesh body (masses left to finalize: density x volume,
    split evenly) built at 1141 kg/m^3 and finalized with density=500 took 500 without a word,
    where a tet body's set masses make that an error.  It now says so (the given density is
    used: its masses are that density x the volume); its own density gives no warning."""
    import warnings

    sphere = mesh_path("sphere.obj")
    body = jellysim.Body.from_mesh(sphere, size=0.04, points=300, connect="radius",
                                   sampling="uniform", density=1141.0)
    assert body.masses is None and body.meta["density"] == 1141.0
    with pytest.warns(UserWarning, match=r"density=500 kg/m\^3, but the body was built at "
                                         r"1141 kg/m\^3"):
        light = jellysim.finalize(body, stiffness=2.0, density=500.0)
    assert light.total_mass == pytest.approx(500.0 * body.volume, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        own = jellysim.finalize(body, stiffness=2.0)
        assert jellysim.finalize(body, stiffness=2.0, density=1141.0).total_mass == \
            own.total_mass == pytest.approx(1141.0 * body.volume, rel=1e-12)


def test_from_mesh_radius_bodies_get_surface_points_build_body_keeps_the_reports_way():
    """Session 24's API trial: a radius ball from ``Body.from_mesh`` (jello defaults) rested
    and landed on its inside points, rough at the spacing, and rolled 71 mm off a 3 cm drop
    (benchmarks/bench_drift.py).  ``from_mesh`` now puts points on the surface for radius
    bodies (``surface_samples=True``, as a physical body wants); ``build_body``, the report's
    builder, keeps exactly ``points`` points strictly inside."""
    sphere = mesh_path("sphere.obj")
    mesh = jellysim.load_mesh(sphere)
    v = mesh.vertices[mesh.faces]  # a convex mesh: a point's distance to its surface is the
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])  # smallest to a face's plane
    n /= np.linalg.norm(n, axis=1)[:, None]
    n *= np.sign(np.einsum("ij,ij->i", n, v[:, 0] - mesh.vertices.mean(axis=0)))[:, None]

    def depth(x):
        return np.min(np.einsum("fj,fj->f", n, v[:, 0])[None, :] - x @ n.T, axis=1)

    jelly = jellysim.Body.from_mesh(sphere, size=None, points=300, connect="radius")
    report = jellysim.build_body(sphere, points=300, connect="radius")
    on_jelly, on_report = np.abs(depth(jelly.points)), depth(report.points)
    spacing = (report.volume / 300) ** (1 / 3)
    assert np.sum(on_jelly < 1e-9 * spacing) >= 50  # a layer of points on the faces
    assert len(report.points) == 300 and on_report.min() > 1e-9 * spacing  # all inside
    inside_only = jellysim.Body.from_mesh(sphere, size=None, points=300, connect="radius",
                                          surface_samples=False)
    np.testing.assert_array_equal(inside_only.points, report.points)


def test_a_point_cloud_becomes_a_jello_body():
    """API trial (session 28): a raw point cloud had no documented way to get tets (the FEM
    material said "or radius bodies built with tets" and no more).  Body.from_points gives it
    springs within a radius and its Delaunay tets: the same body as the box field's random
    points, its tets filling the cloud's convex hull (mass = density x that volume, to the
    slivers dropped); a springs-only body's FEM error names it."""
    from scipy.spatial import ConvexHull

    from jellysim.geometry.sampling import box_field
    from jellysim.errors import ParameterError

    lo, hi = np.zeros(3), np.full(3, 0.05)
    cloud = box_field(400, lo, hi, distribution="uniform", seed=3)
    body = jellysim.Body.from_points(cloud, radius=0.012, seed=3)  # (the Delaunay jitter)
    ref = jellysim.Body.box(lo, hi, points=400, distribution="uniform", radius=0.012, seed=3)
    assert np.array_equal(body.points, ref.points) and np.array_equal(body.tets, ref.tets)
    assert np.array_equal(body.springs, ref.springs)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    hull = ConvexHull(cloud).volume
    assert 0.95 * hull < float(np.sum(model.point_mass)) / 1141.0 <= hull * (1 + 1e-9)
    chosen = jellysim.Body.from_points(cloud)  # radius chosen for 24 neighbours on average
    assert 2 * chosen.spring_count / chosen.point_count == pytest.approx(24.0, rel=0.1)
    with pytest.raises(ParameterError, match=r"Body.from_points\(points\)"):
        jellysim.physical_model(jellysim.Body(points=cloud, springs=ref.springs),
                                jellysim.Material(model="fem"))
    for bad, said in ((cloud[:3], "n >= 4"), (cloud[:, :2], r"shape \(400, 2\)"),
                      (np.where(cloud == cloud[0, 0], np.nan, cloud), "NaN")):
        with pytest.raises(ParameterError, match=said):
            jellysim.Body.from_points(bad)


def test_a_handle_moved_frame_by_frame_follows_exactly():
    """API trial (session 28): an app moving a pinned handle each frame had to re-pin it with a
    one-keyframe path.  sim.move_pinned(idx, offset) does that: the pinned top face is where
    the offsets sum to after each frame, to rounding, and the run is bitwise the re-pinned
    one; unpinned points are refused."""
    body = jellysim.Body.box((0, 0, 0), (0.02, 0.04, 0.02), points=90)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    top = np.flatnonzero(body.points[:, 1] > 0.04 - 1e-9)
    sims = [jellysim.Simulator(model, dt=1 / 60) for _ in range(2)]
    for sim in sims:
        sim.pin(top)
    start = sims[0].state.x[top].copy()
    total = np.zeros(3)
    for k in range(12):
        step = np.array([0.002 * np.cos(k), 0.001, -0.0015 * np.sin(k)])
        total += step
        sims[0].move_pinned(top, step)
        sims[1].pin(top, path=[[sims[1].state.t + sims[1].dt, *step]])
        for sim in sims:
            sim.advance(1)
        np.testing.assert_allclose(sims[0].state.x[top], start + total, atol=1e-12)
    assert np.array_equal(sims[0].state.x, sims[1].state.x)
    with pytest.raises(jellysim.SceneError, match="not pinned"):
        sims[0].move_pinned([0, top[0]], (0.0, 0.01, 0.0))


def test_gravity_scales_per_point_and_index_lists_are_flat():
    """API trial (session 28): a scale per point took one call per value (an array was
    refused with the whole array printed), and a 2-D index array was flattened silently.  Per
    point scales now act in the order given: under scales s_i alone (no elasticity acting in
    the first step) each point falls g s_i dt in the first step, exactly the symplectic
    step; a 2-D index list is refused."""
    body = jellysim.Body.box((0, 0, 0), (0.02, 0.02, 0.02), points=27)
    model = jellysim.physical_model(body, jellysim.material("gelatin"))
    sim = jellysim.Simulator(model, dt=1 / 600, substeps=1)
    idx = np.array([5, 0, 17])
    sim.set_gravity_scale(idx, [0.0, 2.0, 0.5])
    sim.advance(1)
    vy = sim.state.v[:, 1]
    np.testing.assert_allclose(vy[idx], -9.8 * np.array([0.0, 2.0, 0.5]) / 600, rtol=1e-9,
                               atol=1e-15)
    mask = np.zeros(model.point_count, dtype=bool)
    mask[[20, 3]] = True  # (a mask: its points in point order, 3 then 20)
    sim.set_gravity_scale(mask, [0.25, 4.0])
    assert sim.handles.gravity_scale[3] == 0.25 and sim.handles.gravity_scale[20] == 4.0
    with pytest.raises(jellysim.SceneError, match="flat list"):
        sim.pin([[0, 1], [2, 3]])
    with pytest.raises(jellysim.SceneError, match="2 scales need as many distinct"):
        sim.set_gravity_scale([1, 2, 3], [1.0, 2.0])
    with pytest.raises(jellysim.SceneError, match=r"got an array of shape \(27, 1\)"):
        sim.set_gravity_scale(np.arange(27), np.ones((27, 1)))
