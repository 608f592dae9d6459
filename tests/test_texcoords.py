"""Texture coordinates: a mesh file's UVs survive welding, cleaning, turning outward,
subdividing, body files, runs and every export (OBJ, glTF, USD), per face corner.

The reference is independent of jellysim's reading: a cube whose UVs are a known function of
the position on each face (a planar projection per face, different on every face, so every
edge is a UV seam), and the shipped Spot read here line by line."""
from pathlib import Path

import numpy as np
import pytest

from jellysim.geometry.mesh import load_mesh, outward

HALF = 0.05  # [m] the test cube's half side


def _uv_of(points, centre):
    """The cube's texture: on the face whose outward normal is +-axis a, u and v are the two
    other coordinates (from the centre), shifted per face: each face has its own UVs."""
    q = np.asarray(points, dtype=np.float64) - centre
    a = np.argmax(np.abs(q.mean(axis=-2)), axis=-1)          # the face's axis (from its centroid)
    side = np.take_along_axis(q.mean(axis=-2), a[..., None], -1)[..., 0] > 0
    u = np.take_along_axis(q, ((a + 1) % 3)[..., None, None].repeat(q.shape[-2], -2), -1)[..., 0]
    v = np.take_along_axis(q, ((a + 2) % 3)[..., None, None].repeat(q.shape[-2], -2), -1)[..., 0]
    return np.stack([u + 2.0 * a[..., None], v + side[..., None]], axis=-1)


def _cube_obj(path: Path, *, inside_out=False, materials=False, flipped=()):
    """An OBJ cube of side 2 HALF centred at the origin: 8 shared vertices, 6 quads, each
    corner with its own ``vt`` (the planar UVs of :func:`_uv_of`); ``materials``: the first
    three quads use one textured material and the others another (an .mtl and two PNGs)."""
    corners = np.array([[x, y, z] for x in (-HALF, HALF) for y in (-HALF, HALF)
                        for z in (-HALF, HALF)])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in corners]
    faces = []
    for k, quad in enumerate(quads):
        quad = quad[::-1] if inside_out != (k in flipped) else quad
        uv = _uv_of(corners[list(quad)][None], np.zeros(3))[0]
        lines += [f"vt {u:.17g} {v:.17g}" for u, v in uv]
        if materials and k in (0, 3):
            faces.append(f"usemtl {'ab'[k // 3]}")
        faces.append("f " + " ".join(f"{i + 1}/{4 * k + c + 1}" for c, i in enumerate(quad)))
    if materials:
        from PIL import Image

        for name, colour in (("a", (200, 30, 30)), ("b", (30, 30, 200))):
            Image.new("RGB", (8, 8), colour).save(path.parent / f"{name}.png")
        (path.parent / "cube.mtl").write_text("newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\n")
        lines.insert(0, "mtllib cube.mtl")
    path.write_text("\n".join(lines + faces) + "\n")
    return path


def _read_obj(path):
    """(corner positions (f, 3, 3), corner UVs (f, 3, 2), vertex count): a plain reading of
    an OBJ of triangles ``f a/ta b/tb c/tc``."""
    v, vt, f = [], [], []
    for line in Path(path).read_text().splitlines():
        w = line.split()
        if w and w[0] == "v":
            v.append([float(x) for x in w[1:4]])
        elif w and w[0] == "vt":
            vt.append([float(x) for x in w[1:3]])
        elif w and w[0] == "f":
            f.append([[int(t) - 1 for t in c.split("/")[:2]] for c in w[1:]])
    v, vt, f = np.array(v), np.array(vt), np.array(f)
    return v[f[:, :, 0]], vt[f[:, :, 1]], len(v)


def test_spot_keeps_its_uvs_per_face_corner_across_its_seams():
    from importlib import resources

    path = resources.files("jellysim") / "data" / "spot.obj"
    file_xyz, file_uv, _ = _read_obj(path)
    m = load_mesh("jellysim:spot.obj")
    # the file has seams: vertices with two UVs (so a UV per vertex could not hold them)
    seam = {}
    for xyz, uv in zip(file_xyz.reshape(-1, 3), file_uv.reshape(-1, 2)):
        seam.setdefault(tuple(xyz), set()).add(tuple(uv))
    assert sum(len(s) > 1 for s in seam.values()) > 50
    assert m.uv is not None and m.uv.shape == (len(m.faces), 3, 2)
    np.testing.assert_array_equal(m.vertices[m.faces], file_xyz)  # (faces in the file's order)
    np.testing.assert_array_equal(m.uv, file_uv)


@pytest.mark.parametrize("inside_out", [False, True])
def test_a_cube_keeps_its_uvs_through_welding_and_turning_outward(tmp_path, inside_out):
    m = load_mesh(_cube_obj(tmp_path / "cube.obj", inside_out=inside_out))
    assert len(m.vertices) == 8 and len(m.faces) == 12  # welded, quads split
    with pytest.warns(UserWarning, match="inside out") if inside_out else _no_warning():
        m = outward(m, "cube.obj")
    assert m.defects.volume > 0
    np.testing.assert_allclose(m.uv, _uv_of(m.vertices[m.faces], np.zeros(3)), atol=1e-15)


def test_faces_wound_against_their_neighbours_are_turned_with_their_uvs(tmp_path):
    """Two of the cube's six quads wound the wrong way (session 26's hostile-mesh trial: the
    winding rule then called 44 % of a box's inside outside): turned on load, the cube is a
    closed oriented manifold of the right volume, and each turned corner keeps its UV."""
    m = load_mesh(_cube_obj(tmp_path / "cube.obj", flipped=(1, 4)))
    d = m.defects
    assert d.turned_faces == 4 and d.watertight and d.volume == pytest.approx(8 * HALF**3)
    np.testing.assert_allclose(m.uv, _uv_of(m.vertices[m.faces], np.zeros(3)), atol=1e-15)


def _in_material_a(corners):
    """The test cube's faces of material ``a``: quads 0-2, the sides x = -HALF, x = +HALF and
    y = -HALF (by each face's centroid)."""
    c = np.asarray(corners).mean(axis=-2)
    return np.isclose(np.abs(c[..., 0]), HALF) | np.isclose(c[..., 1], -HALF)


def test_a_file_of_two_textured_materials_keeps_each_faces_own_uvs(tmp_path):
    """trimesh merges the materials by packing their images into one atlas and rescaling the
    UVs into it (a trial found every corner wrong); the skin keeps the file's, and which
    material each face uses."""
    m = load_mesh(_cube_obj(tmp_path / "cube.obj", materials=True))
    np.testing.assert_allclose(m.uv, _uv_of(m.vertices[m.faces], np.zeros(3)), atol=1e-15)
    assert sorted(m.materials.names) == ["a", "b"]
    np.testing.assert_array_equal(m.materials.index == m.materials.names.index("a"),
                                  _in_material_a(m.vertices[m.faces]))


def test_unreadable_uvs_are_said_and_dropped(tmp_path):
    path = _cube_obj(tmp_path / "cube.obj")
    text = path.read_text().replace("f 1/1 ", "f 1 ", 1)   # one corner without its UV
    path.write_text(text)
    with pytest.warns(UserWarning, match="its texture coordinates could not be read"):
        m = load_mesh(path)
    assert m.uv is None and len(m.faces) == 12


def test_a_duplicate_face_keeps_the_uvs_of_its_kept_copy():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2], [2, 1, 0]])  # last: face 0 reversed
    uv = v[f][..., :2] + v[f][..., 2:] * 0.5
    from jellysim.geometry.mesh import _clean

    m = _clean(v, f, "t", None, 1e-10, uv)
    assert len(m.faces) == 4
    np.testing.assert_array_equal(m.uv, m.vertices[m.faces][..., :2]
                                  + m.vertices[m.faces][..., 2:] * 0.5)


class _no_warning:
    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


def test_a_subdivided_skin_interpolates_the_uvs_on_each_face(tmp_path):
    """The 10 cm cube's 12 triangles are far coarser than a 600-point body's spacing: its
    skin is subdivided, and each new corner's UV is the face's texture at that point."""
    from jellysim import Body
    from jellysim.skin import default_skin

    body = Body.from_mesh(_cube_obj(tmp_path / "cube.obj"), size=2 * HALF, points=600)
    skin = default_skin(None, body)
    assert len(skin.faces) > 20 * 12 and skin.uv.shape == (len(skin.faces), 3, 2)
    rest = skin.rest_vertices[skin.faces]
    np.testing.assert_allclose(skin.uv, _uv_of(rest, np.zeros(3)), atol=1e-12)


@pytest.fixture(scope="module")
def cube_run(tmp_path_factory):
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    out = tmp_path_factory.mktemp("uvrun")
    _cube_obj(out / "cube.obj")
    text = f"""
[material]
preset = "gelatin"
[body]
type = "mesh"
path = "{(out / 'cube.obj').as_posix()}"
points = 300
size = {2 * HALF}
base = [0.0, 0.01, 0.0]
[integrator]
steps = 8
[output]
vtu = false
"""
    run_scene(Scene.from_text(text, name=str(out / "cube.toml")), out / "run", progress=False)
    from jellysim.io.trajectory import load_trajectory

    return load_trajectory(out / "run"), out


def test_a_runs_skin_carries_the_uvs(cube_run):
    traj, _ = cube_run
    rest = traj.skin.rest_vertices
    centre = 0.5 * (rest.min(axis=0) + rest.max(axis=0))
    np.testing.assert_allclose(traj.skin.uv, _uv_of(rest[traj.skin.faces], centre), atol=1e-12)


def test_obj_sequence_writes_welded_vertices_with_per_corner_uvs(cube_run, tmp_path):
    from jellysim.io.meshseq import export_mesh_sequence

    traj, _ = cube_run
    files = export_mesh_sequence(traj, tmp_path / "seq", fmt="obj")
    k = len(files) - 1
    xyz, uv, count = _read_obj(files[k])
    assert count == traj.skin.vertex_count  # welded: a seam is no hole in the file
    np.testing.assert_allclose(xyz, traj.skin_positions(k)[traj.skin.faces], atol=1e-9)
    np.testing.assert_allclose(uv, traj.skin.uv, atol=1e-9)


def test_obj_frames_carry_smooth_normals(cube_run, tmp_path):
    """Session 29: the OBJ frames had no normals, so Blender's importer shaded every face flat.
    Each face corner now names its vertex's unit normal (`f a/ta/a`), the area-weighted mean of
    its faces' normals: on a box at rest, inside a flat face it is that face's normal, and
    every normal leans to the outside of each face it touches (files without UVs: `f a//a`,
    tests/test_visual.py)."""
    from jellysim.io.meshseq import export_mesh_sequence

    traj, _ = cube_run

    def read(path):
        v, vn, f = [], [], []
        for line in Path(path).read_text().splitlines():
            w = line.split()
            if w and w[0] in ("v", "vn"):
                (v if w[0] == "v" else vn).append([float(x) for x in w[1:4]])
            elif w and w[0] == "f":
                f.append([[int(t) - 1 for t in c.split("/")] for c in w[1:]])
        return np.array(v), np.array(vn), np.array(f)

    files = export_mesh_sequence(traj, tmp_path / "seq", fmt="obj")
    for k in (0, len(files) - 1):
        v, vn, f = read(files[k])
        assert len(vn) == len(v) and np.array_equal(f[:, :, 2], f[:, :, 0])
        tri = v[f[:, :, 0]]
        face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
        corner_n = vn[f[:, :, 2]]
        np.testing.assert_allclose(np.linalg.norm(corner_n, axis=2), 1.0, atol=1e-5)
        cos = np.einsum("fck,fk->fc", corner_n, face_n)
        assert cos.min() > 0.0
        if k == 0:  # a vertex inside a flat face: all its faces share the normal
            lo, hi = v.min(axis=0), v.max(axis=0)
            at_bound = np.isclose(v, lo, atol=1e-6) | np.isclose(v, hi, atol=1e-6)
            flat = at_bound.sum(axis=1) == 1  # on one face of the box, off its edges
            assert flat.sum() > len(v) // 4
            axis = np.abs(vn[flat]).max(axis=1)
            np.testing.assert_allclose(axis, 1.0, atol=1e-5)


def test_glb_and_usd_carry_the_uvs(cube_run, tmp_path):
    from jellysim.io.gltf import _accessor, export_glb, read_glb
    from jellysim.io.usd import export_usd

    traj, _ = cube_run
    doc, binary = read_glb(export_glb(traj, tmp_path / "a.glb"))
    prim = doc["meshes"][0]["primitives"][0]
    faces = _accessor(doc, binary, prim["indices"]).reshape(-1, 3)
    st = _accessor(doc, binary, prim["attributes"]["TEXCOORD_0"])
    xyz = _accessor(doc, binary, prim["attributes"]["POSITION"])
    np.testing.assert_allclose(xyz[faces], traj.skin_positions(0)[traj.skin.faces], atol=1e-6)
    glb_uv = np.stack([st[:, 0], 1.0 - st[:, 1]], axis=-1)[faces]  # (glTF's v points down)
    np.testing.assert_allclose(glb_uv, traj.skin.uv, atol=1e-6)

    pytest.importorskip("pxr", reason="usd-core (the usd extra) is not installed")
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(export_usd(traj, tmp_path / "a.usda")))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/jello/skin"))
    var = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    assert var.GetInterpolation() == UsdGeom.Tokens.faceVarying
    np.testing.assert_allclose(np.asarray(var.Get()).reshape(-1, 3, 2), traj.skin.uv, atol=1e-6)


@pytest.mark.parametrize("suffix", [".jello", ".npz"])
def test_body_files_keep_the_uvs_and_a_scene_of_the_file_carries_them(tmp_path, suffix):
    from jellysim import Body
    from jellysim.geometry.jellyfile import read_body, write_body
    from jellysim.scene import Scene
    from jellysim.skin import default_skin

    body = Body.from_mesh(_cube_obj(tmp_path / "cube.obj"), size=2 * HALF, points=100)
    write_body(tmp_path / f"cube{suffix}", body)
    back = read_body(tmp_path / f"cube{suffix}")
    np.testing.assert_array_equal(back.skin_uv, body.skin_uv)
    scene = Scene.from_text(f'[material]\npreset = "gelatin"\n[body]\ntype = "file"\n'
                            f'path = "cube{suffix}"\nbase = [0.0, 0.0, 0.0]\n',
                            name=str(tmp_path / "s.toml"))
    skin = default_skin(scene, scene.build_body())
    rest = skin.rest_vertices
    centre = 0.5 * (rest.min(axis=0) + rest.max(axis=0))
    np.testing.assert_allclose(skin.uv, _uv_of(rest[skin.faces], centre), atol=1e-12)


def test_a_jello_files_bad_uv_section_is_named(tmp_path):
    from jellysim.errors import JelloFileError
    from jellysim.geometry.jellyfile import read_jello

    head = ("jello 1\npoints 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nsprings 0\n"
            "skin_vertices 3\n0 0 0\n1 0 0\n0 1 0\nskin_faces 1\n0 1 2\n")
    (tmp_path / "a.jello").write_text(head + "skin_uv 2\n0 0 1 0 0 1\n0 0 1 0 0 1\nend\n")
    with pytest.raises(JelloFileError, match=r"a.jello:14:9: section 'skin_uv' has 2 rows; "
                                             r"expected one per skin face \(1\)"):
        read_jello(tmp_path / "a.jello")
    (tmp_path / "b.jello").write_text(head.replace("skin_faces 1\n0 1 2\n", "")
                                      + "skin_uv 1\n0 0 1 0 0 1\nskin_faces 1\n0 1 2\nend\n")
    with pytest.raises(JelloFileError, match="b.jello:12:1: section 'skin_uv' before "
                                             "'skin_faces'"):
        read_jello(tmp_path / "b.jello")
    (tmp_path / "c.jello").write_text(head + "skin_uv 1\n0 0 1 0 0 nan\nend\n")
    with pytest.raises(JelloFileError, match="c.jello:15:11: 'nan' is not finite; expected "
                                             "a finite texture coordinate"):
        read_jello(tmp_path / "c.jello")


def test_a_texture_is_carried_into_each_export(cube_run, tmp_path):
    """--texture: glTF embeds the image's own bytes as the material's base colour texture;
    USD's stage and the OBJ frames' .mtl name a path that leads to the image; a skin
    without UVs refuses it."""
    import dataclasses
    import os

    from PIL import Image

    from jellysim.errors import JellysimError
    from jellysim.io.gltf import export_glb, read_glb
    from jellysim.io.meshseq import export_mesh_sequence

    traj, _ = cube_run
    image = tmp_path / "tex" / "checker.png"
    image.parent.mkdir()
    Image.new("RGB", (4, 4), (10, 200, 30)).save(image)
    doc, binary = read_glb(export_glb(traj, tmp_path / "a.glb", texture=image))
    view = doc["bufferViews"][doc["images"][0]["bufferView"]]
    start = view.get("byteOffset", 0)
    assert binary[start:start + view["byteLength"]] == image.read_bytes()
    pbr = doc["materials"][0]["pbrMetallicRoughness"]
    assert pbr["baseColorTexture"]["index"] == 0 and doc["textures"][0]["source"] == 0
    assert doc["materials"][0]["alphaMode"] == "OPAQUE"

    files = export_mesh_sequence(traj, tmp_path / "seq", texture=image)
    lines = files[0].read_text().splitlines()
    assert lines[1] == "mtllib skin.mtl" and lines.count("usemtl jello") == 1
    assert lines.index("usemtl jello") < min(k for k, w in enumerate(lines) if w[:2] == "f ")
    (line,) = [w for w in (tmp_path / "seq" / "skin.mtl").read_text().splitlines()
               if w.startswith("map_Kd ")]
    copy = tmp_path / "seq" / line.split(" ", 1)[1]     # (copied beside the frames)
    assert copy.parent == tmp_path / "seq" and copy.read_bytes() == image.read_bytes()

    pytest.importorskip("pxr", reason="usd-core (the usd extra) is not installed")
    from pxr import Usd, UsdShade

    from jellysim.io.usd import export_usd

    stage = Usd.Stage.Open(str(export_usd(traj, tmp_path / "a.usda", texture=image)))
    shader = UsdShade.Shader(stage.GetPrimAtPath("/jello/jello_material/texture"))
    asset = shader.GetInput("file").Get().path
    assert Path(os.path.normpath(tmp_path / asset)) == image
    surface = UsdShade.Shader(stage.GetPrimAtPath("/jello/jello_material/surface"))
    source = surface.GetInput("diffuseColor").GetConnectedSources()[0][0].source
    assert source.GetPath() == shader.GetPath()

    plain = dataclasses.replace(traj, skin=dataclasses.replace(traj.skin, uv=None))
    with pytest.raises(JellysimError, match="has no texture coordinates"):
        export_glb(plain, tmp_path / "b.glb", texture=image)


def test_inspect_of_the_run_says_its_skin_has_uvs(cube_run):
    from click.testing import CliRunner

    from jellysim.cli import cli

    traj, out = cube_run
    res = CliRunner().invoke(cli, ["inspect", str(out / "run")])
    assert res.exit_code == 0, res.output
    (row,) = [line for line in res.output.splitlines() if line.strip().startswith("skin ")]
    assert f"{traj.skin.vertex_count} vertices, {len(traj.skin.faces)} faces, with texture " \
           "coordinates" in row


def test_a_uv_seam_of_a_smooth_skin_shades_smooth_in_the_glb(tmp_path):
    """Spot's UV seams split its glTF vertices (one UV per vertex) but are no creases: each
    seam vertex's copies carry one normal (the one of its smooth side), as many distinct
    normals as it has sides of a crease (a session-25 review found seams shaded as creases)."""
    from jellysim.geometry.creases import split_creases
    from jellysim.io.gltf import _accessor, export_glb, read_glb
    from jellysim.io.trajectory import load_trajectory
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "mesh"\npath = "jellysim:spot.obj"\n'
            'points = 150\nsize = 0.1\nbase = [0.0, 0.01, 0.0]\n[integrator]\nsteps = 2\n'
            '[output]\nvtu = false\n')
    run_scene(Scene.from_text(text, name=str(tmp_path / "s.toml")), tmp_path / "run",
              progress=False)
    traj = load_trajectory(tmp_path / "run")
    doc, binary = read_glb(export_glb(traj, tmp_path / "spot.glb"))
    prim = doc["meshes"][0]["primitives"][0]
    xyz = _accessor(doc, binary, prim["attributes"]["POSITION"])
    normal = _accessor(doc, binary, prim["attributes"]["NORMAL"])
    rest = traj.skin_positions(0)
    source, _ = split_creases(rest, traj.skin.faces)
    sides = np.bincount(source, minlength=len(rest))          # crease copies per vertex
    from scipy.spatial import cKDTree

    vertex = cKDTree(rest).query(xyz)[1]                       # each glb vertex's skin vertex
    copies = np.bincount(vertex, minlength=len(rest))
    seam = np.flatnonzero(copies > sides)
    assert len(seam) > 50                                      # Spot's seams, split for glTF
    for v in seam:
        distinct = np.unique(np.round(normal[vertex == v], 4), axis=0)
        assert len(distinct) <= sides[v]


@pytest.fixture(scope="module")
def two_material_run(tmp_path_factory):
    from jellysim.io.trajectory import load_trajectory
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    out = tmp_path_factory.mktemp("uv2")
    _cube_obj(out / "cube.obj", materials=True)
    text = (f'[material]\npreset = "gelatin"\n[body]\ntype = "mesh"\n'
            f'path = "{(out / "cube.obj").as_posix()}"\npoints = 300\nsize = {2 * HALF}\n'
            'base = [0.0, 0.01, 0.0]\n[integrator]\nsteps = 4\n[output]\nvtu = false\n')
    run_scene(Scene.from_text(text, name=str(out / "cube.toml")), out / "run", progress=False)
    return load_trajectory(out / "run"), out


def test_a_skin_of_two_materials_exports_a_group_per_material(two_material_run, tmp_path):
    """The subdivided skin keeps each face's material (its parent's); OBJ frames write one
    usemtl run per material, glTF one primitive each, USD a GeomSubset each (a partition of
    the faces), each bound to its own material; NAME=IMAGE gives one material its image."""
    from PIL import Image

    from jellysim.io.gltf import _accessor, export_glb, read_glb
    from jellysim.io.meshseq import export_mesh_sequence

    traj, out = two_material_run
    skin = traj.skin
    rest = skin.rest_vertices[skin.faces]
    names = skin.materials.names
    assert len(skin.faces) > 100 and sorted(names) == ["a", "b"]
    in_a = skin.materials.index == names.index("a")
    count = {"a": in_a.sum(), "b": (~in_a).sum()}
    np.testing.assert_array_equal(in_a, _in_material_a(rest - rest.reshape(-1, 3).mean(0)))
    red = tmp_path / "red.png"
    Image.new("RGB", (4, 4), (220, 20, 20)).save(red)

    files = export_mesh_sequence(traj, tmp_path / "seq", texture={"b": red})
    text = files[-1].read_text().splitlines()
    runs = [w.split()[1] for w in text if w.startswith("usemtl ")]
    assert runs == list(names)
    starts = [text.index(f"usemtl {r}") for r in runs] + [len(text)]
    for r, a, b in zip(runs, starts[:-1], starts[1:]):
        assert sum(1 for w in text[a:b] if w[:2] == "f ") == count[r]
    mtl = (tmp_path / "seq" / "skin.mtl").read_text()
    (kd,) = [w for w in mtl.splitlines() if w.startswith("map_Kd ")]
    assert mtl.index("newmtl b") < mtl.index(kd)            # b's image; a keeps the red
    copy = tmp_path / "seq" / kd.split(" ", 1)[1]       # (copied beside the frames)
    assert copy.parent == tmp_path / "seq" and copy.read_bytes() == red.read_bytes()

    doc, binary = read_glb(export_glb(traj, tmp_path / "a.glb", texture={"b": red}))
    prims = doc["meshes"][0]["primitives"]
    for p in prims:
        material = doc["materials"][p["material"]]
        assert len(_accessor(doc, binary, p["indices"])) // 3 == count[material["name"]]
        textured = "baseColorTexture" in material["pbrMetallicRoughness"]
        assert textured == (material["name"] == "b")          # b's image; a keeps the red
    assert sorted(doc["materials"][p["material"]]["name"] for p in prims) == ["a", "b"]

    pytest.importorskip("pxr", reason="usd-core (the usd extra) is not installed")
    from pxr import Usd, UsdGeom, UsdShade

    from jellysim.io.usd import export_usd

    stage = Usd.Stage.Open(str(export_usd(traj, tmp_path / "a.usda", texture=red)))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/jello/skin"))
    subsets = UsdGeom.Subset.GetGeomSubsets(mesh, UsdGeom.Tokens.face, "materialBind")
    assert sorted(s.GetPrim().GetName() for s in subsets) == ["a", "b"]
    for s in subsets:
        rows = np.array(s.GetIndicesAttr().Get())
        want = np.flatnonzero(in_a if s.GetPrim().GetName() == "a" else ~in_a)
        np.testing.assert_array_equal(np.sort(rows), want)
        material = UsdShade.MaterialBindingAPI(s.GetPrim()).GetDirectBinding().GetMaterial()
        assert material.GetPrim().GetName() == s.GetPrim().GetName()
        assert stage.GetPrimAtPath(material.GetPath().AppendChild("texture")).IsValid()


def test_texture_names_are_checked(two_material_run, tmp_path):
    from click.testing import CliRunner

    from jellysim.cli import cli

    traj, out = two_material_run
    res = CliRunner().invoke(cli, ["inspect", str(out / "run")])   # (the names to give)
    (row,) = [w for w in res.output.splitlines() if w.strip().startswith("materials ")]
    for k, name in enumerate(traj.skin.materials.names):
        assert f"'{name}' ({(traj.skin.materials.index == k).sum()} faces)" in row
    res = CliRunner().invoke(cli, ["export", str(out / "run"), "-o", str(tmp_path / "a.glb"),
                                   "--texture", f"c={out / 'a.png'}"])
    assert res.exit_code != 0
    assert "the skin has no material 'c'; its materials are " in res.output
    assert "'a'" in res.output and "'b'" in res.output
    res = CliRunner().invoke(cli, ["export", str(out / "run"), "-o", str(tmp_path / "b.glb"),
                                   "--texture", f"a={out / 'a.png'}", "--texture",
                                   f"b={out / 'b.png'}"])
    assert res.exit_code == 0, res.output


def test_material_names_become_distinct_identifiers():
    """USD prim names and OBJ usemtl allow no spaces or dots: names are mapped to distinct
    identifiers (a clash after the mapping gets a suffix)."""
    import re

    from jellysim.io.texture import identifiers

    names = ["Skin Mat.001", "a b", "a_b", "3d", "", "a b"]
    ids = identifiers(names)
    assert ids[0] == "Skin_Mat_001" and ids[1] == "a_b"
    assert len(set(ids)) == len(ids)
    assert all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", i) for i in ids)
