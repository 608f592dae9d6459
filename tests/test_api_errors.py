"""The Python API's answers to mistakes (session 24's new-user trial of the API): a refused
call changes nothing, every error class is a top-level name, and what nothing stops but
nothing can use (duplicate points, a shape held by nothing) is said."""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import jellysim as js
from jellysim import errors


def _gelatin_sim():
    body = js.Body.box(upper=(0.03, 0.03, 0.03), points=27)
    return js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)


@pytest.mark.parametrize("path", [[[1.0, 0.0, 0.0]], [[0.0, 0.1, 0.0, 0.0]],
                                  [[0.0, 0.0, 0.0, 0.0], [1.0, np.nan, 0.0, 0.0]],
                                  [[0.0, 0.0, 0.0, 0.0], [2.0, 0.0, 0.1, 0.0],
                                   [1.0, 0.0, 0.0, 0.0]]])
def test_a_pin_refused_for_its_path_pins_nothing(path):
    """A bad path (wrong row length, a jump at the pinning time, NaN, times going back) is
    refused before any point is pinned, its anchor set or its velocity zeroed."""
    sim = _gelatin_sim()
    sim.state.v[:] = [0.0, -0.5, 0.0]
    v = sim.state.v.copy()
    with pytest.raises(js.SceneError, match=r"pin path"):
        sim.pin([1, 2], path=path)
    assert not np.any(sim.handles.pinned)
    assert sim.handles.paths == []
    np.testing.assert_array_equal(sim.state.v, v)
    x = sim.state.x.copy()
    sim.advance(2)  # and the points fall as free ones: no stray pin holds them
    assert np.all(sim.state.x[[1, 2], 1] < x[[1, 2], 1])


def test_a_pin_path_in_the_past_is_explained():
    """Path times are absolute simulation times: a path asking for an offset at the pinning
    time because its keyframes began earlier says so; one lying wholly before it warns that
    the points are only held."""
    sim = _gelatin_sim()
    sim.advance(3)  # t = 0.05 s
    with pytest.raises(js.SceneError, match=r"times are absolute simulation times: the path's "
                                            r"first keyframe, t = -1 s, is before the pinning"):
        sim.pin([0], path=[[-1.0, 0.01, 0.0, 0.0], [1.0, 0.02, 0.0, 0.0]])
    with pytest.warns(UserWarning, match=r"every keyframe \(the last at t = 0.01 s\) is before "
                                         r"the pinning time t = 0.05 s"):
        sim.pin([0], path=[[-1.0, 0.0, 0.0, 0.0], [0.01, 0.0, 0.0, 0.0]])
    x0 = sim.state.x[0].copy()
    sim.advance(3)
    np.testing.assert_array_equal(sim.state.x[0], x0)  # held where it was pinned


def test_pinning_again_replaces_the_path():
    """The last call wins: a plain pin after a pin along a path holds the points still."""
    sim = _gelatin_sim()
    sim.pin([0], path=[[0.0, 0.0, 0.0, 0.0], [1.0, 0.05, 0.0, 0.0]])
    sim.pin([0])
    x0 = sim.state.x[0].copy()
    sim.advance(6)
    np.testing.assert_array_equal(sim.state.x[0], x0)


def test_every_error_and_warning_class_is_a_top_level_name():
    """What a message's class says can be caught under that name: ``js.SceneError`` ..."""
    names = [n for n in errors.__all__ if n != "did_you_mean"]
    assert {"SceneError", "SimulationError", "ParameterError", "StabilityWarning"} <= set(names)
    for name in names:
        assert getattr(js, name) is getattr(errors, name)
        assert name in dir(js)
    declared = set(re.findall(r"^class (\w+)\(", open(errors.__file__).read(), re.M))
    assert declared == set(names)  # a new class is exported too
    with pytest.raises(js.SceneError):
        js.Simulator(js.finalize(js.Body.box(points=27), stiffness=1.0), dt=-0.01)


def test_duplicate_points_and_a_shape_held_by_nothing_are_said():
    """Two points at one place give a spring of rest length 0 (strain limiting cannot hold
    it): the warning names the spring; a springs body with every stiffness 0 and no strain
    limiting holds no shape: the Simulator says so."""
    from jellysim.geometry.connect import radius_springs

    pts = np.random.default_rng(0).random((50, 3)) * 0.1
    pts[7] = pts[3]
    body = js.Body(points=pts, springs=radius_springs(pts, 0.04))
    with pytest.warns(UserWarning, match=r"1 spring\(s\) join two points at the same position "
                                         r"\(the first: springs\[\d+\] = \[3, 7\]\)"):
        model = js.finalize(body, stiffness=10.0, point_mass=1e-3)
    assert np.sum(model.spring_rest_length == 0.0) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # distinct points, stiff springs: nothing to say
        model = js.finalize(js.Body(points=pts[:7], springs=radius_springs(pts[:7], 0.1)),
                            stiffness=10.0, point_mass=1e-3)
        js.Simulator(model, dt=1e-3)
    limp = js.finalize(js.Body(points=pts[:7], springs=radius_springs(pts[:7], 0.1)),
                       stiffness=0.0, point_mass=1e-3)
    with pytest.warns(UserWarning, match=r"every spring has stiffness 0 N/m and strain "
                                         r"limiting is off: nothing holds the body's shape"):
        js.Simulator(limp, dt=1e-3)
    loose = js.finalize(js.Body(points=pts[:7], springs=np.zeros((0, 2), int)), point_mass=1e-3)
    with pytest.warns(UserWarning, match=r"the body has no springs and strain limiting is off"):
        js.Simulator(loose, dt=1e-3)


def test_the_package_docstring_example_names_a_mesh_that_exists():
    """``help(jellysim)`` opens with an example: the mesh it names loads."""
    from jellysim.geometry import load_mesh

    paths = re.findall(r'from_mesh\("([^"]+)"', js.__doc__)
    assert paths
    for path in paths:
        mesh = load_mesh(path)
        assert len(mesh.faces) > 100


def test_a_scene_says_values_that_likely_mean_another_unit():
    """Valid values a teacher's trial gave in the wrong unit or with the wrong expectation:
    said once each by name; the same scenes without them say nothing."""
    import warnings

    from jellysim.scene import Scene

    base = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
            'lower = [0.0, 0.0, 0.0]\nupper = [0.03, 0.03, 0.03]\n')

    def said(extra):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            Scene.from_text(base + extra, name="lesson.toml")
        return [str(w.message) for w in caught]

    assert said("[integrator]\ndt = 0.005\nsteps = 1\n[ground]\nfriction = 0.6\n") == []
    (dt,) = said("[integrator]\ndt = 16.7\nsteps = 1\n")
    assert dt.startswith("lesson.toml: [integrator] dt = 16.7 s: time steps are in seconds")
    assert "16.7 ms would be 0.0167" in dt
    (mu,) = said("[integrator]\nsteps = 1\n[ground]\nfriction = 30\n")
    assert "[ground] friction = 30 is a coefficient" in mu and "would be 0.3" in mu
    (e,) = said("[integrator]\nsteps = 1\n[ground]\nrestitution = 0.5\n")
    assert "[ground] restitution = 0.5" in e and "damping_ratio" in e
    (drag,) = said("[integrator]\nsteps = 1\n[physics]\ndamping = 0.001\n")
    assert "[physics] damping = 0.001 kg/s" in drag and "damps a finer body more" in drag
    # a sweep's dictionaries are told the same (a researcher's trial: they were not)
    import tomllib

    raw = tomllib.loads(base + "[integrator]\nsteps = 1\n[ground]\nfriction = 30\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Scene.from_dict(raw, name="sweep")
    assert [str(w.message) for w in caught] == [mu.replace("lesson.toml", "sweep")]
    # a value given by --set is said to be (teacher trial, session 28: the warning named the
    # scene file, where it is not), as errors said it
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Scene.from_text(base + "[integrator]\nsteps = 1\n", name="lesson.toml",
                        overrides=("ground.friction=30",))
    assert [str(w.message) for w in caught] == [
        mu + " (given as an override: --set ground.friction=30)"]
    with warnings.catch_warnings(record=True) as caught:  # (the material's own, built later)
        warnings.simplefilter("always")
        Scene.from_text(base + "[integrator]\nsteps = 1\n", name="lesson.toml",
                        overrides=("material.density=1.141",)).build_model()
    said = [str(w.message) for w in caught if "1.141 would be g/cm^3" in str(w.message)]
    assert said and all(s.endswith("(given as an override: --set material.density=1.141)")
                        for s in said)
    # a springs body (no elastic material): e is each point's, as for free particles
    springs = ('[body]\npoints = 27\nlower = [0.0, 0.0, 0.0]\nupper = [0.03, 0.03, 0.03]\n'
               '[springs]\nradius = 0.02\nstiffness = 100.0\n[integrator]\ndt = 0.001\n'
               'steps = 1\n[ground]\nrestitution = 0.5\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        Scene.from_text(springs, name="s.toml")
    assert not [w for w in caught if "restitution" in str(w.message)]


@pytest.mark.parametrize("kw, says", [
    (dict(lower=(0.0, 0.0), upper=(0.1, 0.1)), r"lower must be a corner \(x, y, z\) \[m\], three "
                                               r"numbers, got \(0\.0, 0\.0\)"),
    (dict(upper="0.1"), r"upper must be a corner .* got '0\.1'"),
    (dict(upper=None), r"upper must be a corner .* got None")])
def test_a_box_corner_that_is_not_three_numbers_is_named(kw, says):
    """Notebook trial, session 30: Body.box(lower=(0, 0), ...) raised numpy's "cannot reshape
    array of size 2 into shape (3,)" from inside; now the corner is named."""
    with pytest.raises(errors.ParameterError, match=says):
        js.Body.box(**kw)


@pytest.mark.parametrize("name, value", [("stiffness", "2"), ("density", "1141"),
                                         ("damping", True), ("point_mass", b"1"),
                                         ("stiffness", [1.0, "a"]), ("gravity", (0, "-9.81", 0))])
def test_finalize_refuses_text_where_it_needs_numbers(name, value):
    """Notebook trial, session 30: finalize(body, stiffness='2') made a model (numpy reads the
    text as 2.0), while material(youngs_modulus='10k') was refused; now finalize names the
    parameter, its unit and what it got.  Numbers of any numpy type still pass."""
    body = js.Body.box(points=27, distribution="uniform", radius=0.5, seed=1)
    kw = dict(stiffness=2.0, density=1141.0)
    kw[name] = value
    with pytest.raises(errors.ParameterError, match=rf"finalize: {name} must be numeric \[.*\], "
                                                    r"got .*\((str|bool|bytes|list|tuple)\)"):
        js.finalize(body, **kw)
    model = js.finalize(body, stiffness=np.float32(2.0), density=np.int64(1141), damping=0,
                        gravity=np.array([0.0, -9.81, 0.0]))
    assert model.spring_stiffness.min() == 2.0


def test_every_bad_argument_is_a_parameter_error_and_choices_ignore_case():
    """Notebook trial, session 30: the Simulator's refusals were SceneError, material's and
    finalize's ParameterError; now one ``except ParameterError`` catches both kinds, and a
    choice written in capitals is the same choice."""
    sim = _gelatin_sim()
    for call in (lambda: sim.advance(-1), lambda: js.Simulator(sim.model, dt=0.0),
                 lambda: js.material("gelatin", youngs_modulus=-1.0)):
        with pytest.raises(errors.ParameterError):
            call()
    assert issubclass(errors.SceneError, errors.ParameterError)
    body = js.Body.box(points=27, distribution="uniform", radius=0.5, seed=1)
    model = js.finalize(body, stiffness=20.0, density=1000.0, damping=0.1)
    sims = [js.Simulator(model, dt=1e-3, integrator=name, ground=js.GroundParams(model=g))
            for name, g in (("symplectic", "paper"), ("SYMPLECTIC", "Paper"))]
    assert sims[0].integrator is sims[1].integrator is js.Integrator.SYMPLECTIC
    for sim in sims:
        sim.advance(20)
    np.testing.assert_array_equal(sims[0].state.x, sims[1].state.x)
    with pytest.raises(errors.SceneError, match=r"integrator must be one of"):
        js.Simulator(model, dt=1e-3, integrator="sympl")
    # a scene's choices (a file's value or an override) likewise
    from pathlib import Path

    cube = Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml"
    scenes = [js.Scene.from_file(cube, overrides=[f"integrator.name={name}",
                                                  f"ground.model={g}"])
              for name, g in (("implicit", "contact"), ("Implicit", "CONTACT"))]
    assert scenes[0].params == scenes[1].params
    with pytest.raises(errors.SceneError, match=r"unknown choice"):
        js.Scene.from_file(cube, overrides=["integrator.name=implicitly"])


@pytest.mark.parametrize("given, plain", [("'10kPa'", "10000"), ("'5 cm'", "0.05"),
                                          ("'0.02'", "0.02")])
def test_a_number_written_with_its_unit_is_told_the_plain_si_number(given, plain):
    """Sweep trial, session 30: --set material.youngs_modulus=10kPa was refused as the wrong
    type without the fix; the refusal now gives the SI number to write."""
    from pathlib import Path

    cube = Path(__file__).resolve().parents[1] / "examples" / "gelatin_cube.toml"
    key = "springs.radius" if "cm" in given else "material.youngs_modulus"
    with pytest.raises(errors.SceneError, match=rf"wrong type; expected .*; write {plain} "
                                                r"\(SI units"):
        js.Scene.from_file(cube, overrides=[f"{key}={given}"])
