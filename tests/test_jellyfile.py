"""Facts about the .jello text format and its .npz twin: exact round trips, located errors,
atomic writes."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from jellysim.body import Body
from jellysim.errors import JelloFileError, JellysimError
from jellysim.geometry import jellyfile
from jellysim.geometry.jellyfile import read_body, read_jello, write_body, write_jello

VALID = """\
jello 1
# a tiny body
points 4 mass
0.0 0.0 0.0 0.25
1.0 0.0 0.0 0.25
0.0 1.0 0.0 0.25
0.0 0.0 1.0 0.25
springs 3 rest_length stiffness
0 1 1.0 100.0
0 2 1.0 100.0
1 2 1.5 50.0
tets 1
0 1 2 3
end
"""


SKIN = """\
skin_vertices 3
0.0 0.0 0.0
1.0 0.0 0.0
0.0 1.0 0.0
skin_faces 1
0 1 2
end
"""


def with_line(lineno: int, new: str | None) -> str:
    lines = VALID.splitlines()
    if new is None:
        del lines[lineno - 1]
    else:
        lines[lineno - 1] = new
    return "\n".join(lines) + "\n"


def body_equal(a: Body, b: Body) -> None:
    for name in ("points", "springs", "rest_length", "stiffness", "masses", "tets", "triangles",
                 "skin_vertices", "skin_faces"):
        x, y = getattr(a, name), getattr(b, name)
        if x is None:
            assert y is None, name
        else:
            assert y is not None, name
            assert x.dtype == y.dtype and x.shape == y.shape, name
            assert np.array_equal(x, y), name  # exact, bit for bit for finite floats
    assert a.volume == b.volume
    assert a.meta == b.meta


def test_valid_file_contents(tmp_path):
    p = tmp_path / "tiny.jello"
    p.write_text(VALID)
    b = read_jello(p)
    assert b.points.shape == (4, 3) and b.points.dtype == np.float64
    assert b.masses.tolist() == [0.25] * 4
    assert b.springs.tolist() == [[0, 1], [0, 2], [1, 2]]
    assert b.rest_length.tolist() == [1.0, 1.0, 1.5]
    assert b.stiffness.tolist() == [100.0, 100.0, 50.0]
    assert b.tets.tolist() == [[0, 1, 2, 3]]
    assert b.triangles is None and b.volume is None and b.meta == {}


def test_springs_are_normalised_to_sorted_i_lt_j(tmp_path):
    p = tmp_path / "rev.jello"
    p.write_text(VALID.replace("0 1 1.0 100.0\n0 2 1.0 100.0\n1 2 1.5 50.0",
                               "2 1 1.5 50.0\n1 0 1.0 100.0\n0 2 1.25 100.0"))
    b = read_jello(p)
    assert b.springs.tolist() == [[0, 1], [0, 2], [1, 2]]
    assert b.rest_length.tolist() == [1.0, 1.25, 1.5]


def random_body(rng, with_extras=True):
    n = 50
    pts = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-8, 8, size=(n, 1))
    pts[0] = [1 / 3, 5e-324, -0.0]  # subnormal and negative zero survive
    pts[1] = [1e308, -2.2250738585072014e-308, 0.1]
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n) if (i * 7 + j) % 5 == 0])
    k = len(pairs)
    return Body(
        points=pts,
        springs=pairs.astype(np.int64),
        rest_length=rng.uniform(0.1, 2.0, k) if with_extras else None,
        stiffness=rng.uniform(1.0, 1e4, k) if with_extras else None,
        masses=rng.uniform(1e-6, 1.0, n) if with_extras else None,
        tets=np.argsort(rng.random((7, n)), axis=1)[:, :4].astype(np.int64)
        if with_extras else None,
        triangles=np.array([[0, 1, 2], [3, 4, 5]], dtype=np.int64) if with_extras else None,
        volume=float(rng.uniform(0.1, 1.0)) if with_extras else None,
        meta={"builder": "test", "h": 0.1, "nested": {"a": [1, 2.5, None]}, "s": "x # y"}
        if with_extras else {},
        skin_vertices=rng.normal(size=(9, 3)) / 3.0 if with_extras else None,
        skin_faces=np.argsort(rng.random((5, 9)), axis=1)[:, :3].astype(np.int64)
        if with_extras else None,
    )


@pytest.mark.parametrize("suffix", [".jello", ".npz"])
@pytest.mark.parametrize("extras", [True, False])
def test_round_trip_is_exact(tmp_path, suffix, extras):
    b = random_body(np.random.default_rng(7), extras)
    p = tmp_path / f"body{suffix}"
    write_body(p, b)
    body_equal(b, read_body(p))
    # writing what was read gives the same bytes
    write_body(tmp_path / f"again{suffix}", read_body(p))
    if suffix == ".jello":
        assert (tmp_path / f"again{suffix}").read_bytes() == p.read_bytes()


def test_round_trip_of_a_built_body(tmp_path):
    tetra = pytest.importorskip("jellysim.geometry.tetra")
    pytest.importorskip("tetgen")
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.load(Path(__file__).parent / "data" / "sphere.obj", force="mesh", process=True)
    b = tetra.tetgen_body(m.vertices, m.faces)
    for suffix in (".jello", ".npz"):
        write_body(tmp_path / f"s{suffix}", b)
        body_equal(b, read_body(tmp_path / f"s{suffix}"))


# (line, column, message pattern) for each malformed variant of VALID
MALFORMED = {
    "bad count": (with_line(3, "points x mass"), 3, 8, r"bad row count 'x'"),
    "count too large": (with_line(8, "springs 4 rest_length stiffness"), 12, 1,
                        r"section 'springs' declares 4 rows but 'tets' starts after 3: make "
                        r"the count 3, or add the missing rows"),
    "count too large before volume": (VALID.replace("springs 3", "springs 4").replace(
        "tets 1\n0 1 2 3\n", "volume 0.5\n"), 12, 1,
        r"section 'springs' declares 4 rows but 'volume' starts after 3"),
    "mass column not named": (with_line(3, "points 4"), 4, 13,
                              r"4 fields in section 'points'; expected 3 \(x y z\); a further "
                              r"column must be named in the section line, e.g. 'points 4 mass'"),
    "too few fields": (with_line(5, "1.0 0.0 0.0"), 5, 12,
                       r"3 fields in section 'points'; expected 4 \(x y z mass\)"),
    "too many fields": (with_line(13, "0 1 2 3 3"), 13, 9, r"5 fields.*expected 4"),
    "unparsable number": (with_line(5, "1.0 0.x 0.0 0.25"), 5, 5, r"cannot parse '0\.x'"),
    "underscore number": (with_line(5, "1_0 0.0 0.0 0.25"), 5, 1, r"cannot parse '1_0'"),
    "overflow": (with_line(5, "1e999 0.0 0.0 0.25"), 5, 1, r"'1e999' is not finite"),
    "float index": (with_line(10, "0 2.0 1.0 100.0"), 10, 3, r"cannot parse '2\.0' as an int"),
    "index out of range": (with_line(10, "0 7 1.0 100.0"), 10, 3, r"index 7 out of range.*0\.\.3"),
    "negative index": (with_line(13, "0 1 -2 3"), 13, 5, r"index -2 out of range"),
    "self spring": (with_line(10, "2 2 1.0 100.0"), 10, 3, r"self-spring"),
    "duplicate spring": (with_line(11, "0 1 1.5 50.0"), 11, 1,
                         r"duplicate spring 0-1 \(already at line 9"),
    "duplicate reversed": (with_line(11, "  1 0 1.5 50.0"), 11, 3,
                           r"duplicate spring 0-1 \(already at line 9.*j-i"),
    "nan": (with_line(6, "nan 1.0 0.0 0.25"), 6, 1, r"'nan' is not finite"),
    "inf stiffness": (with_line(9, "0 1 1.0 inf"), 9, 9, r"'inf' is not finite.*stiffness"),
    "negative mass": (with_line(4, "0.0 0.0 0.0 -0.25"), 4, 13, r"mass \[kg\] -0\.25 must be > 0"),
    "zero rest length": (with_line(9, "0 1 0 100.0"), 9, 5, r"rest length \[m\] 0 must be > 0"),
    "zero stiffness": (with_line(9, "0 1 1.0 0.0"), 9, 9, r"stiffness \[N/m\] 0\.0 must be > 0"),
    "truncated": ("\n".join(VALID.splitlines()[:10]) + "\n", 11, 1,
                  r"truncated file.*row 3 of 3 of section 'springs'"),
    "missing end": (with_line(14, None), 14, 1, r"truncated file.*'end'"),
    "unknown section": (with_line(12, "tetz 1"), 12, 1, r"unknown section 'tetz'"),
    "unknown column": (with_line(3, "points 4 masss"), 3, 10, r"unknown column 'masss'"),
    "missing header": (with_line(1, "jelly 1"), 1, 1, r"missing header.*'jello 1'"),
    "no header at all": (with_line(1, None), 2, 1, r"missing header: found 'points'"),
    "unsupported version": (with_line(1, "jello 2"), 1, 7, r"unsupported version '2'"),
    "repeated tet corner": (with_line(13, "0 1 1 3"), 13, 5, r"point 1 repeated in one tet"),
    "text after end": (VALID + "points 1\n", 15, 1, r"unexpected text after 'end'"),
    "repeated section": (VALID.replace("end\n", "tets 0\nend\n"), 14, 1,
                         r"section 'tets' repeated \(first at line 12\)"),
    "bad meta json": (VALID.replace("end\n", "meta {\"a\": }\nend\n"), 14, 12,
                      r"bad JSON in 'meta'"),
    "zero volume": (VALID.replace("end\n", "volume 0.0\nend\n"), 14, 8, r"volume 0\.0 must be > 0"),
    "missing springs": ("\n".join(VALID.splitlines()[:7] + VALID.splitlines()[11:]) + "\n",
                        10, 1, r"missing section 'springs'"),
    "empty file": ("# nothing but a comment\n\n", 1, 1, r"empty file; expected the header"),
    "section before points": (VALID.replace("jello 1\n", "jello 1\nsprings 0\n", 1), 2, 1,
                              r"before 'points'"),
    "skin face out of range": (VALID.replace("end\n", SKIN.replace("0 1 2", "0 1 3")), 19, 5,
                               r"index 3 out of range.*0\.\.2"),
    "skin face repeats a vertex": (VALID.replace("end\n", SKIN.replace("0 1 2", "0 2 2")), 19,
                                   5, r"vertex 2 repeated in one face"),
    "skin faces before vertices": (VALID.replace("end\n", "skin_faces 0\nend\n"), 14, 1,
                                   r"'skin_faces' before 'skin_vertices'"),
    "skin vertices without faces": (VALID.replace("end\n", SKIN.split("skin_faces")[0]
                                                  + "end\n"), 14, 1,
                                    r"'skin_vertices' without 'skin_faces'"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_file_error_names_file_line_and_column(tmp_path, case):
    text, line, col, pattern = MALFORMED[case]
    p = tmp_path / "bad.jello"
    p.write_text(text)
    with pytest.raises(JelloFileError) as info:
        read_jello(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}:{line}:{col}: "), msg
    assert re.search(pattern, msg), msg
    assert isinstance(info.value, JellysimError) and isinstance(info.value, ValueError)


def test_a_byte_order_mark_is_not_content(tmp_path):
    """Notepad saves UTF-8 with a byte-order mark; the file reads as without it."""
    p = tmp_path / "bom.jello"
    p.write_bytes(b"\xef\xbb\xbf" + VALID.encode())
    body_equal(read_jello(p), read_jello(_write(tmp_path / "v.jello", VALID)))


def test_comments_blank_lines_and_indentation_are_ignored(tmp_path):
    text = "# leading comment\n\n" + VALID.replace("points 4 mass", "  points 4 mass   # four")
    p = tmp_path / "c.jello"
    p.write_text(text)
    body_equal(read_jello(p), read_jello(_write(tmp_path / "v.jello", VALID)))


def _write(p, text):
    p.write_text(text)
    return p


def test_failed_write_leaves_existing_file_intact(tmp_path, monkeypatch):
    p = tmp_path / "keep.jello"
    p.write_text(VALID)
    before = p.read_bytes()
    bad = read_jello(p)
    bad.points[0, 0] = np.nan
    with pytest.raises(JelloFileError, match=r"array 'points': row 0 is NaN"):
        write_jello(p, bad)
    assert p.read_bytes() == before
    # a failure while replacing (e.g. disk full) also leaves the old file and no temp file
    good = read_jello(p)
    good.points[0, 0] = 0.5

    def boom(*a, **k):
        raise OSError("simulated failure")

    monkeypatch.setattr(os, "replace", boom)   # the one atomic writer: jellysim.io.atomic
    with pytest.raises(OSError, match="simulated"):
        write_body(p, good)
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["keep.jello"]


def test_npz_errors_name_file_and_array(tmp_path):
    b = read_jello(_write(tmp_path / "v.jello", VALID))
    p = tmp_path / "b.npz"
    write_body(p, b)
    z = dict(np.load(p))
    cases = {
        "springs": (dict(z, springs=np.array([[0, 9]])),
                    r"array 'springs': row 0 has an index out"),
        "self": (dict(z, springs=np.array([[1, 1]]), rest_length=np.array([1.0]),
                      stiffness=np.array([1.0])), r"array 'springs': row 0 is a self-spring"),
        "dup": (dict(z, springs=np.array([[0, 1], [0, 1], [1, 2]])), r"row 1 duplicates row 0"),
        "mass": (dict(z, masses=np.array([1.0, 0.0, 1.0, 1.0])), r"array 'masses': row 1"),
        "nan": (dict(z, points=np.full((4, 3), np.inf)), r"array 'points': row 0 is NaN or inf"),
        "shape": (dict(z, rest_length=np.ones(2)), r"array 'rest_length': shape \(2,\)"),
        "format": (dict(z, format=np.str_("jello-npz 9")), r"array 'format'"),
        "missing": ({k: v for k, v in z.items() if k != "points"}, r"array 'points' is missing"),
        "skin alone": (dict(z, skin_vertices=np.eye(3)),
                       r"array 'skin_faces': missing: a skin needs both"),
        "skin face": (dict(z, skin_vertices=np.eye(3), skin_faces=np.array([[0, 1, 3]])),
                      r"array 'skin_faces': row 0 has an index out of range 0..2"),
    }
    for name, (arrays, pattern) in cases.items():
        q = tmp_path / f"{name}.npz"
        np.savez(q, **arrays)
        with pytest.raises(JelloFileError, match=pattern) as info:
            read_body(q)
        assert str(q) in str(info.value)
    q = tmp_path / "garbage.npz"
    q.write_bytes(b"not a zip")
    with pytest.raises(JelloFileError, match="not a readable .npz"):
        read_body(q)


def test_written_file_is_world_readable_like_a_normal_file(tmp_path):
    p = tmp_path / "m.jello"
    write_body(p, read_jello(_write(tmp_path / "v.jello", VALID)))
    assert p.stat().st_mode & 0o777 == 0o644


def test_unknown_suffix_is_refused(tmp_path):
    with pytest.raises(JelloFileError, match=r"unknown body file suffix '\.txt'"):
        read_body(tmp_path / "x.txt")


def test_example_in_the_spec_reads(tmp_path):
    spec = Path(__file__).resolve().parents[1] / "docs" / "jello-format.md"
    if not spec.exists():
        pytest.skip("docs/jello-format.md absent")
    text = spec.read_text().split("## Example", 1)[1].split("```", 2)[1].lstrip("\n")
    b = read_jello(_write(tmp_path / "example.jello", text))
    assert b.masses.sum() == 1.0 and b.spring_count == 6 and b.stiffness.tolist() == [500.0] * 6
    assert b.volume == pytest.approx(1 / 6) and b.meta == {"builder": "hand-written"}


def test_crlf_line_endings(tmp_path):
    p = tmp_path / "crlf.jello"
    p.write_bytes(VALID.replace("\n", "\r\n").encode())
    body_equal(read_jello(p), read_jello(_write(tmp_path / "v.jello", VALID)))


def test_missing_body_file_is_a_clear_error(tmp_path):
    from jellysim.errors import JelloFileError
    from jellysim.geometry.jellyfile import read_body

    for suffix in (".jello", ".npz"):
        with pytest.raises(JelloFileError, match="file not found"):
            read_body(tmp_path / f"absent{suffix}")


def test_a_body_files_own_masses_and_stiffness_against_the_scene(tmp_path):
    """A body file's masses and stiffnesses are the user's data: a scene key the user wrote
    that they would silently override is refused, naming it; a preset's default gives way
    (said); a file with neither masses nor a volume asks for the keys that would do."""
    import warnings

    from jellysim.errors import SceneError
    from jellysim.scene import Scene

    def jello(name, header, rows, springs):
        f = tmp_path / name
        f.write_text(f"jello 1\npoints 2 {header}\n" + "\n".join(rows) + f"\n{springs}\nend\n")
        return f.name

    masses = jello("m.jello", "mass", ["0 0 0 1e9", "0 1 0 0.5"], "springs 1\n0 1")
    stiff = jello("k.jello", "mass", ["0 0 0 1e9", "0 1 0 0.5"], "springs 1 stiffness\n0 1 20")
    bare = jello("b.jello", "", ["0 0 0", "0 1 0"], "springs 1\n0 1")

    def model(path, extra):
        scene = tmp_path / "s.toml"
        scene.write_text(f'[body]\ntype = "file"\npath = "{path}"\n{extra}'
                         "[integrator]\ndt = 0.001\nsteps = 1\n")
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            m = Scene.load(scene).build_model()
        return m, [str(w.message) for w in said]

    m, said = model(masses, "[springs]\nstiffness = 20.0\n")
    assert m.point_mass.tolist() == [1e9, 0.5] and said == []
    for key in ("point_mass = 2.0", "density = 500.0"):
        with pytest.raises(SceneError, match=rf"\[mass\] {key.split()[0]} = .* but the body file "
                                             r"m.jello gives every point its own mass; remove"):
            model(masses, f"[springs]\nstiffness = 20.0\n[mass]\n{key}\n")
    # the paper preset keeps the file's masses and stiffnesses (its k = 2 and its even mass
    # split give way, both said: a lecturer's file ran with its own masses, unsaid)
    m, said = model(stiff, '[material]\npreset = "paper-2010"\n')
    assert m.point_mass.tolist() == [1e9, 0.5] and m.spring_stiffness.tolist() == [20.0]
    assert len(said) == 2 and "own stiffness, used instead of the preset's" in said[0]
    assert "gives every point its own mass (1e+09 kg in all), used instead of the " \
           "'paper-2010' preset's masses" in said[1]
    with pytest.raises(SceneError, match=r"\[springs\] stiffness = 5, but the body file k.jello"):
        model(stiff, "[springs]\nstiffness = 5.0\n")
    with pytest.raises(SceneError, match=r"b.jello has no masses and no volume: give \[mass\] "
                                         r"point_mass \(kg\) in the scene, or a mass column"):
        model(bare, "[springs]\nstiffness = 20.0\n")
    m, said = model(bare, "[springs]\nstiffness = 20.0\n[mass]\npoint_mass = 0.25\n")
    assert m.point_mass.tolist() == [0.25, 0.25] and said == []


def test_a_body_file_written_in_centimetres_is_said(tmp_path):
    """Sizes are in metres: a body file 100 m across (a 1 m bob written in cm) is warned, as a
    box or mesh that large is; a 1 m one is not."""
    import warnings

    from jellysim.scene import Scene

    for span, said in ((100.0, True), (1.0, False)):
        (tmp_path / "b.jello").write_text(f"jello 1\npoints 2 mass\n0 0 0 1\n0 {span} 0 1\n"
                                          "springs 1 stiffness\n0 1 20\nend\n")
        (tmp_path / "s.toml").write_text('[body]\ntype = "file"\npath = "b.jello"\n'
                                         "[integrator]\ndt = 0.001\nsteps = 1\n")
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            Scene.load(tmp_path / "s.toml").build_body()
        words = [str(w.message) for w in got if "slip of units" in str(w.message)]
        assert bool(words) is said
        if said:
            assert "the body file b.jello is 100 m across" in words[0]


def test_base_places_a_body_file_by_its_skin_as_a_mesh_body(tmp_path):
    """Session 12's artist trial: ``base`` put a body file's points at the given height and
    its skin (what is drawn, a little below the points) under the floor; a mesh body is
    placed by its skin.  Now both are, and the points keep their place inside the skin."""
    from jellysim.body import Body
    from jellysim.geometry.jellyfile import write_body
    from jellysim.scene import Scene

    body = Body.from_mesh(str(Path(__file__).parent / "data" / "sphere.obj"), size=0.05, points=300, connect="marching")
    write_body(tmp_path / "ball.jello", body)
    (tmp_path / "s.toml").write_text('[body]\ntype = "file"\npath = "ball.jello"\n'
                                     "base = [0.1, 0.01, 0.0]\n[material]\npreset = 'gelatin'\n"
                                     "[integrator]\nsteps = 1\n")
    placed = Scene.load(tmp_path / "s.toml").build_body()
    lo, hi = placed.skin_vertices.min(axis=0), placed.skin_vertices.max(axis=0)
    assert np.allclose([0.5 * (lo[0] + hi[0]), lo[1], 0.5 * (lo[2] + hi[2])], [0.1, 0.01, 0.0],
                       atol=1e-12)
    shift = placed.points - body.points
    assert np.allclose(shift, shift[0], atol=1e-12)                   # moved rigidly
    assert np.allclose(placed.skin_vertices - body.skin_vertices, shift[0], atol=1e-12)
    assert placed.points[:, 1].min() >= 0.01 - 1e-6     # none under the skin (its facets: 1e-7)


def test_a_built_body_file_at_the_materials_density_runs_without_a_mass_warning(tmp_path):
    """Scale trial (session 28): every run of a body file from `jellysim build` warned that
    its masses (density x the mesh's enclosed volume) were replaced by the physical path's
    (density x its tets' volume), 2-9 % apart, which nothing could fix.  At the same density
    that is the path's own rule: said nothing; a file built at another density is still said."""
    import warnings

    from jellysim import Body
    from jellysim.geometry.jellyfile import write_body
    from jellysim.scene import Scene

    mesh = Path(__file__).parent / "data" / "sphere.obj"
    for density, said in ((1141.0, False), (1000.0, True)):
        path = tmp_path / f"b{density:g}.jello"
        write_body(path, Body.from_mesh(mesh, size=0.05, points=400, density=density))
        text = (f'[material]\npreset = "gelatin"\n[body]\ntype = "file"\npath = "{path}"\n'
                '[integrator]\nsteps = 1\n')
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = Scene.from_text(text, name="s.toml").build_model()
        replaced = [w for w in caught if "are replaced by the material" in str(w.message)]
        assert bool(replaced) == said, (density, [str(w.message) for w in caught])
        assert float(np.sum(model.point_mass)) == pytest.approx(
            1141.0 * float(np.sum(model.fem.rest_volume)), rel=1e-9)


def test_a_body_file_with_no_springs_is_told_to_list_them(tmp_path):
    """Session 29's report trial: a `.jello` file with `springs 0` was told "none within
    [springs] radius of another ... a larger radius joins them", though a file body has no
    radius.  The warning now names the file's springs section; a radius body keeps its own."""
    from jellysim.scene import Scene

    (tmp_path / "loose.jello").write_text("jello 1\npoints 3\n0 0 0\n1 0 0\n0 1 0\nsprings 0\n"
                                          "end\n")
    scene = tmp_path / "s.toml"
    scene.write_text('[material]\npreset = "paper-2010"\n[body]\ntype = "file"\n'
                     'path = "loose.jello"\n[mass]\npoint_mass = 0.1\n[integrator]\nsteps = 2\n')
    with pytest.warns(UserWarning, match=r"no spring \(3 points, its file lists none\).*"
                      r"give the file a springs section") as got:
        Scene.load(scene).build_model()
    assert not any("radius" in str(w.message) for w in got)
