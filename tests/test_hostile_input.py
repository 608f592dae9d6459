"""Nothing silent (issue 13): the crash reproducers become located errors, the reader follows
its spec exactly, and a bounded fuzz run lets only jellysim's own errors escape."""
from __future__ import annotations

import io
import math
import random
import re
import time
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from jellysim.cli import cli
from jellysim.errors import (JelloFileError, JellysimError, ResourceError, SceneError)
from jellysim.geometry.jellyfile import parse_jello, read_body, read_jello, write_body
from jellysim.geometry.jellyfile import read_npz as read_body_npz
from jellysim.scene import Scene

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
meta {"builder": "test", "h": 0.5}
end
"""

BOX = """
[body]
points = 40
lower = [0.0, 0.1, 0.0]
upper = [0.2, 0.3, 0.2]
[springs]
radius = 0.1
stiffness = 100.0
[integrator]
dt = 0.001
steps = 10
"""


def _jello(tmp_path, text, name="b.jello") -> Path:
    p = tmp_path / name
    p.write_bytes(text.encode("utf-8") if isinstance(text, str) else text)
    return p


def _error(tmp_path, text) -> str:
    with pytest.raises(JelloFileError) as info:
        read_jello(_jello(tmp_path, text))
    return str(info.value)


# -- the seven crash signatures ----------------------------------------------------------------

def test_huge_digit_counts_and_indices_are_located_errors(tmp_path):
    msg = _error(tmp_path, VALID.replace("points 4 mass", "points " + "9" * 5000 + " mass"))
    assert "b.jello:3:8:" in msg and "digits" in msg
    msg = _error(tmp_path, VALID.replace("0 1 1.0 100.0", "0 " + "1" * 5000 + " 1.0 100.0"))
    assert "b.jello:9:3:" in msg and "out of range" in msg
    # also from a scene that names the file
    p = _jello(tmp_path, VALID.replace("springs 3", "springs " + "7" * 4400))
    scene = tmp_path / "s.toml"
    scene.write_text(BOX.replace("points = 40\n", "").replace(  # keys a file body ignores
        "lower = [0.0, 0.1, 0.0]\nupper = [0.2, 0.3, 0.2]\n", "").replace(
        "radius = 0.1\n", "").replace("[body]", f'[body]\ntype = "file"\npath = "{p.name}"'))
    r = CliRunner().invoke(cli, ["run", str(scene), "-o", str(tmp_path / "o"), "--quiet"])
    assert r.exit_code == 2 and "b.jello:8:9:" in r.output and "Traceback" not in r.output


def test_deep_huge_or_nonfinite_meta_is_refused(tmp_path):
    deep = "[" * 100_000 + "]" * 100_000
    assert "nested deeper" in _error(tmp_path, VALID.replace(
        '{"builder": "test", "h": 0.5}', '{"a": ' + deep + "}"))
    assert "digits" in _error(tmp_path, VALID.replace("0.5}", "1" * 5000 + "}"))
    for bad in ("NaN", "Infinity", "-Infinity", "1e999"):
        msg = _error(tmp_path, VALID.replace("0.5}", bad + "}"))
        assert "b.jello:14:6:" in msg and "finite" in msg, msg


def test_zero_points_is_refused_in_both_formats(tmp_path):
    text = "jello 1\npoints 0\nsprings 0\nend\n"
    assert "b.jello:2:8:" in _error(tmp_path, text) and "at least one point" in _error(
        tmp_path, text)
    p = tmp_path / "z.npz"
    np.savez(p, format=np.str_("jello-npz 1"), points=np.zeros((0, 3)),
             springs=np.zeros((0, 2), dtype=np.int64))
    with pytest.raises(JelloFileError, match="at least one point"):
        read_body(p)


def _lying_npz(path, rows):
    """A valid-looking body .npz whose 'points' header claims ``rows`` rows."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                               "shape": (rows, 3)})
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("format.npy", _npy(np.str_("jello-npz 1")))
        zf.writestr("points.npy", buf.getvalue() + b"\0" * 48)
        zf.writestr("springs.npy", _npy(np.zeros((0, 2), dtype=np.int64)))


def _npy(a) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


@pytest.mark.parametrize("rows", [10**12, 5 * 10**7])
def test_npz_whose_header_claims_huge_rows_allocates_nothing(tmp_path, rows):
    p = tmp_path / "liar.npz"
    _lying_npz(p, rows)
    assert p.stat().st_size < 1000
    tracemalloc.start()
    try:
        with pytest.raises(JelloFileError, match="claims shape") as info:
            read_body(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert "points" in str(info.value) and peak < 1 << 20
    # the CLI says it in one line
    r = CliRunner().invoke(cli, ["inspect", str(p)])
    assert r.exit_code == 2 and "claims shape" in r.output


def test_preset_of_the_wrong_type_names_the_key():
    with pytest.raises(SceneError, match=r"\[material\] preset = \[1\]"):
        Scene.from_text("[material]\npreset = [1]\n" + BOX)


def test_huge_box_point_counts_are_refused_before_building(monkeypatch):
    import jellysim.geometry.sampling as sampling

    def never(*a, **k):
        raise AssertionError("the body was built")

    monkeypatch.setattr(sampling, "box_field", never)
    scene = Scene.from_text(BOX.replace("points = 40", f"points = {2**31}"), name="s.toml")
    with pytest.raises(ResourceError, match=r"s.toml: \[body\] points") as info:
        scene.build_model()
    assert "2,147,483,648 points" in str(info.value) and "--max-memory" in str(info.value)
    monkeypatch.setenv("JELLYSIM_MAX_MEMORY", "4G")
    scene = Scene.from_text(BOX.replace("points = 40", "points = 20000000"), name="s.toml")
    with pytest.raises(ResourceError, match="limit 4 GiB"):
        scene.build_model()


def test_builders_refuse_huge_point_counts_and_all_pairs_provot_before_building(
        monkeypatch, tmp_path):
    from jellysim.build import build_body

    monkeypatch.setenv("JELLYSIM_MAX_MEMORY", "4G")
    t0 = time.perf_counter()
    mesh = Path(__file__).parent / "data" / "cube.obj"
    with pytest.raises(ResourceError, match="20,000,000 points"):
        build_body(mesh, points=20_000_000, connect="delaunay")
    r = CliRunner().invoke(cli, ["build", str(mesh), "--points", "20000000", "-o",
                                 str(tmp_path / "b.jello"), "--max-memory", "1G"])
    assert r.exit_code == 2 and "limit 1 GiB" in r.output
    assert time.perf_counter() - t0 < 5.0
    import jellysim.geometry.sampling as sampling

    monkeypatch.setattr(sampling, "box_field", lambda *a, **k: 1 / 0)
    scene = Scene.from_text(BOX.replace("points = 40", "points = 5000") +
                            "[provot]\nenabled = true\npairs = 'all'\n", name="s.toml")
    with pytest.raises(SceneError, match=r"pairs = 'all'.*\[body\] points = 5000"):
        scene.build_model()


# -- the reader follows its spec ---------------------------------------------------------------

def test_line_breaks_are_lf_or_crlf_only(tmp_path):
    # CR LF is accepted and gives the same body
    a = read_jello(_jello(tmp_path, VALID))
    b = read_jello(_jello(tmp_path, VALID.replace("\n", "\r\n"), "crlf.jello"))
    assert np.array_equal(a.points, b.points) and np.array_equal(a.springs, b.springs)
    # a bare CR is an error at its place
    msg = _error(tmp_path, VALID.replace("# a tiny body\n", "# a tiny\rbody\n"))
    assert "b.jello:2:9:" in msg and "carriage return" in msg
    # U+2028, form feed, NEL inside a comment are not line breaks: later lines keep numbers
    for ch in ("\u2028", "\f", "\x85"):
        text = VALID.replace("# a tiny body", f"# a {ch} tiny body").replace(
            "1 2 1.5 50.0", "1 2 1.5 -50.0")
        assert "b.jello:11:9:" in _error(tmp_path, text), repr(ch)
    # ... and in data they are not token separators
    assert "b.jello:4:" in _error(tmp_path, VALID.replace("0.0 0.0 0.0 0.25",
                                                          "0.0\u20280.0 0.0 0.25", 1))


def test_only_ascii_digits(tmp_path):
    msg = _error(tmp_path, VALID.replace("points 4", "points \u0664"))   # Arabic-Indic 4
    assert "b.jello:3:8:" in msg and "row count" in msg
    msg = _error(tmp_path, VALID.replace("0 1 1.0 100.0", "0 \uff11 1.0 100.0"))  # fullwidth 1
    assert "b.jello:9:3:" in msg
    msg = _error(tmp_path, VALID.replace("1.0 0.0 0.0 0.25", "\u0661.0 0.0 0.0 0.25"))
    assert "b.jello:5:1:" in msg


def test_utf8_errors_give_line_and_column(tmp_path):
    raw = VALID.replace("# a tiny body", "# a tiny body \u00e9X").encode("utf-8")
    raw = raw.replace("\u00e9".encode(), b"\xe9")        # a Latin-1 byte: invalid UTF-8
    with pytest.raises(JelloFileError) as info:
        read_jello(_jello(tmp_path, raw))
    assert "b.jello:2:15:" in str(info.value) and "0xe9" in str(info.value)


def test_written_meta_reads_back_and_reader_agrees_with_writer(tmp_path):
    body = read_jello(_jello(tmp_path, VALID))
    assert body.meta == {"builder": "test", "h": 0.5}
    write_body(tmp_path / "c.jello", body)
    write_body(tmp_path / "c.npz", body)
    assert read_body(tmp_path / "c.jello").meta == read_body(tmp_path / "c.npz").meta


# -- fuzz -------------------------------------------------------------------------------------

_ALPHABET = ["\n", "\r\n", "\r", " ", "\t", "#", "-", "+", ".", "e", "9" * 30, "0", "1", "4",
             "nan", "inf", "\u2028", "\x85", "\u0664", "{", "}", "[", "]", '"', ":", ",",
             "1e999", "points", "springs", "tets", "triangles", "meta", "volume", "end",
             "mass", "stiffness", "jello 1", "\x00", "\xe9", "\ud7ff"]


def _mutate(rng: random.Random, text: str) -> str:
    s = list(text)
    for _ in range(rng.randint(1, 4)):
        op = rng.random()
        i = rng.randrange(len(s) + 1)
        if op < 0.35 and s:
            del s[rng.randrange(len(s)):rng.randrange(len(s)) + rng.randint(1, 12)]
        elif op < 0.7:
            s[i:i] = list(rng.choice(_ALPHABET))
        elif op < 0.85 and s:
            j = rng.randrange(len(s))
            s[j] = rng.choice(_ALPHABET)
        else:                                     # duplicate a slice (repeated sections/rows)
            a = rng.randrange(len(s) + 1)
            s[i:i] = s[a:a + rng.randint(1, 60)]
    return "".join(s)


def _npz_cases(rng, base: dict):
    """Mutated body .npz files: wrong dtypes/shapes, lying headers, NaNs, garbage bytes."""
    d = {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in base.items()}
    key = rng.choice(sorted(d))
    op = rng.randrange(7)
    if op == 0:
        try:
            d[key] = np.asarray(d[key]).astype(rng.choice(["f4", "i2", "U3", "c16", "?"]))
        except (ValueError, TypeError):
            d[key] = np.zeros(3, dtype="c16")
    elif op == 1:
        d[key] = np.asarray(d[key]).reshape(-1)[: rng.randrange(1, 12)]
    elif op == 2 and np.asarray(d[key]).dtype.kind == "f" and np.asarray(d[key]).size:
        a = np.asarray(d[key]).copy()
        a.flat[rng.randrange(a.size)] = rng.choice([np.nan, np.inf, -1e308, 0.0])
        d[key] = a
    elif op == 3 and np.asarray(d[key]).dtype.kind == "i" and np.asarray(d[key]).size:
        a = np.asarray(d[key]).copy()
        a.flat[rng.randrange(a.size)] = rng.choice([-1, 4, 2**62, 0])
        d[key] = a
    elif op == 4:
        del d[key]
    elif op == 5:
        d["meta"] = np.str_(rng.choice(['{"a": NaN}', "[" * 5000, '{"a": 1' + "0" * 5000 + "}",
                                        "{", '"x"', "{}"]))
    buf = io.BytesIO()
    np.savez(buf, **d)
    raw = bytearray(buf.getvalue())
    if op == 6:                                   # flip or cut bytes anywhere
        for _ in range(rng.randint(1, 6)):
            raw[rng.randrange(len(raw))] = rng.randrange(256)
        if rng.random() < 0.5:
            raw = raw[: rng.randrange(len(raw))]
    return bytes(raw)


_SCENE_VALUES = ["[1]", "1e999", "-1", "0", "2", "'x'", "true", "nan", "inf", "[0, 0]",
                 "{a = 1}", str(2**31), "9" * 40, "'gelatin'", "'file'", "'mesh'",
                 "1.0", '"b.jello"', "[1.0, 2.0, 3.0]"]


def _scene_case(rng, base: str) -> str:
    lines = base.strip().splitlines()
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(lines))
        op = rng.random()
        if op < 0.5 and "=" in lines[i]:
            k = lines[i].split("=")[0]
            lines[i] = f"{k}= {rng.choice(_SCENE_VALUES)}"
        elif op < 0.7:
            lines.insert(i, rng.choice(["[material]", "preset = " + rng.choice(_SCENE_VALUES),
                                        "[provot]", "[output]", "[[obstacle]]",
                                        "kind = 'plane'", "bogus = 1", "[bogus]"]))
        elif op < 0.85:
            del lines[i]
        else:
            lines[i] = _mutate(rng, lines[i])
    return "\n".join(lines) + "\n"


def test_fuzz_only_jellysim_errors_escape(tmp_path, monkeypatch):
    """2,400 seeded mutations of a .jello text, a body .npz and a scene (which also names the
    mutated body file): each is read, and a scene is validated and its body built (box scenes
    under a 256 MB memory limit, no run); anything but a JellysimError fails the test, as does
    a case that takes over 5 s (a hang)."""
    monkeypatch.setenv("JELLYSIM_MAX_MEMORY", "256M")
    rng = random.Random(2013)
    body = read_jello(_jello(tmp_path, VALID))
    write_body(tmp_path / "base.npz", body)
    with np.load(tmp_path / "base.npz") as z:
        base_npz = {k: z[k] for k in z.files}
    scene_base = BOX + '\n# file scenes read b.jello\n'
    Scene.from_text(scene_base).build_body()     # warm up (imports, compilation)
    counts = {"jello": 0, "npz": 0, "scene": 0}
    t_start = time.perf_counter()
    for case in range(2400):
        kind = ("jello", "npz", "scene")[case % 3]
        t0 = time.perf_counter()
        try:
            if kind == "jello":
                parse_jello(_mutate(rng, VALID).encode("utf-8", "surrogatepass"), name="f")
            elif kind == "npz":
                read_body_npz(io.BytesIO(_npz_cases(rng, base_npz)))
            else:
                text = _scene_case(rng, scene_base)
                if rng.random() < 0.3:   # a file scene reading a mutated body file
                    text = text.replace("[body]", '[body]\ntype = "file"\npath = "b.jello"')
                    _jello(tmp_path, _mutate(rng, VALID).encode("utf-8", "surrogatepass"))
                sc = Scene.from_text(text, name=str(tmp_path / "s.toml"))
                if sc.params["body"]["type"] != "mesh":
                    sc.build_body()
            counts[kind] += 1
        except JellysimError:
            counts[kind] += 1
        except Exception as exc:  # noqa: BLE001 - the point of the test
            raise AssertionError(f"case {case} ({kind}) escaped as {type(exc).__name__}: "
                                 f"{exc}") from exc
        assert time.perf_counter() - t0 < 5.0, f"case {case} ({kind}) took too long (hang?)"
    assert sum(counts.values()) == 2400
    assert time.perf_counter() - t_start < 60


def test_overlapping_shells_are_reported_and_mass_follows_the_inside_rule(tmp_path):
    """Two unit spheres 0.6 apart: the parity rule leaves their lens empty, so the body's
    volume is 2 V - 2 V_lens (V_lens = pi (4 r + d)(2 r - d)^2 / 12), not the signed 2 V
    (2.3x more); inspect says the shells overlap; a single sphere is not flagged."""
    from jellysim.build import body_stats, build_body, shell_overlap
    from jellysim.geometry.mesh import load_mesh

    data = Path(__file__).parent / "data"
    mesh = load_mesh(data / "overlapping_spheres.obj")
    v_one = abs(load_mesh(data / "sphere.obj").defects.volume)     # the icosphere's volume
    lens = np.pi * (4 + 0.6) * (2 - 0.6) ** 2 / 12
    over, inside_vol, signed = shell_overlap(mesh)
    assert over and signed == pytest.approx(2 * v_one, rel=1e-9)
    assert inside_vol == pytest.approx(2 * v_one - 2 * lens, rel=0.03)
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        body = build_body(mesh, points=300, connect="radius", density=1000.0, seed=1)
    said = [str(w.message) for w in caught]
    assert any("overlap or nest" in m for m in said) and not any("open" in m for m in said)
    assert body_stats(body, density=1000.0)["mass"] == pytest.approx(1000.0 * inside_vol,
                                                                    rel=0.01)
    r = CliRunner().invoke(cli, ["inspect", str(data / "overlapping_spheres.obj")])
    assert "shells overlap/nest:     yes" in r.output
    assert not shell_overlap(load_mesh(data / "sphere.obj"))[0]  # (one shell: compared too)
    assert not shell_overlap(load_mesh(data / "hollow_sphere.obj"))[0]


def test_surface_samples_on_a_box_scene_is_refused_not_ignored():
    with pytest.raises(SceneError, match=r"\[body\] surface_samples is used only by"):
        Scene.from_text(BOX.replace("[body]", "[body]\nsurface_samples = false"))


def test_a_body_below_the_ground_is_refused_with_the_fix():
    """A body starting 4 cm inside the ground would be shot out of it (the contact puts every
    point below the plane onto it at once): refused, naming the depth and the fix; a body
    resting on the plane (its lowest point at y = 0) is fine."""
    import jellysim as js
    from jellysim.errors import SceneError

    sphere = Path(__file__).parent / "data" / "sphere.obj"
    body = js.Body.from_mesh(sphere, size=0.08, points=200, connect="marching")  # centred
    model = js.physical_model(body, js.material("gelatin"))
    depth = -float(model.point_x0[:, 1].min())
    with pytest.raises(SceneError, match=r"starts 0\.0\d+ m below the ground.*base"):
        js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    js.Simulator(model, dt=1 / 60)  # no ground: nothing to refuse
    placed = js.Body.from_mesh(sphere, size=0.08, points=200, connect="marching",
                               base=(0, 0, 0))
    js.Simulator(js.physical_model(placed, js.material("gelatin")), dt=1 / 60,
                 ground=js.GroundParams(model="contact"))
    assert depth > 0.03


def test_a_box_scene_below_the_ground_is_refused_by_the_cli(tmp_path):
    """The paper preset starts from a given state (zero acceleration): still checked."""
    from jellysim.cli import cli

    scene = tmp_path / "s.toml"
    scene.write_text('[material]\npreset = "paper-2010"\n[body]\ntype = "box"\npoints = 100\n'
                     "lower = [0.0, -0.05, 0.0]\nupper = [0.1, 0.05, 0.1]\n[springs]\n"
                     "radius = 0.05\n[integrator]\nsteps = 2\n")
    r = CliRunner().invoke(cli, ["run", str(scene), "-o", str(tmp_path / "out"), "--quiet"])
    assert r.exit_code == 2, r.output
    assert "0.05 m below the ground" in r.output and "[body] lower" in r.output
    assert "s.toml:" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "out").exists()  # refused: no empty output folder left


def test_python_api_mistakes_name_the_parameter_and_the_choices():
    import jellysim as js
    from jellysim.errors import BuildError, SceneError

    sphere = Path(__file__).parent / "data" / "sphere.obj"
    with pytest.raises(BuildError, match=r"connect must be one of .*did you mean 'delaunay'"):
        js.Body.from_mesh(sphere, connect="delauney")
    with pytest.raises(ValueError, match=r"'poisson' \(did you mean 'poisson_ratio'\?\)"):
        js.material("gelatin", poisson=0.3)
    body = js.Body.from_mesh(sphere, size=0.05, points=100, connect="marching", base=(0, 0, 0))
    with pytest.raises(ValueError, match=r"gravity must be 3 finite numbers"):
        js.physical_model(body, js.material("gelatin"), gravity=(0, -9.8))
    assert "\n" not in repr(body) and f"{body.point_count} points" in repr(body)
    sim = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    n = body.point_count
    with pytest.raises(SceneError, match=rf"pin: point index {10**6} is out of range.*{n} points"):
        sim.pin([10**6])
    low = sim.state.x[:, 1] < sim.state.x[:, 1].min() + 0.01  # a boolean mask: the bottom
    sim.pin(low)
    assert np.array_equal(np.flatnonzero(sim.handles.pinned), np.flatnonzero(low))
    assert low.sum() > 2
    with pytest.raises(SceneError, match="one entry per point"):
        sim.pin(low[:-1])
    with pytest.raises(SceneError, match="must be integers"):
        sim.pin([2.7])
    with pytest.raises(SceneError, match=r"apply_force: force \[N\] must be 3 numbers"):
        sim.apply_force([0], [1.0, 2.0])
    with pytest.raises(SceneError, match=r"drag: target \[m\] must be 3 numbers"):
        sim.drag(0, [0.0, 1.0])


def test_point_selections_refuse_empty_inverted_and_negative_shapes():
    """A selection that cannot mean what was typed is an error naming the fix, not a silent
    reinterpretation (a negative radius used to select like a positive one)."""
    import jellysim as js
    from jellysim.errors import SceneError

    x = np.random.default_rng(0).uniform(0, 0.1, (200, 3))
    with pytest.raises(SceneError, match="indices is empty"):
        js.select_points(x, indices=[])
    with pytest.raises(SceneError, match="must not exceed upper.*swap them"):
        js.select_points(x, box=[[0.1, 0.1, 0.1], [0.0, 0.0, 0.0]])
    with pytest.raises(SceneError, match="radius must be a number > 0"):
        js.select_points(x, sphere=([0.05, 0.05, 0.05], -0.02))
    inside = js.select_points(x, sphere=([0.05, 0.05, 0.05], 0.02))
    assert np.array_equal(inside, np.flatnonzero(np.linalg.norm(x - 0.05, axis=1) <= 0.02))


def test_a_physical_blow_up_names_the_handle_not_an_infinite_dt():
    """A force no material can hold (1e30 N) blows the physical path up even after its
    substep doublings; the error says what does that instead of 'stable limit inf s'."""
    import jellysim as js
    from jellysim.errors import SimulationError, StabilityWarning

    sphere = Path(__file__).parent / "data" / "sphere.obj"
    body = js.Body.from_mesh(sphere, size=0.04, points=60, connect="marching", base=(0, 0, 0))
    sim = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    sim.apply_force([0], [1e30, 0.0, 0.0])
    with pytest.warns(StabilityWarning), pytest.raises(SimulationError) as info:
        sim.advance(2)
    assert "too strong for the material" in str(info.value) and "inf" not in str(info.value)


@pytest.mark.parametrize("override", [{"density": 1e-9}, {"youngs_modulus": 1e12}])
def test_an_absurd_material_is_refused_before_it_runs_for_minutes(override):
    """A gelatin body with a near-zero density or a steel-like modulus would need 10^5-10^7
    substeps per frame (a frame running for minutes, in a kernel Ctrl-C cannot stop): refused
    at once, saying how many and which parameters set it.  The count is the stability limit's
    (omega_max from the body's rest stiffness), so the refusal scales as sqrt(E / rho)."""
    import jellysim as js
    from jellysim.simulator import MAX_AUTO_SUBSTEPS

    sphere = Path(__file__).parent / "data" / "sphere.obj"
    body = js.Body.from_mesh(sphere, size=0.04, points=60, base=(0, 0, 0))
    ok = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    # sqrt(E / rho) grows by sqrt(1141 / 1e-9) or sqrt(1e12 / 1e4) over the gelatin's count
    assert ok.substeps * math.sqrt(1e8) > MAX_AUTO_SUBSTEPS
    with pytest.raises(SceneError, match=r"needs \d+ substeps per step.*youngs_modulus.*density"):
        js.Simulator(js.physical_model(body, js.material("gelatin", **override)), dt=1 / 60)


def _mesh_handle_scene(tmp_path, extra=""):
    mesh = Path(__file__).parent / "data" / "torus.obj"
    p = tmp_path / "s.toml"
    p.write_text(f"""[material]
preset = "gelatin"
[body]
type = "mesh"
path = "{mesh.as_posix()}"
points = 200
size = 0.08
base = [0.0, 0.0, 0.0]
{extra}
[[handle]]
kind = "pin"
box = [[-1.0, -1.0, -1.0], [1.0, 0.002, 1.0]]
""")
    return Scene.load(p)


def test_handles_on_a_springs_body_say_why_it_is_not_on_the_physical_path(tmp_path):
    """A gelatin mesh scene without [springs] connect gets a marching body (the physical path:
    the pin works); so does the report's radius builder (connect = 'radius': its own tets,
    session 27: it ran on springs and a dropped random cube flattened, its centre of mass
    at 40 % of its resting height); with [material] model = 'springs' asked for, pinning says why and the fix,
    instead of asking for the gelatin preset it already has."""
    sim = _mesh_handle_scene(tmp_path, "[integrator]\nsteps = 2").simulator()
    assert sim.physical and int(sim.handles.pinned.sum()) > 0
    assert sim.model.body.meta["connect"] == "marching"
    sim = _mesh_handle_scene(tmp_path, '[springs]\nconnect = "radius"\n[integrator]\n'
                             'steps = 2').simulator()
    assert sim.physical and int(sim.handles.pinned.sum()) > 0
    assert sim.model.body.meta["connect"] == "radius"
    f = tmp_path / "s.toml"
    f.write_text(f.read_text().replace('preset = "gelatin"', 'preset = "gelatin"\nmodel = '
                                       '"springs"'))
    scene = Scene.load(f)
    with pytest.raises(SceneError, match=r"runs on springs: \[material\] model = 'springs'"):
        scene.simulator()


def test_an_integrator_that_takes_a_tet_body_off_the_physical_path_is_said(tmp_path):
    """[integrator] name = 'implicit' on a gelatin tet body runs it on calibrated springs
    (the implicit integrator has no tet forces): a warning says so instead of swapping the
    material model silently."""
    scene = _mesh_handle_scene(tmp_path, '[springs]\nconnect = "marching"\n'
                               '[integrator]\nname = "implicit"\nsteps = 2')
    scene.params.pop("handle")
    with pytest.warns(UserWarning, match=r"calibrated springs, not its FEM tets.*implicit"):
        model = scene.build_model()
    assert getattr(model, "fem", None) is None


def test_a_box_body_refuses_base():
    """A box field is placed by [body] lower and upper; [body] base (mesh and file bodies)
    used to be accepted and ignored."""
    example = Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml"
    with pytest.raises(SceneError, match=r"base is not used for \[body\] type = 'box'"):
        Scene.load(example, overrides=["body.base=[0, 0, 0]"])
    assert Scene.load(example).params["body"]["base"] is None


def test_session_8_trial_mistakes_are_said(tmp_path):
    """From session 8's new-user trial: a mesh in millimetres (read as metres: a 50 m body)
    warns with the fix; `sampling` with the marching builder (which places its own grid) is
    refused instead of ignored; an inside-out closed mesh's negative volume is explained by
    inspect; a body file's own masses replaced by the gelatin material are said."""
    import warnings

    from click.testing import CliRunner
    from conftest import mesh_path

    from jellysim.build import build_body
    from jellysim.cli import cli
    from jellysim.errors import BuildError
    from jellysim.geometry import load_mesh
    from jellysim.geometry.jellyfile import write_body
    from jellysim.geometry.mesh import Mesh

    cube = load_mesh(mesh_path("cube.obj"))  # [-1, 1]^3: 2 units
    in_mm = Mesh.from_arrays(cube.vertices * 25.0, cube.faces, name="cube_mm")
    with pytest.warns(UserWarning, match=r"50 m across .* millimetres .*size"):
        build_body(in_mm, points=50, connect="radius")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same mesh scaled is quiet
        build_body(in_mm, points=50, connect="radius", size=0.05)
    with pytest.raises(BuildError, match=r"sampling='edge' applies to connect='radius' or "
                                         r"'delaunay'"):
        build_body(mesh_path("cube.obj"), points=100, connect="marching", sampling="edge")
    flipped = tmp_path / "inside_out.obj"
    flipped.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in cube.vertices)
                       + "".join(f"f {a + 1} {c + 1} {b + 1}\n" for a, b, c in cube.faces))
    res = CliRunner().invoke(cli, ["inspect", str(flipped)])
    assert res.exit_code == 0 and "wound inward" in res.output
    body = build_body(mesh_path("cube.obj"), points=100, connect="marching", size=0.05,
                      density=1000.0)  # (at the material's own density nothing is said:
    assert body.masses is not None       # test_jellyfile.py, session 28)
    write_body(tmp_path / "cube.jello", body)
    (tmp_path / "s.toml").write_text('[material]\npreset = "gelatin"\n[body]\ntype = "file"\n'
                                     'path = "cube.jello"\n[integrator]\nsteps = 1\n')
    with pytest.warns(UserWarning, match=r"body file's own masses .* replaced by the material"):
        Scene.load(tmp_path / "s.toml").build_model()


def test_session_9_a_run_says_the_build_warnings_first_and_names_the_file(tmp_path):
    """From session 9's new-user trial: `jellysim run` said a mesh's unit warning only after
    simulating (and named it "mesh"); when the build then refused the body (far below the
    ground) the warning that explains why was lost.  Now it comes first, names the file, and
    also precedes the refusal."""
    from click.testing import CliRunner
    from conftest import mesh_path

    from jellysim.cli import cli
    from jellysim.geometry import load_mesh

    cube = load_mesh(mesh_path("cube.obj"))  # [-1, 1]^3: 2 units, read as 2 m... x 25
    (tmp_path / "cube_mm.obj").write_text(
        "".join(f"v {x * 25} {y * 25} {z * 25}\n" for x, y, z in cube.vertices)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in cube.faces))
    scene = ('[body]\ntype = "mesh"\npath = "cube_mm.obj"\npoints = 30\n{base}[springs]\n'
             'stiffness = 1.0\n[integrator]\ndt = 0.01\nsteps = 2\n')
    (tmp_path / "s.toml").write_text(scene.format(base="base = [0, 0, 0]\n"))
    res = CliRunner().invoke(cli, ["run", str(tmp_path / "s.toml"), "--out",
                                   str(tmp_path / "o"), "--quiet", "--no-vtu"])
    assert res.exit_code == 0, res.output
    said = res.output.index(f"warning: {tmp_path / 'cube_mm.obj'}: the mesh is 50 m across")
    assert said < res.output.index("2 steps, ")
    (tmp_path / "t.toml").write_text(scene.format(base=""))  # centred on 0: half below
    res = CliRunner().invoke(cli, ["run", str(tmp_path / "t.toml"), "--out",
                                   str(tmp_path / "p"), "--quiet"])
    assert res.exit_code != 0
    assert res.output.index("50 m across") < res.output.index("below the ground")
    for target in ("t.toml", "cube_mm.obj"):  # inspect says it too, for a scene and a mesh
        res = CliRunner().invoke(cli, ["inspect", str(tmp_path / target)])
        assert "50 m across" in res.output, res.output


@pytest.mark.parametrize("text, said", [
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", r":4: face vertex 7 does not exist \(the file has 3"),
    ("v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n", r":2: a vertex needs three numbers"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 two 3\n", r":4: 'two' is not a vertex number"),
    # 0-based (the loader itself wraps index 0 around to the last vertex, silently)
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 0 1 2\nf 0 1 3\nf 1 2 3\nf 0 2 3\n",
     r":5: face vertex 0 does not exist .* OBJ numbers them from 1"),
])
def test_a_broken_obj_is_blamed_on_its_line(tmp_path, text, said):
    """Session 9's trial: a broken OBJ said "could not parse the file (IndexError: index 6
    ...)", a 0-based number for a 1-based format and no line.  Now: file:line, what, fix."""
    from jellysim.errors import MeshError
    from jellysim.geometry import load_mesh

    path = tmp_path / "broken.obj"
    path.write_text(text)
    with pytest.raises(MeshError, match=said):
        load_mesh(path)


def test_a_body_meant_to_travel_far_is_not_a_blow_up_when_said(tmp_path):
    """Session 9's trial: a block sliding at 60 m/s on a frictionless plate was stopped as
    "unstable" once 100 m from its start.  The error says how to allow it
    ([integrator] runaway_distance), and with it the block slides on at 60 m/s (frictionless:
    its centre of mass moves at exactly its speed)."""
    from jellysim.errors import SimulationError

    text = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
            'velocity = [60.0, 0.0, 0.0]\n[ground]\nfriction = 0.0\n[integrator]\nsteps = 120\n')
    import warnings

    from jellysim.simulator import StabilityWarning

    scene = Scene.from_text(text)
    sim = scene.simulator()
    with warnings.catch_warnings():
        warnings.simplefilter("error", StabilityWarning)  # no retakes: it did not blow up
        with pytest.raises(SimulationError, match=r"travelled more than 100 m .* intact: "
                                                  r"nothing went unstable.*\[integrator\] "
                                                  r"runaway_distance") as info:
            sim.advance(scene.steps)
    assert "doubled" not in str(info.value) and "dt <=" not in str(info.value)
    assert sim.substeps == scene.simulator().substeps
    springs = Scene.from_text(text.replace('preset = "gelatin"', 'preset = "gelatin"\n'
                                           'model = "springs"').replace(
        "[integrator]", '[integrator]\nname = "symplectic"'))
    with pytest.raises(SimulationError, match=r"travelled more than 100 m .* intact"):
        springs.simulator().advance(springs.steps)  # the springs path says the same
    far = Scene.from_text(text.replace("steps = 120", "steps = 120\nrunaway_distance = 1e4"))
    sim = far.simulator()
    m = sim.model.point_mass
    x0 = m @ sim.state.x / m.sum()
    sim.advance(far.steps)
    travelled = (m @ sim.state.x / m.sum() - x0)[0]
    assert travelled == pytest.approx(60.0 * 2.0, rel=1e-9)


def test_a_misspelt_handle_key_gets_a_did_you_mean(tmp_path):
    """Session 9's trial: `forc = ...` in a [[handle]] named the key but offered no
    suggestion, unlike the other sections."""
    p = tmp_path / "h.toml"
    p.write_text('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
                 '[integrator]\nsteps = 2\n[[handle]]\nkind = "force"\nindices = [0]\n'
                 'forc = [0.0, 1.0, 0.0]\n')
    with pytest.raises(SceneError, match=r"\[\[handle\]\] #1: unknown key 'forc' \(did you "
                                         r"mean 'force'\?\)"):
        Scene.load(p).simulator()


def test_a_pin_path_row_of_three_numbers_is_named(tmp_path):
    """Session 15's trial: a path row [1, 0.01, 0] said "give rows [t, dx, dy, dz]" without
    saying which row."""
    p = tmp_path / "h.toml"
    p.write_text('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
                 '[integrator]\nsteps = 2\n[[handle]]\nkind = "pin"\nindices = [0]\n'
                 'path = [[0, 0, 0, 0], [1, 0.01, 0]]\n')
    with pytest.raises(SceneError, match=r"\[\[handle\]\] #1 path: row 2 is \[1, 0.01, 0\]: "
                                         r"give rows \[t, dx, dy, dz\]"):
        Scene.load(p).simulator()


def test_rendering_a_body_file_or_scene_says_to_run_it_first(tmp_path):
    """Session 9's trial: `jellysim render teapot.jello` said "not a jellysim trajectory (File
    is not a zip file)"; a body file, a scene or a mesh is now named as such, with the fix."""
    from click.testing import CliRunner

    from jellysim.cli import cli

    import numpy as np

    np.savez(tmp_path / "b.npz", points=np.zeros((4, 3)), springs=np.zeros((1, 2), int))
    for name in ("t.jello", "t.toml", "t.obj", "t.vtp", "b.npz"):
        if not name.endswith(".npz"):
            (tmp_path / name).write_text("x\n")
        res = CliRunner().invoke(cli, ["render", str(tmp_path / name), "-o",
                                       str(tmp_path / "x.png")])
        assert res.exit_code != 0 and "not a trajectory: run it first" in res.output
        assert not (tmp_path / "x.png").exists()


def test_a_grid_box_of_too_few_points_says_so():
    """Session 9's trial: `points = 3` with `distribution = "grid"` asked for a spring radius
    (which 8 or more points do not need); it now says a grid needs its 8 corners."""
    with pytest.raises(SceneError, match=r"points = 3: a grid box needs at least 8"):
        Scene.from_text('[body]\ntype = "box"\npoints = 3\ndistribution = "grid"\n'
                        '[springs]\nstiffness = 1.0\n[integrator]\ndt = 0.01\nsteps = 1\n')


@pytest.mark.parametrize("points", [5, 30])
def test_too_few_points_for_a_shape_is_one_clear_error(points):
    """Session 9's second trial: a torus of 5 points crashed deep inside (IndexError in
    tet_edges) where 50 points said the resolution is too coarse; now both say so."""
    import jellysim as js
    from jellysim.errors import BuildError

    with pytest.raises(BuildError, match="no tetrahedron was kept - the resolution is too "
                                         "coarse"):
        js.Body.from_mesh(Path(__file__).parent / "data" / "torus.obj", size=0.08,
                          points=points)


_GEL = '[material]\npreset = "gelatin"\n[body]\npoints = 27\n'


@pytest.mark.parametrize("extra,match", [
    ('[ground]\nmu = 0.3\n', r"\[ground\] mu is the report's paper ground's.*friction"),
    ('[mass]\ndensity = 500\n', r"\[mass\] density is not used.*from the preset 'gelatin'"
                                r".*set \[material\] density"),
    ('[provot]\nenabled = true\n', r"\[provot\] enabled = true.*not used by the physical"),
    ('[provot]\npairs = "all"\n', r'\[provot\] pairs = "all".*not used by the physical'),
    ('[springs]\nstiffness = 50\n', r"stiffness is not used with \[material\] preset = "
                                    r"'gelatin'"),
    ('[ground]\nmodel = "paper"\n', r"model = 'paper'.*springs path only.*fall through"),
    ('[ground]\nmu = 0.3\nfriction = 0.5\n', r"mu \(the paper ground's rule\) and friction"),
    ('[mass]\npoint_mass = 0.01\n', r"\[mass\] point_mass = 0.01 kg is not used.*density = "
                                     r"1141 kg/m\^3.*set \[material\] density"),
])
def test_keys_a_gelatin_scene_would_ignore_are_refused_with_the_fix(extra, match):
    """Session 10's trial: each of these ran and changed nothing (or, for the paper ground,
    let the tet body fall 5 m through the floor); each is now an error naming the key and
    the fix.  (point_mass: session 16's researcher trial; the tets' lumped masses won.)"""
    with pytest.raises(SceneError, match=match):
        scene = Scene.from_text(_GEL + extra, name="s.toml")
        scene.simulator(scene.build_model())


def test_a_tet_body_without_a_ground_model_lands_on_the_contact_ground():
    """A scene with [material] youngs_modulus (no preset) puts a box on the physical path; its
    unset [ground] model was the paper rule, which that path does not apply: the body fell
    4.9 m through the floor in 1 s, silently.  Unset, the model now follows the body's path
    (contact here, paper on the springs path), and the body rests on the plane: no point
    below it (the contact rule's non-penetration) after landing, and the box still 10 cm
    wide (within its landing's wobble).  Python's Simulator refuses the paper ground for a tet body, naming the fix."""
    import jellysim as js
    from jellysim.params import GroundModel

    text = ("[material]\nyoungs_modulus = 1e4\ndensity = 1141\n[body]\ntype = 'box'\n"
            "distribution = 'grid'\npoints = 64\nlower = [0, 0.02, 0]\nupper = [0.1, 0.12, 0.1]"
            "\n[integrator]\ndt = 0.016666666666666666\nsteps = 30\n")
    scene = Scene.from_text(text, name="s.toml")
    model = scene.build_model()
    sim = scene.simulator(model)
    assert sim.physical and sim.ground.model is GroundModel.CONTACT
    sim.advance(30)
    x = sim.state.x
    assert x[:, 1].min() >= -1e-9 and x[:, 1].max() > 0.09  # on the floor, not flattened
    assert np.ptp(x[:, 0]) == pytest.approx(0.1, rel=0.1)   # (still wobbling from the drop)
    springs = Scene.from_text(text.replace("[material]\nyoungs_modulus = 1e4\ndensity = 1141",
                                           "[springs]\nstiffness = 300.0\nradius = 0.06"),
                              name="s.toml")
    assert springs.ground_params(springs.build_model()).model is GroundModel.PAPER
    with pytest.raises(SceneError, match=r"paper ground.*springs path only.*model='contact'"):
        js.Simulator(model, dt=1 / 60, ground=js.GroundParams())
    with pytest.raises(ValueError, match=r"ground model must be one of \['paper', 'contact'\]"):
        js.GroundParams(model="contcat")
    with pytest.raises(ValueError, match=r"ground mu = 0.3: mu and nu are the report's paper"):
        js.GroundParams(model="contact", mu=0.3)
    with pytest.raises(ValueError, match=r"material model must be one of \['fem', 'springs'\]"):
        js.material("gelatin", model="fen")
    with pytest.warns(UserWarning, match=r"youngs_modulus = 10 Pa is outside 100 Pa"):
        js.material("gelatin", youngs_modulus=10)
    sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    sim.drag(0, (0.0, 0.2, 0.0))
    assert sim.handles.drag[0] == 0
    sim.drag(0, None)                     # the docstring's "None releases", as written
    assert sim.handles.drag[0] < 0


@pytest.mark.parametrize("name,kind", [("cube.obj", "a mesh"), ("body.jello", "a body file")])
def test_a_mesh_or_body_given_as_a_scene_says_how_to_use_it(tmp_path, name, kind):
    """`jellysim run cube.obj` said only "not valid TOML" (session 10's trial)."""
    (tmp_path / name).write_text("v 0 0 0\n")
    r = CliRunner().invoke(cli, ["run", str(tmp_path / name), "--quiet"])
    assert r.exit_code != 0 and kind in r.output and "not a scene" in r.output
    assert "[body] type =" in r.output and "Traceback" not in r.output


def test_a_body_metres_across_is_said_a_likely_slip_of_units():
    """Session 10's trial: a 10 m box (`upper = [10, 10, 10]`, meant as cm) and a mesh scaled
    to `size = 10` ran without a word, where E = 10 Pa is warned about.  Bodies larger than
    3 m now warn; the report's 1 m cube does not."""
    import warnings as w

    import jellysim as js

    with pytest.warns(UserWarning, match="10 m across: sizes are in metres"):
        js.Body.box(upper=(10.0, 10.0, 10.0), points=27)
    with pytest.warns(UserWarning, match="size is 10 m across"):
        js.Body.from_mesh(Path(__file__).parent / "data" / "cube.obj", size=10.0, points=64)
    with w.catch_warnings():
        w.simplefilter("error")
        js.Body.box(upper=(1.0, 1.0, 1.0), points=27)


def test_unit_slips_and_empty_bodies_are_said_once(tmp_path):
    """Session 11's hostile trial: `[material] density = 1.141` (g/cm^3) ran silently, 8,775
    substeps per frame; the Young's modulus warning was printed twice (once raw, from
    click's line); `--set springs.radius=0.001` made 600 loose particles without a word.  Each
    is now one warning naming the value and the unit."""
    from click.testing import CliRunner

    from jellysim.cli import cli

    scene = tmp_path / "slip.toml"
    scene.write_text('[material]\npreset = "gelatin"\ndensity = 1.141\nyoungs_modulus = 10\n'
                     '[body]\npoints = 27\n[integrator]\nsteps = 2\n')
    r = CliRunner().invoke(cli, ["run", str(scene), "-o", str(tmp_path / "o"), "--quiet"])
    assert r.exit_code == 0, r.output
    assert r.output.count("density = 1.141 kg/m^3 is outside") == 1
    assert r.output.count("youngs_modulus = 10 Pa is outside") == 1
    r = CliRunner().invoke(cli, ["inspect", str(scene)])  # (it printed Python's raw form)
    assert r.output.count("warning: material youngs_modulus = 10 Pa is outside") == 1
    assert "UserWarning" not in r.output
    with pytest.warns(UserWarning, match=r"has no spring \(600 points"):
        Scene.load(Path(__file__).parents[1] / "examples" / "paper_cube.toml",
                   overrides=("springs.radius=0.001",)).build_model()
    springs = Scene.from_text('[body]\npoints = 50\n[springs]\nradius = 0.5\nstiffness = 10.0\n'
                              '[mass]\ndensity = 1.141\n[integrator]\ndt = 0.001\nsteps = 2\n')
    with pytest.warns(UserWarning, match=r"\[mass\] density = 1.141 kg/m\^3 is outside"):
        springs.build_model()
    high = Scene.from_text('[material]\npreset = "gelatin"\n[body]\npoints = 27\n'
                           'lower = [0, 20, 0]\nupper = [0.1, 20.1, 0.1]\n')  # mm meant
    with pytest.warns(UserWarning, match=r"starts 20 m above the ground .* falls for 2.02 s"):
        high.simulator(high.build_model())


def test_scene_files_as_editors_save_them_and_odd_command_lines(tmp_path):
    """Session 11's hostile trial: a scene saved with a UTF-8 byte-order mark was "not valid
    TOML (line 1, column 1)", a Latin-1 comment named no line, `--max-memory abc` printed
    Python's float error and `-o ''` silently wrote to out/<scene>.  The BOM is read; the
    others name the line, the flag and the fix."""
    from click.testing import CliRunner

    from jellysim.cli import cli

    text = '[material]\npreset = "gelatin"\n[integrator]\nsteps = 2\n'
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert Scene.load(bom).params == Scene.from_text(text).params
    latin = tmp_path / "latin.toml"
    latin.write_bytes(b"# jello\n# caf\xe9\n" + text.encode())
    with pytest.raises(SceneError, match=r"latin.toml:2: not UTF-8 text \(byte 0xe9\)"):
        Scene.load(latin)
    r = CliRunner().invoke(cli, ["run", str(bom), "--max-memory", "abc"])
    assert r.exit_code == 2 and "--max-memory: memory size 'abc': expected" in r.output
    r = CliRunner().invoke(cli, ["run", str(bom), "-o", ""])
    assert r.exit_code == 2 and "--out is empty" in r.output


def test_two_pins_on_the_same_points_are_refused():
    """Session 11's hostile trial: two [[handle]] pins selecting the same points ran with the
    second silently replacing the first (the body held at 2 cm, not at the 5 cm asked).  An
    overlap where either pin moves along a path is refused, naming both tables; two fixed
    pins on a point agree and are accepted."""
    text = (_GEL + '[[handle]]\nkind = "pin"\nbox = [[-1, 0.09, -1], [1, 1, 1]]\n'
            '[[handle]]\nkind = "pin"\nindices = [0, 63]\npath = [[0, 0, 0, 0], [1, 0, 0.02, 0]]\n')
    scene = Scene.from_text(text, name="s.toml")
    with pytest.raises(SceneError, match=r"\[\[handle\]\] #2 pins 1 point\(s\) that \[\[handle\]\] "
                                         r"#1 already pins \(point 63\), one of them along a path"):
        scene.simulator(scene.build_model())
    fixed = Scene.from_text(text.replace("path = [[0, 0, 0, 0], [1, 0, 0.02, 0]]\n", ""),
                            name="s.toml")  # two fixed pins agree: accepted
    sim = fixed.simulator(fixed.build_model())
    assert sim.handles.pinned[[0, 63]].all()


def test_a_scene_body_that_cannot_be_built_names_the_scene_keys():
    """Session 11's hostile trial: a scene's `[springs] h = 1.0` failed with "marching_grid: no
    tetrahedron was kept", naming a function and no key of the file.  The error now names
    the scene and the keys the build read."""
    mesh = Path(__file__).parent / "data" / "sphere.obj"
    scene = Scene.from_text(f'[material]\npreset = "gelatin"\n[body]\ntype = "mesh"\n'
                            f'path = "{mesh}"\n[springs]\nh = 1.0\n[integrator]\nsteps = 2\n',
                            name="coarse.toml")
    with pytest.raises(SceneError, match=r'coarse.toml: building the body \(\[springs\] connect '
                                         r'= "marching", .*\[springs\] h = 1.0\): .*no '
                                         r'tetrahedron was kept'):
        scene.build_body()


def test_a_pin_path_below_the_ground_is_said():
    """Session 11's hostile trial: a pin path going 3 cm below the ground was held on the
    ground, silently (not where the path said).  It is warned when pinned, by how much; a
    path staying above is not."""
    import warnings

    import jellysim as js

    model = js.physical_model(js.Body.box((0, 0.02, 0), (0.05, 0.07, 0.05), points=27),
                              "gelatin")
    sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    top = js.select_points(sim.state.x, box=[[-1, 0.065, -1], [1, 1, 1]])
    with pytest.warns(UserWarning, match=r"takes pinned points 0.03 m below the ground"):
        sim.pin(top, path=[[0, 0, 0, 0], [1, 0, -0.1, 0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.pin(top, path=[[0, 0, 0, 0], [1, 0, -0.06, 0]])


def test_a_teachers_slips_in_python_and_scenes_are_named():
    """Session 12's teacher trial: ``provot=True`` (AttributeError), a scalar mass
    (``cannot reshape``), ``gravity=9.8`` and a spring key under [physics] now say what is
    wrong and what to write instead."""
    import jellysim as js
    from jellysim.scene import Scene

    pts, spr = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([[0, 1]])
    model = js.finalize(js.Body(points=pts, springs=spr), stiffness=2.0, point_mass=1.0)
    with pytest.raises(TypeError, match=r"provot must be a jellysim.ProvotParams .* got True"):
        js.Simulator(model, dt=0.01, provot=True)
    with pytest.raises(TypeError, match=r"implicit must be a jellysim.ImplicitParams"):
        js.Simulator(model, dt=0.01, implicit="bdf2")
    with pytest.raises(ValueError, match=r"masses must have shape \(2,\) \[kg\], one per point, "
                                         r"got shape \(\) \(one value for all: finalize\(body, "
                                         r"point_mass=...\)\)"):
        js.Body(points=pts, springs=spr, masses=0.5)
    with pytest.raises(ValueError, match=r"stiffness must have shape \(1,\) \[N/m\]"):
        js.Body(points=pts, springs=spr, stiffness=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"gravity must be a vector of 3 accelerations"):
        js.finalize(js.Body(points=pts, springs=spr), stiffness=2.0, point_mass=1.0, gravity=9.8)
    with pytest.raises(SceneError, match=r"\[physics\] unknown key 'stiffness' \(it is a key of "
                                         r"\[springs\]\)"):
        Scene.from_text("[body]\npoints = 10\n[physics]\nstiffness = 3.0\n[integrator]\n"
                        "dt = 0.01\nsteps = 1\n", name="s.toml")


def test_a_demo_of_a_mesh_too_thin_names_the_mesh_and_the_demos_option(tmp_path):
    """Session 12's artist trial: `demo --mesh thin_plate.obj` said only 'marching_grid: no
    tetrahedron was kept ... --h' (an option the demo lacks), not which file."""
    import trimesh
    from click.testing import CliRunner

    from jellysim.cli import cli

    trimesh.creation.box(extents=[0.08, 0.001, 0.06]).export(tmp_path / "plate.obj")
    r = CliRunner().invoke(cli, ["demo", "--mesh", str(tmp_path / "plate.obj"), "--out",
                                 str(tmp_path / "d"), "--frames", "2"])
    assert r.exit_code != 0
    assert f"--mesh {tmp_path / 'plate.obj'}: marching_grid: no tetrahedron" in r.output
    assert "a larger --points gives a finer grid" in r.output and "Traceback" not in r.output


def test_a_blow_up_mid_run_is_reported_as_one_not_as_a_bad_velocity(tmp_path):
    """Session 12's review: the start check on velocities ('give velocities in m/s') also
    fired on the velocities a blow-up left at the start of the next frame: the run was blamed
    on the user and not saved as failed.  It checks the first steps only now."""
    from click.testing import CliRunner

    from jellysim.cli import cli
    from jellysim.io.trajectory import load_trajectory

    scene = Path(__file__).resolve().parents[1] / "examples" / "paper_cube.toml"
    r = CliRunner().invoke(cli, ["run", str(scene), "--out", str(tmp_path / "r"), "--quiet",
                                 "--no-vtu", "--set", "springs.stiffness=2000"])
    assert r.exit_code != 0
    assert "went unstable" in r.output and "give velocities in m/s" not in r.output
    traj = load_trajectory(tmp_path / "r")
    assert traj.status.startswith("failed") and traj.frame_count > 1


@pytest.mark.parametrize("physical", [True, False])
def test_a_state_the_kernels_cannot_update_is_refused_before_any_step(physical):
    """Session 13's hostile trial: ``sim.state.v = np.zeros((3, 3))`` then ``advance`` crashed
    the process (segfault, glibc aborts: the kernels read and write past the array), an int
    ``x`` was truncated at every step, a float32 one or a list gave a numba traceback, and a
    State of another body was blamed on instability.  Each is now refused, naming the array,
    the shape (n, 3) and float64 it must have, and the state is left untouched."""
    import jellysim as js

    if physical:
        model = js.physical_model(js.Body.box(points=27), js.material("gelatin"))
        sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(model="contact"))
    else:
        body = js.Body.box(points=64, distribution="uniform", radius=0.05, seed=1)
        model = js.finalize(body, stiffness=50.0, density=100.0)
        sim = js.Simulator(model, dt=1e-3, ground=js.GroundParams())
    n = model.point_count
    good = {k: getattr(sim.state, k).copy() for k in "xva"}
    frozen = good["x"].copy()
    frozen.flags.writeable = False
    bad = {"a short array": np.zeros((3, 3)), "int64": good["x"].astype(np.int64),
           "float32": good["x"].astype(np.float32), "a list": good["x"].tolist(),
           "read-only": frozen, "not contiguous": np.asfortranarray(good["x"])}
    for name in "xva":
        for what, value in bad.items():
            setattr(sim.state, name, value)
            with pytest.raises(SceneError, match=rf"state\.{name} .* float64 array of "
                                                 rf"shape \({n}, 3\)"):
                sim.advance(1)
            setattr(sim.state, name, good[name].copy())
    assert sim.state.step == 0 and np.array_equal(sim.state.x, good["x"])
    sim.state.t = float("nan")
    with pytest.raises(SceneError, match=r"state\.t .* finite"):
        sim.advance(1)
    sim.state.t = 0.0
    sim.advance(2)                                   # a good state steps as before
    assert sim.state.step == 2 and np.all(np.isfinite(sim.state.x))
    other = js.physical_model(js.Body.box(points=8), js.material("gelatin")).state()
    with pytest.raises(SceneError, match=rf"Simulator\(state=\): state\.x .* \({n}, 3\)"):
        js.Simulator(model, dt=1 / 60, state=other)


def test_handle_tables_that_overlap_or_push_pinned_points_are_said():
    """Session 13's hostile trial: a second [[handle]] force on some of the points of a first
    silently replaced it there (1 N on every point plus 0.1 N up on the top layer ran with a
    net [0.75, 0.1, 0] N), gravity tables likewise, a force on pinned points did nothing
    without a word, and ``scale = true`` gave a Python traceback.  Overlapping force or
    gravity tables are refused naming both tables; a force on pinned points is warned; a
    non-number scale is refused naming its table."""
    base = ('[material]\npreset = "gelatin"\n[body]\npoints = 27\n[physics]\n'
            'gravity = [0, 0, 0]\n[ground]\nenabled = false\n')
    every = '[[handle]]\nkind = "{kind}"\nbox = [[-1, -1, -1], [2, 2, 2]]\n{value}\n'
    top = '[[handle]]\nkind = "{kind}"\nbox = [[-1, 0.099, -1], [2, 2, 2]]\n{value}\n'
    for kind, value in (("force", "force = [1.0, 0.0, 0.0]"), ("gravity", "scale = 0.5")):
        scene = Scene.from_text(base + every.format(kind=kind, value=value)
                                + top.format(kind=kind, value=value), name="h.toml")
        with pytest.raises(SceneError, match=r"h\.toml: \[\[handle\]\] #2 .* \[\[handle\]\] "
                                             r"#1 already does .* disjoint"):
            scene.simulator()
    # disjoint tables: the net force is the sum of the two (no point's force replaced)
    low = '[[handle]]\nkind = "force"\nbox = [[-1, -1, -1], [2, 0.098, 2]]\nforce = [1, 0, 0]\n'
    sim = Scene.from_text(base + low + top.format(kind="force", value="force = [0, 0.1, 0]"),
                          name="h.toml").simulator()
    assert sim.handles.point_force.sum(axis=0) == pytest.approx([1.0, 0.1, 0.0], rel=1e-12)
    pin = '[[handle]]\nkind = "pin"\nbox = [[-1, -1, -1], [2, 0.001, 2]]\n'
    with pytest.warns(UserWarning, match=r"#2 pushes 16 pinned point\(s\).* does nothing there"):
        Scene.from_text(base + pin + every.format(kind="force", value="force = [1, 0, 0]"),
                        name="h.toml").simulator()
    with pytest.warns(UserWarning, match=r"#2 scales gravity on 16 pinned point\(s\)"):
        Scene.from_text(base + pin + every.format(kind="gravity", value="scale = 0.5"),
                        name="h.toml").simulator()
    # session 20's trial: the same from Python said nothing; it says so too (and a scene
    # says it once, by its tables' names)
    import warnings

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        Scene.from_text(base + pin + every.format(kind="force", value="force = [1, 0, 0]"),
                        name="h.toml").simulator()
    assert len([w for w in said if "follows its pin" in str(w.message)]) == 1
    sim = Scene.from_text(base, name="h.toml").simulator()
    sim.pin([0, 1])
    with pytest.warns(UserWarning, match=r"apply_force: 1 of the 2 points given is pinned "
                                         r"\(point 1\).*the force does nothing there"):
        sim.apply_force([1, 2], [0.0, 0.1, 0.0])
    with pytest.warns(UserWarning, match=r"set_gravity_scale: 2 of the 3 points given are pinned"):
        sim.set_gravity_scale([0, 1, 2], 0.5)
    with pytest.raises(SceneError, match=r"indices must be point numbers, not true/false"):
        Scene.from_text(base + '[[handle]]\nkind = "pin"\nindices = [true, 2]\n',
                        name="h.toml").simulator()
    bad = Scene.from_text(base + every.format(kind="gravity", value="scale = true"),
                          name="h.toml")
    with pytest.raises(SceneError, match=r"h\.toml: \[\[handle\]\] #1 scale must be a finite "
                                         r"number"):
        bad.simulator()


def test_select_points_takes_the_scenes_sphere_and_names_bad_input():
    """Session 13's hostile trial: ``js.select_points(x, sphere={"center": ..., "radius":
    ...})`` (the scene's own form) raised ``KeyError: 0``, 2-D points a numpy broadcast error,
    and ``radius = true`` selected as radius 1 m.  The dict form now selects the same points as
    the tuple form (those within the radius, counted here directly); the rest are SceneErrors
    naming what to give."""
    import jellysim as js

    x = js.Body.box(points=27).points
    c, r = np.array([0.05, 0.05, 0.05]), 0.03
    want = np.flatnonzero(np.linalg.norm(x - c, axis=1) <= r)
    assert 0 < len(want) < len(x)
    assert np.array_equal(js.select_points(x, sphere={"center": c.tolist(), "radius": r}), want)
    assert np.array_equal(js.select_points(x, sphere=(c, r)), want)
    for kw, msg in ((dict(sphere={"center": c.tolist()}), "exactly 'center' and 'radius'"),
                    (dict(sphere=(c, True)), r"sphere must be \(\[x, y, z\], radius\)")):
        with pytest.raises(SceneError, match=msg):
            js.select_points(x, **kw)
    with pytest.raises(SceneError, match=r"shape \(n, 3\) .* got shape \(64, 2\)"):
        js.select_points(x[:, :2], box=[[0, 0, 0], [1, 1, 1]])


def test_keys_a_run_would_not_read_are_said():
    """Session 13's hostile trial: on the springs path these ran bitwise as without them,
    silently: the implicit integrator's keys with another integrator, the tet material's
    keys on springs, the ground's keys with the ground off.  Each is now warned, naming the
    keys and why; a scene giving none of them warns nothing."""
    import warnings

    text = ('[body]\npoints = 40\nlower = [0.0, 0.1, 0.0]\nupper = [0.2, 0.3, 0.2]\n'
            '[springs]\nradius = 0.1\nstiffness = 100.0\n[integrator]\ndt = 0.001\n'
            'steps = 5\n{i}\n[material]\n{m}\n[ground]\n{g}\n')
    cases = [(dict(i="theta = 0.5\nscheme = 'bdf2'"),
              r"\[integrator\] scheme, theta apply to name = 'implicit' only"),
             (dict(i="cg_tolerance = 0.5"), r"cg_tolerance apply to name = 'implicit'"),
             (dict(m="poisson_ratio = 0.1\ndamping_ratio = 0.9"),
              r"\[material\] poisson_ratio, damping_ratio act on the physical .* springs"),
             (dict(m="mass_scaling = 0.05"), r"mass_scaling acts on the physical"),
             (dict(g="enabled = false\nmu = 0.0"), r"\[ground\] mu given, but the ground is off")]
    for given, said in cases:
        kw = dict(i="", m="", g="") | given
        with pytest.warns(UserWarning, match=said):
            scene = Scene.from_text(text.format(**kw), name="s.toml")
            scene.simulator(scene.build_model())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = Scene.from_text(text.format(i="", m="", g=""), name="s.toml")
        scene.simulator(scene.build_model()).advance(1)


def test_python_options_that_were_taken_loosely_are_refused():
    """Session 13's hostile trial: ``Simulator(precision="float16")`` ran in float64,
    ``apply_force(total="no")`` split the force (a non-empty string is true) and
    ``drag([0, 1], ...)`` dragged point 0 only, each silently."""
    import jellysim as js

    model = js.physical_model(js.Body.box(points=27), js.material("gelatin"))
    with pytest.raises(SceneError, match="precision must be 'float64' or 'float32'"):
        js.Simulator(model, dt=1 / 60, precision="float16")
    sim = js.Simulator(model, dt=1 / 60)
    with pytest.raises(SceneError, match="total must be True .* or False"):
        sim.apply_force([0, 1], [1.0, 0.0, 0.0], total="no")
    assert not sim.handles.point_force.any()
    with pytest.raises(SceneError, match="drag: point must be one point index"):
        sim.drag([0, 1], [0.0, 0.0, 0.0])
    sim.apply_force([0, 1], [1.0, 0.0, 0.0], total=False)   # each point gets the force
    assert sim.handles.point_force[[0, 1], 0].tolist() == [1.0, 1.0]
    # substeps = 1e10 ran for hours without a word: refused beyond 100 x the auto limit
    from jellysim.simulator import MAX_AUTO_SUBSTEPS

    with pytest.raises(SceneError, match=r"substeps = 1e\+10 per step .* smaller dt"):
        js.Simulator(model, dt=1 / 60, substeps=1e10)
    assert js.Simulator(model, dt=1 / 60, substeps=2 * MAX_AUTO_SUBSTEPS).substeps == 20_000


def test_api_arguments_are_refused_as_jellysim_errors_naming_them():
    """Session 14's researcher trial: finalize took NaN gravity and NaN or negative rest
    lengths (the run then blamed dt at step 1, or ran on); and the API's argument errors were
    plain ValueErrors that ``except jellysim.JellysimError`` (the README's advice) missed.
    They are ParameterErrors: both a JellysimError and a ValueError."""
    import jellysim as js

    body = js.Body.box(points=27)
    with pytest.raises(js.ParameterError, match=r"gravity must be 3 finite"):
        js.finalize(body, stiffness=10.0, point_mass=0.01, gravity=(0.0, float("nan"), 0.0))
    for bad in (-1.0, float("nan")):
        body.rest_length = np.full(len(body.springs), 0.01)
        body.rest_length[3] = bad
        with pytest.raises(js.JellysimError, match=r"rest_length .* \(spring 3: "):
            js.finalize(body, stiffness=10.0, point_mass=0.01)
    with pytest.raises(ValueError):  # (still a ValueError for older callers)
        js.GroundParams(friction=-1.0)
    with pytest.raises(js.JellysimError):
        js.GroundParams(friction=-1.0)
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.jellyfile import write_body
    from jellysim.geometry.sampling import box_field

    # (each was a numpy, scipy or pathlib error from inside)
    with pytest.raises(js.ParameterError, match=r"lower must be 3 finite coordinates"):
        box_field(10, lower=(0.0, 0.0), upper=(1.0, 1.0, 1.0))
    with pytest.raises(js.ParameterError, match=r"expected one of 'uniform', 'edge'"):
        box_field(10, lower=(0.0, 0.0, 0.0), upper=(1.0, 1.0, 1.0), distribution="gauss")
    with pytest.raises(js.ParameterError, match=r"with NaN or inf"):
        radius_springs(np.full((5, 3), np.nan), 0.1)
    with pytest.raises(js.ParameterError, match=r"swapped"):
        write_body(body, "body.jello")


def test_a_random_box_of_two_or_three_points_is_a_springs_body():
    """`[body] points` allows 2: a random box of 2 or 3 points failed with "cloud_tets needs
    points of shape (n >= 4, 3)" though the springs path needs no tets.  Now it has none; a
    free pair falls as one (gravity only: y drops g t^2 / 2 at both ends, to the scheme's
    error), and the FEM material says it needs tets."""
    import jellysim as js

    for n in (2, 3):
        body = js.Body.box(points=n, distribution="uniform", radius=1.0)
        assert body.point_count == n and len(body.tets) == 0 and len(body.springs) > 0
        sim = js.Simulator(js.finalize(body, stiffness=10.0, point_mass=0.01), dt=1e-3)
        sim.advance(100)
        assert sim.state.x[:, 1] - body.points[:, 1] == pytest.approx(
            -0.5 * 9.8 * 0.1**2, rel=2e-2)
        with pytest.raises(js.JellysimError, match="needs a body with tets"):
            js.physical_model(body, js.material("gelatin"))


def test_gravity_that_does_not_meet_the_ground_is_said():
    """A z-up habit, gravity (0, 0, -9.81) over the y = 0 ground, would slide the body along
    the ground for ever: said, with the y-up fix (session 16's researcher trial); gravity
    tilted 40 deg for a slope, or no ground, is not."""
    import warnings

    import jellysim as js

    body = js.Body.box(upper=(0.02, 0.02, 0.02), points=27)
    ground = js.GroundParams(model="contact", friction=0.3)
    sideways = js.physical_model(body, js.material("gelatin"), gravity=(0.0, 0.0, -9.81))
    with pytest.warns(UserWarning, match=r"does not point down onto the ground.*y is up.*up='z'"):
        js.Simulator(sideways, dt=1 / 60, ground=ground)
    t = np.radians(40.0)
    slope = js.physical_model(body, js.material("gelatin"),
                              gravity=(9.81 * np.sin(t), -9.81 * np.cos(t), 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        js.Simulator(slope, dt=1 / 60, ground=ground)
        js.Simulator(sideways, dt=1 / 60, ground=js.GroundParams(enabled=False))


def test_session_23_trial_mistakes_are_said(tmp_path):
    """From session 23's new-user trial: an empty scene said only "missing section [body]"
    (now: the smallest whole scene and where the keys are listed); a body file whose masses are
    the material's own warned that they were "replaced" by the same 0.5182 kg (now quiet; a
    different total still warns); a grid box's points below 8 said "at least 8 points" of a
    value that counts cells."""
    import warnings

    from jellysim.body import Body
    from jellysim.errors import ParameterError
    from jellysim.geometry.jellyfile import write_body

    (tmp_path / "empty.toml").write_text("")
    with pytest.raises(SceneError, match=r"missing section \[body\].*preset = 'gelatin'.*"
                                         r"scene-help"):
        Scene.load(tmp_path / "empty.toml")
    (tmp_path / "no_int.toml").write_text("[body]\npoints = 10\n[springs]\nstiffness = 1.0\n"
                                          "radius = 0.5\n")
    with pytest.raises(SceneError, match=r"missing section \[integrator\] \(at least dt"):
        Scene.load(tmp_path / "no_int.toml")
    with pytest.raises(ParameterError, match=r"counts the cells"):
        Body.box(points=1)
    scene = ('[material]\npreset = "gelatin"\n[body]\ntype = "file"\npath = "b.jello"\n'
             '[integrator]\nsteps = 1\n')
    (tmp_path / "s.toml").write_text(scene)
    body = Body.box(upper=(0.03, 0.03, 0.03), points=27)
    write_body(tmp_path / "b.jello", body)                      # without masses
    body.masses = Scene.load(tmp_path / "s.toml").build_model().point_mass.copy()
    (tmp_path / "b.jello").unlink()
    write_body(tmp_path / "b.jello", body)                      # with the material's own
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Scene.load(tmp_path / "s.toml").build_model()           # the same masses: quiet
    body.masses = 2.0 * body.masses
    (tmp_path / "b.jello").unlink()
    write_body(tmp_path / "b.jello", body)
    with pytest.warns(UserWarning, match=r"own masses .* replaced by the material"):
        Scene.load(tmp_path / "s.toml").build_model()


def test_a_tiny_body_that_needs_too_many_substeps_is_told_its_size_first():
    """The artist trial: a 0.1 mm mesh read as metres was refused for needing 40,108
    substeps, with fixes (modulus, density, fewer points, 'marching') none of which was the
    real one, although it was already marching.  The substeps go as 1 / size (the smallest
    tet's pressure wave), so a body under 1 cm across is told its size and how to scale it,
    and 'marching' is no longer offered to a marching body."""
    import jellysim as js

    sphere = Path(__file__).parent / "data" / "sphere.obj"
    with pytest.warns(UserWarning):  # (a body under 1 mm is warned of at build: units)
        body = js.Body.from_mesh(sphere, size=1e-4, points=60, base=(0, 0, 0),
                                 connect="marching")
    with pytest.raises(SceneError) as info:
        js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    msg = str(info.value)
    assert re.search(r"the body is only 0\.09\d* mm across", msg) and "[body] size = 0.1" in msg
    assert "connect = 'marching'" not in msg and "youngs_modulus" in msg
    # a body of ordinary size with too stiff a material is not told about its size
    body = js.Body.from_mesh(sphere, size=0.04, points=60, base=(0, 0, 0), connect="delaunay")
    with pytest.raises(SceneError) as info:
        js.Simulator(js.physical_model(body, js.material("gelatin", youngs_modulus=1e12)),
                     dt=1 / 60)
    assert "mm across" not in str(info.value) and "connect = 'marching'" in str(info.value)


GELATIN_BOX = """[material]
preset = "gelatin"
[body]
type = "box"
points = 27
distribution = "grid"
lower = [0.0, 0.0, 0.0]
upper = [0.05, 0.05, 0.05]
[integrator]
steps = 2
"""


@pytest.mark.parametrize("item, said", [
    ("material.youngs_modulus=1e200", r"countless substeps .*beyond floating point"),
    ("material.density=1e-300", r"countless substeps .*beyond floating point"),
    ("body.upper=[1e100,1e100,1e100]", r"1e\+100 m across: .*more than 1e\+06 m is refused"),
    ("body.upper=[1e300,1e300,1e300]", r"1e\+300 m across: .*more than 1e\+06 m is refused"),
])
def test_absurd_numbers_are_one_line_errors_not_tracebacks(tmp_path, item, said):
    """The reliability trial: E = 1e200 or 1e-300 kg/m^3 (the stability estimate overflowed
    to NaN: "cannot convert float NaN to integer" from inside) and a 1e300 m box (an overflow
    inside cKDTree) ended in tracebacks, where 1e20-1e100 gave a clean refusal."""
    scene = tmp_path / "s.toml"
    scene.write_text(GELATIN_BOX)
    res = CliRunner().invoke(cli, ["run", str(scene), "--out", str(tmp_path / "o"), "--quiet",
                                   "--set", item])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    assert re.search(said, res.output), res.output


def test_substeps_auto_as_the_messages_advise_it(tmp_path):
    """The blow-up warning says "substeps >= 8 (or 'auto': [integrator] substeps)", and the
    scene refused substeps = 'auto' as "wrong type": 'auto' is now the default's name."""
    scene = Scene.from_text(GELATIN_BOX + "substeps = 'auto'\n", name="s.toml")
    assert scene.params["integrator"]["substeps"] is None
    assert scene.simulator().substeps == Scene.from_text(GELATIN_BOX).simulator().substeps
    with pytest.raises(SceneError, match=r"substeps = 'many': wrong type; expected an integer "
                                         r">= 1, or 'auto'"):
        Scene.from_text(GELATIN_BOX + "substeps = 'many'\n", name="s.toml")


def test_a_guard_distance_inside_the_body_and_an_absurd_gravity_are_refused(tmp_path):
    """The reliability trial: runaway_distance = 1e-9 m stopped a resting gelatin cube as a
    blow-up ("a body squashed inside out does that") after doubling its substeps three times;
    gravity = [0, -1e300, 0] overflowed into a claim that gravity "does not point down onto
    the ground".  Both are refused at once, naming the key and the allowed range."""
    with pytest.raises(SceneError, match=r"runaway_distance = 1e-09 m: the body's own points "
                                         r"reach 0\.0433 m .*more than 0\.0866 m"):
        Scene.from_text(GELATIN_BOX + "runaway_distance = 1e-9\n", name="s.toml").simulator()
    sim = Scene.from_text(GELATIN_BOX + "runaway_distance = 0.1\n", name="s.toml").simulator()
    assert sim.runaway_distance == 0.1
    with pytest.raises(SceneError, match=r"\[physics\] gravity = \[0.0, -1e\+300, 0.0\]: "
                                         r"out of range; expected three numbers, at most "
                                         r"1e6 m/s\^2"):
        Scene.from_text(GELATIN_BOX + "[physics]\ngravity = [0, -1e300, 0]\n", name="s.toml")


def test_absurdly_stiff_springs_get_their_stable_step_not_an_overflow():
    """The reliability trial: springs of k = 1e200 N/m overflowed the power iteration (its
    vector's squared norm), numpy warned, and the estimate said "stable limit inf s" and ran
    one substep.  The estimate now scales the vector: the limit is 2 / omega_max ~ 4e-102 s,
    the substep count (printed as 2.89e+99) is refused, and nothing overflows on the way."""
    import warnings

    text = ("[body]\npoints = 200\nlower = [0.0, 0.2, 0.0]\nupper = [0.2, 0.4, 0.2]\nseed = 1\n"
            "[springs]\nradius = 0.08\nstiffness = 1e200\n[mass]\npoint_mass = 0.01\n"
            "[integrator]\nname = 'symplectic'\ndt = 0.01\nsteps = 20\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SceneError) as info:
            Scene.from_text(text, name="blow.toml").simulator()
    msg = str(info.value)
    limit = float(re.search(r"stable limit ([0-9.e+-]+) s", msg).group(1))
    model = Scene.from_text(text, name="blow.toml").build_model()
    degree = np.bincount(model.spring_ij.ravel(), minlength=model.point_count).max()
    # omega_max^2 <= Gershgorin's 2 k degree / m (times the estimate's 5 % margin)
    assert 2.0 / np.sqrt(1.05 * 2.0 * 1e200 * degree / 0.01) <= limit < 1e-100
    assert re.search(r"would need \d\.\d+e\+\d+ substeps", msg)


def test_an_empty_mesh_path_is_named_as_empty():
    """The reliability trial: `path = ""` said "<scene folder>/mesh: not a regular file"."""
    with pytest.raises(SceneError, match=r"s\.toml: \[body\] path = '': .*expected a file name"):
        Scene.from_text('[material]\npreset = "gelatin"\n[body]\ntype = "mesh"\npath = ""\n',
                        name="s.toml")


def test_a_near_zero_mass_on_springs_is_refused_not_run_with_contradictory_advice():
    """The re-trial: springs of 50 N/m on points of 1e-300 kg/m^3 overflowed k / m (numpy
    warnings, "omega_max = inf"), the run started with one substep and failed at its first
    step saying "try dt <= 0.005 s (no dt is stable for it)".  Refused at once, naming the
    numbers and the keys; the gelatin path with that density, without a numpy warning."""
    import warnings

    text = ("[body]\npoints = 200\ndistribution = 'uniform'\nlower = [0, 0.1, 0]\n"
            "upper = [0.1, 0.2, 0.1]\n[springs]\nradius = 0.035\nstiffness = 50\n"
            "[mass]\ndensity = 1e-300\n[integrator]\ndt = 0.01\nsteps = 10\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)      # (the density's range is warned)
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(SceneError, match=r"stiffness over the point masses is beyond "
                                             r"floating point \(largest k 50 N/m, smallest "
                                             r"mass .*e-30\d kg\).*\[mass\] density"):
            Scene.from_text(text, name="sp.toml").simulator()
        with pytest.raises(SceneError, match=r"countless substeps"):
            Scene.from_text(GELATIN_BOX.replace('preset = "gelatin"', 'preset = "gelatin"\n'
                                                'density = 1e-300'), name="g.toml").simulator()
